"""The companion papers' sections of ``k37 reproduce``: the formulas their rows check.

The filters paper's recursion eq (35) against the accel/decel circuit's reference model, the
motion-errors paper's radius-loss formulas and mismatch ellipse, the L16 array, and the filter and
servo models the corner test is compared with. The closed-loop rows run in
``test_reproduce.py``.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from k37.firmware_model.job import MachineConfig
from k37.sim.reproduce.circle_error import (
    LEVELS,
    conditions,
    exact_loss,
    mismatch_ellipse,
    paper_loss,
)
from k37.sim.reproduce.filters import circuit_outputs, recursion_35
from k37.sim.reproduce.theory import accel_filter, mismatch_amplitude, moving_average, servo
from k37.sim.study.analysis import response_surface


def test_recursion_35_is_a_first_order_lag_of_2_to_the_n_additions():
    out = recursion_35(np.ones(200), 4)
    left = (1 - 1 / 16) ** np.arange(1, 201)
    assert out == pytest.approx(1 - left)
    assert out.sum() == pytest.approx(200 - 15 * (1 - left[-1]))


@pytest.mark.parametrize(("bits", "rate"), [(6, 20_000.0), (8, 90_000.0)])
def test_the_exponential_circuit_equals_recursion_35_within_one_pulse(bits, rate):
    machine = MachineConfig(accel="post", accel_bits=bits, accel_fa_hz=200_000.0)
    tau = 2**bits / machine.accel_fa_hz
    inputs, circuit = circuit_outputs(machine, rate, 3 * tau, 8 * tau)
    gap = np.abs(np.cumsum(circuit) - np.cumsum(recursion_35(inputs, bits)))
    assert gap.max() < 1


@pytest.mark.parametrize("shape", ["exponential", "linear"])
def test_eqs_9_and_10_are_the_second_order_terms_of_the_exact_radius_loss(shape):
    radius, kp, tm, tau = 100_000.0, 30.0, 0.004, 0.03
    for speed in (1000.0, 3000.0):
        exact = exact_loss(shape, radius, speed, kp, tm, tau)
        assert paper_loss(shape, radius, speed, kp, tau, tm) == pytest.approx(exact, rel=1e-3)
    # As printed (no velocity lag), the servo term is 1 / (1 - 2 Kp Tm) too large.
    assert paper_loss(shape, radius, 1000.0, kp, 0.0) == pytest.approx(
        exact_loss(shape, radius, 1000.0, kp, tm, 0.0) / (1 - 2 * kp * tm), rel=1e-3)


def test_a_slower_x_axis_bulges_a_ccw_circle_at_45_and_225_degrees():
    radius, speed = 100_000.0, 2000.0
    b = mismatch_ellipse("exponential", radius, speed, (30.0, 39.0), 0.0, 0.0)
    assert b.two_theta_angle == pytest.approx(45, abs=1)
    assert b.two_theta_amplitude == pytest.approx(
        mismatch_amplitude(speed, 1 / 30, 1 / 39), rel=0.01)
    swapped = mismatch_ellipse("exponential", radius, speed, (39.0, 30.0), 0.0, 0.0)
    assert swapped.two_theta_angle == pytest.approx(135, abs=1)


def test_the_l16_runs_are_table_1_levels_with_every_pair_of_levels_once():
    runs = conditions()
    assert len(runs) == 16
    names = list(LEVELS)
    for a, b in itertools.combinations(names, 2):
        pairs = {(getattr(r, a), getattr(r, b)) for r in runs}
        assert pairs == set(itertools.product(LEVELS[a], LEVELS[b]))


def test_full_feedforward_removes_the_steady_following_error():
    t = np.linspace(0, 1, 2001)
    command = 10_000.0 * t
    assert (command - servo(t, command, 30.0, 0.01))[-1] == pytest.approx(10_000 / 30, rel=1e-3)
    assert abs((command - servo(t, command, 30.0, 0.01, kf=1.0))[-1]) < 1e-6


def test_the_linear_filter_delays_a_ramp_by_half_its_window():
    t = np.linspace(0, 1, 1001)
    ramp = 5000.0 * np.maximum(t - 0.1, 0)
    delayed = moving_average(t, ramp, 0.03)
    assert delayed[-1] == pytest.approx(ramp[-1] - 5000 * 0.015, rel=1e-9)
    assert accel_filter("linear", t, ramp, 0.03) == pytest.approx(delayed)
    late = t > 0.6
    exponential = accel_filter("exponential", t, ramp, 0.03)
    assert (ramp - exponential)[late] == pytest.approx(5000 * 0.03 * np.ones(late.sum()),
                                                       rel=1e-6)
    assert math.isclose(float(moving_average(t, ramp, 0.03)[0]), 0.0)


@pytest.mark.parametrize(("signs", "kind"), [((1, 1), "minimum"), ((-1, -1), "maximum"),
                                              ((1, -1), "saddle")])
def test_the_response_surface_names_its_stationary_point(signs, kind):
    rows = [{"a": str(a), "b": str(b), "y": str(signs[0] * (a - 1) ** 2 + signs[1] * b**2)}
            for a, b in itertools.product((-2.0, 0.0, 1.0, 3.0), repeat=2)]
    fit = response_surface(rows, ("a", "b"), "y")
    assert fit.kind == kind
    assert fit.stationary == pytest.approx((1.0, 0.0), abs=1e-9)
