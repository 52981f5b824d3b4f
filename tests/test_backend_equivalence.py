"""The compiled backend is bit-identical to Amaranth's simulator on whole closed-loop jobs.

Random short jobs (lines and arcs, every accel/decel placement, faults injected) run on both
backends; the JSON reports (wall-clock fields aside) and every trace sample must be equal.
Amaranth's simulator manages a few thousand cycles/s on the whole machine, so each job is
cut off after a few thousand cycles (a "timeout" report, compared like any other).
"""

from __future__ import annotations

import random

import numpy as np
import pytest

from firmware_model.gcode import parse
from firmware_model.job import AXES, Job, MachineConfig, ServoConfig
from sim.run.runner import RunOptions, run_job

WALL_CLOCK = ("wall_seconds", "cycles_per_second", "backend", "skipped_cycles")


def random_job(seed: int, accel: str) -> tuple[Job, dict]:
    rng = random.Random(seed)
    lines = ["G21 G91 F2400"]
    for _ in range(3):
        if rng.random() < 0.5:
            x, y = rng.randint(-40, 40) / 1000, rng.randint(-40, 40) / 1000
            lines.append(f"G01 X{x:.3f} Y{y:.3f}")
        else:
            r = rng.randint(5, 30) / 1000
            lines.append(f"G0{rng.choice((2, 3))} I{r:.3f} J0")
    lines.append("M30")
    machine = MachineConfig(accel=accel, accel_bits=rng.choice((4, 6)), sqrt2=rng.random() < 0.5,
                            accel_fa_hz=250_000.0, alarm_limit=rng.choice((30, 20_000)),
                            encoder_filter=rng.randint(1, 4))
    servo = ServoConfig(kp=rng.uniform(100, 400), tm=rng.uniform(0.0002, 0.002))
    program = parse("\n".join(lines), source=f"<random {seed}>", sqrt2=machine.sqrt2)
    faults = {}
    if rng.random() < 0.5:
        faults[rng.choice(AXES)] = {rng.choice(("stall", "break_a")): 1}
    return Job(f"random-{seed}", machine, dict.fromkeys(AXES, servo), program), faults


def comparable(report: dict) -> dict:
    return {k: v for k, v in report.items() if k not in WALL_CLOCK}


@pytest.mark.parametrize("accel", ["pre", "post", "none"])
@pytest.mark.parametrize("seed", [1, 2])
def test_backends_give_identical_reports_and_traces(accel, seed):
    job, faults = random_job(seed * 10 + len(accel), accel)
    results = {}
    for backend in ("pysim", "cxxrtl"):
        results[backend] = run_job(job, RunOptions(backend=backend, max_cycles=4000,
                                                   sample_every=25, faults=faults))
    py, cc = results["pysim"], results["cxxrtl"]
    assert py.report["backend"] == "pysim" and cc.report["backend"] == "cxxrtl"
    assert comparable(py.report) == comparable(cc.report)
    assert py.samples.shape == cc.samples.shape
    assert len(py.samples) >= 20, "the job must run long enough to compare"
    assert np.array_equal(py.samples, cc.samples)
