"""The closed loop: chipset + plants + firmware, checked against physics and the program.

These runs are millions of cycles, so they use the compiled backend (built once per accel
placement and cached); the compiled backend is itself checked against Amaranth's simulator
in ``tests/sim/backends/test_backend_equivalence.py``.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from k37.firmware_model.feeds import FirmwareError, check_program
from k37.firmware_model.job import RunConfig
from k37.sim.run.jobfile import load_job
from k37.sim.run.runner import RunOptions, build_backend, run_job
from k37.sim.run.sampler import TRACE_COLUMNS

COL = {name: k for k, name in enumerate(TRACE_COLUMNS)}


def run(path: Path, **options) -> object:
    return run_job(load_job(path), RunOptions(backend="cxxrtl", **options))


def test_constant_feed_settles_to_following_error_feed_over_kp(job_file):
    # 600 mm/min = 10 mm/s = 1e4 LSB/s on X alone, no accel/decel: error -> 1e4 / 30.
    path = job_file("G21 G90 G01 X20 F600\nM30", machine='accel = "none"',
                    servo="kp = 30.0\ntm = 0.01")
    result = run(path, sample_every=500)
    assert result.ok, result.report["alarms"]
    s = result.samples
    t = s[:, COL["cycle"]] / 1e6
    steady = (t > 0.5) & (t < 1.8)
    mean_error = s[steady, COL["x_error"]].mean()
    assert mean_error == pytest.approx(1e4 / 30.0, rel=0.02)
    assert result.report["axes"]["x"]["max_abs_error"] == pytest.approx(1e4 / 30, rel=0.05)


def test_full_circle_returns_exactly_to_its_start(job_file):
    path = job_file("G21 G90 F1200\nG03 I-5 J0\nG04 P0.5\nM30")
    result = run(path, sample_every=2000)
    r = result.report
    assert r["status"] == "ok", r["alarms"]
    assert r["blocks"][0]["end_command"] == [0, 0]
    for axis in ("x", "y"):
        assert r["axes"][axis]["command"] == 0
        assert r["axes"][axis]["actual"] == 0
        assert r["axes"][axis]["error"] == 0
    # FP control keeps the programmed shape; what remains is the servo's steady-state
    # radius loss at full speed: R (1 - |G(jw)|), G(s) = Kp / (s (1 + s Tm) + Kp), w = v / R.
    radius, v, kp, tm = 5000, 1200 / 60 / 0.001, 30.0, 0.01
    w = v / radius
    expected = radius * (1 - kp / abs(complex(kp - w * w * tm, w)))
    assert r["path"]["max_contour_error"] == pytest.approx(expected, rel=0.1, abs=1.0)


def test_square_with_g01_corners_ends_each_block_at_its_corner(job_file):
    corners = [(5000, 0), (5000, 5000), (0, 5000), (0, 0)]
    path = job_file("G21 G90 F900\nG01 X5\nY5\nX0\nY0\nG04 P0.5\nM30")
    result = run(path, sample_every=2000)
    r = result.report
    assert r["status"] == "ok", r["alarms"]
    assert [b["end_command"] for b in r["blocks"]] == [list(c) for c in corners]
    for block in r["blocks"]:
        assert block["fp_pulses"] == block["fp_budget"]
    assert [r["axes"][a]["actual"] for a in ("x", "y")] == [0, 0]


def test_actual_position_is_command_minus_error_at_every_sample(job_file):
    """The K3702's command - error is the plant's encoder count, a fixed few cycles late."""
    path = job_file("G21 G91 F900\nG01 X0.6 Y-0.3\nG01 X-0.2 Y0.4\nG04 P0.05\nM30",
                    machine='accel = "none"')
    result = run(path, sample_every=1)
    s = result.samples.astype(np.int64)
    moved = s[:, COL["x_command"]] - s[:, COL["x_error"]]
    count = s[:, COL["x_actual"]]
    assert np.ptp(count) > 100, "the axis must actually move"
    lags = [lag for lag in range(12)
            if np.array_equal(moved[lag:], count[:len(count) - lag])]
    assert lags, "command - error never matched the encoder count at a fixed latency"
    lag = lags[0]
    for axis in ("x", "y"):
        moved = s[:, COL[f"{axis}_command"]] - s[:, COL[f"{axis}_error"]]
        assert np.array_equal(moved[lag:], s[:len(s) - lag, COL[f"{axis}_actual"]])
    # And at rest they are equal outright.
    assert moved[-1] == s[-1, COL["y_actual"]]


def test_stalled_axis_raises_the_alarm_and_the_feed_stops(job_file):
    path = job_file("G21 G90 F600\nG01 X50\nM30",
                    machine='accel = "none"\nalarm_limit = 1500')
    job = load_job(path)
    backend = build_backend(job, "cxxrtl")
    result = run_job(job, RunOptions(sample_every=1000, faults={"x": {"stall": 1}}), backend)
    r = result.report
    assert r["status"] == "alarm"
    assert r["alarms"][0]["axis"] == "x" and r["alarms"][0]["kind"] == "alarm"
    assert r["axes"]["x"]["actual"] == 0
    assert r["axes"]["x"]["error"] > 1500
    # The interrupt routine stopped the feed: no further FP reaches the interpolator.
    fp = backend.get("fp_total")
    backend.step(200_000)
    assert backend.get("fp_total") == fp
    backend.close()


def test_k37_run_exits_non_zero_with_the_alarm_in_the_json(job_file, k37):
    path = job_file("G21 G90 F600\nG01 Y30\nM30",
                    machine='accel = "none"\nalarm_limit = 1000')
    out = k37("run", str(path), "--stall", "y", "--json", "-", "--backend", "cxxrtl",
              "--sample-every", "5000")
    assert out.returncode == 1
    report = json.loads(out.stdout)
    assert report["status"] == "alarm"
    assert report["alarms"][0]["axis"] == "y"


@pytest.mark.parametrize(("content", "message"), [
    ("[machine]\nacel = 'pre'\n[program]\ngcode = 'M30'\n", "unknown key machine.acel"),
    ("[machine]\naxes = 2\n[program]\ngcode = 'G01 X1 Z3 F100'\n", "Z3 moves Z"),
    ("[program]\ngcode = 'G01 X1'\n", "F"),
    ("[machine\n", "job.toml:1"),
    ("[program]\ngcode = 'G01 X9000 F100'\n", "outside"),
    ("[program]\ngcode = 'G02 X0 Y0 I5 J0 F4000'\n[run]\nstrict_feed = true\n",
     "above the K3701's maximum"),
])
def test_bad_jobs_give_one_error_line_and_no_traceback(tmp_path, content, message, k37):
    path = tmp_path / "job.toml"
    path.write_text(content)
    out = k37("run", str(path))
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1, out.stderr
    assert lines[0].startswith("k37: error:") and message in lines[0]
    assert "Traceback" not in out.stderr


def test_feed_above_the_interpolator_maximum_is_refused_before_loading(job_file):
    job = load_job(job_file("G21 G90 G02 X0 Y0 I5 J0 F4000\nM30"))
    job = replace(job, run=RunConfig(strict_feed=True))
    # the F word's line and column in the job file (the inline program starts on line 2)
    with pytest.raises(FirmwareError, match=r"job.toml:7:25: feed 4000 mm/min is "
                                            r"above the K3701's maximum for an arc, 2857.*"
                                            r"lower F4000, or raise machine.clock_hz or "
                                            r"machine.lsb_mm \(run.strict_feed = false "
                                            r"clamps it to the maximum\)$"):
        check_program(job)
