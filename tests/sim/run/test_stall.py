"""A run that stops making progress ends as ``stalled``, naming its block and line; slow feeds,
dwells and the accel/decel circuit's tail are progress, not stalls."""

from __future__ import annotations

import numpy as np

from k37.firmware_model.feeds import feed_word, run_feed, word_rate
from k37.firmware_model.job import MachineConfig
from k37.sim.run import runner
from k37.sim.run.report import RUN_SCHEMA
from k37.sim.run.runner import RunOptions, run_job
from k37.sim.run.sampler import PROGRESS_CYCLES
from k37.sim.run.stall import STALL_SECONDS, stall_seconds


def test_a_block_short_of_one_feed_pulse_ends_stalled_naming_its_block_and_line(make_job):
    # One FP less than the block needs: the feed stops and the K3701 waits for ever.
    job = make_job("G21 G90 F600\nG01 X1\nG01 X2\nM30", source="part.ngc")
    result = run_job(job, RunOptions(backend="cxxrtl", budget_offset=-1))
    report = result.report
    assert report["status"] == "stalled"
    assert not result.ok
    assert report["reason"].startswith("stalled in block 0 (part.ngc:2): no feed pulse and no "
                                       "axis motion from cycle ")
    window = stall_seconds(job, job.program.moves[0]) * job.machine.clock_hz
    block = report["blocks"][0]
    assert block["end_cycle"] is None
    # The axis stops one LSB short, the feed one FP short; the stall is seen within the
    # window and two ticks after that, far before the program's limit.
    samples = result.traces
    assert samples["x_actual"][-1] == samples["fp_total"][-1] == 999
    moved = samples["cycle"][np.flatnonzero(np.diff(samples["x_actual"]))[-1] + 1]
    assert moved + window <= report["cycles"] <= moved + window + 2 * PROGRESS_CYCLES
    assert report["cycles"] < runner.cycle_limit(job, RunOptions())[0]
    assert len(report["blocks"]) == 1 and report["end_point"]["program_ran"] is False


def test_the_stall_status_is_in_the_reports_schema():
    assert "stalled" in RUN_SCHEMA["properties"]["status"]["enum"]


def test_the_stall_window_covers_the_slowest_feed_and_the_accel_tail(make_job):
    machine = MachineConfig()
    job = make_job("G21 G90 F0.03\nG01 X0.003\nM30", machine)
    move = job.program.moves[0]
    gap = 1 / word_rate(machine, feed_word(machine, run_feed(move, machine)))
    assert stall_seconds(job, move) == STALL_SECONDS + 2 * gap + 4 * machine.tau_s
    assert stall_seconds(job, move) > 2 * gap > STALL_SECONDS


def test_a_feed_of_one_pulse_every_few_seconds_is_not_a_stall(make_job):
    job = make_job("G21 G90 F0.03\nG01 X0.003\nM30")  # 3 FP, about 2 s apart
    report = run_job(job, RunOptions(backend="cxxrtl")).report
    assert report["status"] == "ok", report["reason"]
    assert report["machine_seconds"] > STALL_SECONDS


def test_a_long_dwell_between_blocks_is_not_a_stall(make_job):
    job = make_job("G21 G90 F600\nG01 X0.1\nG04 P6\nG01 X0\nM30")
    report = run_job(job, RunOptions(backend="cxxrtl")).report
    assert report["status"] == "ok", report["reason"]
    assert report["machine_seconds"] > 6
