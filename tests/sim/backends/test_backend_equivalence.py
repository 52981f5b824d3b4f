"""The compiled backend and the engine are bit-identical to Amaranth's simulator on whole
closed-loop jobs.

Random short jobs (lines and arcs, every accel/decel placement, faults injected) run on every
backend; the JSON reports (wall-clock fields aside) and every trace sample must be equal.
Amaranth's simulator manages a few thousand cycles/s on the whole machine, so each job is
cut off after a few thousand cycles (a "timeout" report, compared like any other).
"""

from __future__ import annotations

import numpy as np
import pytest

from k37.sim.run.report import HOW_FIELDS
from k37.sim.run.runner import RunOptions, run_job


def comparable(report: dict) -> dict:
    return {k: v for k, v in report.items() if k not in HOW_FIELDS}


@pytest.mark.parametrize("accel", ["pre", "post", "none"])
@pytest.mark.parametrize("seed", [pytest.param(1, marks=pytest.mark.slow), 2])
def test_backends_give_identical_reports_and_traces(accel, seed, random_moves):
    job, faults, _ = random_moves(seed * 10 + len(accel), accel, dwell=False)
    same_on_every_backend(job, faults)


#: The torque drive with every term (a 1 ms velocity loop, so that any Kp is stable).
TORQUE = {"drive": "torque", "vg": 2.0, "kf": 0.6, "ti": 0.01, "d": 0.02, "fc": 0.002,
          "load": 0.001}


@pytest.mark.parametrize(("accel", "shape", "axis_shapes", "servo"), [
    ("post", "linear", {"y": "bell"}, {"kf": 0.7}),
    ("pre", "exponential", None, TORQUE),
    pytest.param("pre", "bell", None, None, marks=pytest.mark.slow)])
def test_backends_agree_with_linear_and_bell_circuits_feedforward_and_the_torque_drive(
        accel, shape, axis_shapes, servo, random_moves):
    job, faults, _ = random_moves(3, accel, dwell=False, shape=shape, axis_shapes=axis_shapes,
                                  servo=servo)
    same_on_every_backend(job, faults)


def test_backends_agree_with_each_axis_on_its_own_addition_clock(random_moves):
    job, faults, _ = random_moves(7, "post", dwell=False, axis_shapes={"y": "linear"},
                                  axis_fa=("x", "y"))
    assert job.fa_axes() == ("x", "y")
    same_on_every_backend(job, faults)


#: The two-mass drive with every term, its encoder a linear scale on the table (138 Hz free).
TWO_MASS = {**TORQUE, "drive": "two_mass", "cs": 2000.0, "scale": True}


@pytest.mark.parametrize("servo", [TWO_MASS, {**TWO_MASS, "scale": False, "ti": 0.0}])
def test_backends_agree_with_the_two_mass_drive(servo, random_moves):
    job, faults, _ = random_moves(5, "pre", dwell=False, servo=servo)
    assert job.servo["x"].drive == "two_mass"
    same_on_every_backend(job, faults)


def same_on_every_backend(job, faults) -> None:
    """``job`` gives equal reports and samples on Amaranth's simulator, the compiled RTL and
    the engine."""
    results = {}
    for backend in ("pysim", "cxxrtl", "engine"):
        results[backend] = run_job(job, RunOptions(backend=backend, max_cycles=4000,
                                                   sample_every=25, faults=faults))
        assert results[backend].report["backend"] == backend
    py = results["pysim"]
    assert len(py.samples) >= 20, "the job must run long enough to compare"
    for other in (results["cxxrtl"], results["engine"]):
        assert comparable(py.report) == comparable(other.report)
        assert py.samples.shape == other.samples.shape
        assert np.array_equal(py.samples, other.samples)
