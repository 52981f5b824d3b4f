"""A long program runs to its end with the default limit, which follows its plan."""

from __future__ import annotations

import pytest

from k37.firmware_model.feeds import program_seconds
from k37.sim.run.runner import RunOptions, cycle_limit, run_job

HOUR = 3600.0


@pytest.mark.slow
def test_a_program_of_three_hours_machine_time_runs_to_its_end_with_the_default_limit(
        make_job):
    # Two slow feeds of 100 min each: 1.15e10 cycles, idle between pulses (skipped), so
    # the compiled machine simulates it in seconds. Sampled every 10^6 cycles: the default
    # (every 1000) would store 11.5 million samples, 0.9 GB, which is not what is tested.
    job = make_job("G21 G90\nG01 X20 F0.2\nG01 Y20\nM30")
    assert program_seconds(job) >= 3 * HOUR
    options = RunOptions(backend="cxxrtl", sample_every=1_000_000)
    assert options.max_cycles is None and job.run.max_time_s is None
    report = run_job(job, options).report
    assert report["status"] == "ok", report["reason"]
    assert report["machine_seconds"] >= 3 * HOUR
    assert report["cycles"] < cycle_limit(job, options)[0]
    assert report["end_point"]["program_ran"] and report["end_point"]["reached"]
    assert report["end_point"]["programmed"] == [20_000, 20_000]
    assert [b["end_cycle"] is not None for b in report["blocks"]] == [True, True]
    assert [b["fp_pulses"] for b in report["blocks"]] == [20_000, 20_000]
