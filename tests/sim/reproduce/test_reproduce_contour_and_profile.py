"""The contour-error and profile-error papers in ``k37 reproduce`` (sections 10 and 11): the pure
parts. The closed-loop runs are checked by the quick reproduction (test_reproduce.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from k37.firmware_model.feeds import feed_word, word_rate
from k37.firmware_model.motion.program import Line
from k37.sim.reproduce import contour_error, profile_error, resonance
from k37.sim.reproduce.runs import RunSpec
from k37.sim.reproduce.theory import following_error
from k37.sim.run.ballbar import ballbar_of
from k37.sim.run.sampler import TRACE_COLUMNS


def test_fig_6b_contour_error_vector_is_0_043_where_the_osculating_circle_says_0_377():
    curve = contour_error.Curve.parabola()
    reference = np.array([contour_error.FIG6B["reference"]])
    tool = np.array([contour_error.FIG6B["tool"]])
    u, on_curve = curve.nearest(reference)
    assert on_curve[0] < 1e-3  # the printed reference point is on the parabola
    estimate, (radius, *_) = curve.osculating_estimate(u[0], tool[0])
    assert radius == pytest.approx(contour_error.FIG6B["radius"], abs=1e-3)
    assert estimate == pytest.approx(contour_error.FIG6B["estimate"], abs=2e-3)
    assert curve.nearest(tool)[1][0] == pytest.approx(contour_error.FIG6B["error"], abs=1e-3)


def test_contour_error_vector_is_normal_to_the_curve_and_as_long_as_the_offset():
    curve = contour_error.Curve.bezier(contour_error.BEZIER_MM)
    u = np.linspace(0.05, 0.95, 37)
    tangent = curve.at(u, 1)
    normal = np.column_stack([-tangent[:, 1], tangent[:, 0]]) / np.hypot(*tangent.T)[:, None]
    points = curve.at(u) + 0.3 * normal
    foot, distance = curve.nearest(points)
    assert np.allclose(distance, 0.3, atol=1e-9)
    assert np.allclose(foot, u, atol=1e-9)


def test_bezier_curve_starts_and_ends_at_its_end_points_with_the_polygon_tangents():
    curve = contour_error.Curve.bezier(contour_error.BEZIER_MM)
    ends = curve.at(np.array([0.0, 1.0]))
    assert np.allclose(ends, [contour_error.BEZIER_MM[0], contour_error.BEZIER_MM[-1]])
    assert np.allclose(curve.at(np.array([0.0]), 1)[0],
                       3 * np.subtract(*contour_error.BEZIER_MM[1::-1]))


def test_chords_run_at_60_mm_s_along_their_length_despite_sqrt2_control():
    gcode = contour_error.chords_gcode(contour_error.Curve.bezier(contour_error.BEZIER_MM), 40)
    items = RunSpec("chords", "none", gcode, 1, machine=contour_error.MACHINE).job().program.items
    machine = contour_error.MACHINE
    speed = machine.lsb_per_s(60 * contour_error.SPEED_MM_S)
    lines = [item for item in items if isinstance(item, Line)]
    assert len(lines) == 40 and lines[-1].end[:2] == (0, 0)
    for line in lines:
        seconds = line.plan.fp / word_rate(machine, feed_word(machine, line.feed_mm_min))
        assert math.dist(line.start[:2], line.end[:2]) / seconds == pytest.approx(speed,
                                                                                rel=1e-3)


def test_p_controller_on_the_bezier_curve_averages_table_3s_contour_error():
    # Table 1's linear plant on an exact 60 mm/s reference: Table 3's 0.119 mm.
    curve = contour_error.Curve.bezier(contour_error.BEZIER_MM)
    assert contour_error.ideal_mean_error(curve, dt=2e-3) == pytest.approx(
        contour_error.TABLE3_MEAN, rel=0.05)


def test_eq_9_kf_of_eq_10_leaves_only_the_accel_decel_lag():
    d = profile_error.d_ratio("x")
    assert d == pytest.approx(0.168 / (189 * 0.5))
    assert following_error(16_000, 63.0, kf=1 + d, d_ratio=d, ts=0.028) == pytest.approx(
        0.028 * 16_000)
    assert following_error(16_000, 63.0, d_ratio=d, ts=0.028) == pytest.approx(
        (1 + d) * 16_000 / 63 + 0.028 * 16_000)


def test_ballbar_of_samples_finds_the_ellipse_of_a_lagging_axis():
    spec = RunSpec("circle", "pre", "G17 G21 G91 F600\nG03 I-10 J0\nM30", 1)
    theta = np.linspace(0, 2 * math.pi, 721)
    radius = 10_000 + 3.0 * np.cos(2 * (theta - math.radians(135)))
    samples = np.zeros((len(theta), len(TRACE_COLUMNS)))
    samples[:, 0] = np.arange(len(theta))
    samples[:, TRACE_COLUMNS.index("x_actual")] = radius * np.cos(theta) - 10_000
    samples[:, TRACE_COLUMNS.index("y_actual")] = radius * np.sin(theta)
    report = {"clock_hz": 1e6, "blocks": [{"index": 0, "start_cycle": 0,
                                           "end_cycle": len(theta)}]}
    b = ballbar_of(spec.job(), report, [samples], TRACE_COLUMNS)
    assert b.two_theta_amplitude == pytest.approx(3.0, rel=1e-6)
    assert b.two_theta_angle == pytest.approx(135, abs=0.01)


def test_eq_4_omega_curve_keeps_the_free_mode_and_table_1_ratio_is_the_mass_split():
    base = resonance.table1_drive("x")
    for j_scale in (0.5, 1.0, 3.0):
        k = resonance.jk_curve("x", 206.3, np.array([base.ja * j_scale]))[0]
        drive = resonance.table1_drive("x", j_scale=j_scale, ks_scale=k / base.ks)
        assert drive.free_hz == pytest.approx(206.3, rel=1e-9)
    for axis, row in resonance.TABLE1.items():
        drive = resonance.table1_drive(axis)
        assert drive.held_hz / drive.free_hz == pytest.approx(
            math.sqrt(row.m_prime / (row.m + row.m_prime)))
        assert drive.held_hz / drive.free_hz == pytest.approx(row.ratio, abs=0.01)
