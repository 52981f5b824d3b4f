"""The host's contour controllers: the path geometry, each controller's contour error model,
and the PID with its distributor."""

from __future__ import annotations

import math
from functools import cache

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from k37.firmware_model.contour.controllers import ContourController, derivatives, error_vector
from k37.firmware_model.contour.path import Path, Segment
from k37.firmware_model.gcode.parser import parse
from k37.firmware_model.job import ContourConfig
from k37.sim.run.jobfile import load_job


@cache
def moves(text: str, axes: int = 2):
    return parse("G17 G21 G90\n" + text, source="<t>", lsb_mm=0.001, sqrt2=True,
                 axes=axes).moves


def piece(move, axes: int) -> Segment:
    return Segment(move, axes)


def nearest(segment: Segment, p: np.ndarray) -> tuple[float, np.ndarray]:
    u, q = segment.foot(np.asarray(p, dtype=float)[None])
    return float(u[0]), q[0]


def test_nearest_point_of_a_line_is_the_perpendicular_foot():
    line = piece(moves("G01 X10 Y0 F600")[0], 2)
    u, q = nearest(line, np.array([4000.0, 300.0]))
    assert u == pytest.approx(0.4)
    assert q == pytest.approx([4000.0, 0.0])


def test_nearest_point_beyond_a_line_is_its_end():
    line = piece(moves("G01 X10 Y0 F600")[0], 2)
    assert nearest(line, np.array([12000.0, 50.0]))[1] == pytest.approx([10000.0, 0.0])


@settings(max_examples=25, deadline=None)
@given(st.floats(0.05, 1.95), st.floats(2000.0, 20000.0))
def test_nearest_point_of_an_arc_is_on_the_radius_through_the_point(angle, distance):
    # A CCW half circle of radius 10 mm about the origin, from (10, 0) to (-10, 0).
    arc = piece(moves("G00 X10 Y0\nG03 X-10 Y0 I-10 J0 F600")[1], 2)
    p = distance * np.array([math.cos(angle), math.sin(angle)])
    _, q = nearest(arc, p)
    assert q == pytest.approx(10000 * np.array([math.cos(angle), math.sin(angle)]), abs=1e-4)


@settings(max_examples=25, deadline=None)
@given(st.floats(0.0, 30.0), st.floats(-3.0, 3.0))
def test_nearest_point_of_a_parabola_agrees_with_a_dense_search(x_mm, offset_mm):
    # The K3701's parabola through (0, 0), tangent point (15, -15) and (30, 0) (mm).
    curve = piece(moves("G06 X30 Y0 I15 J-15 F600")[0], 2)
    dense = curve.at(np.linspace(0.0, 1.0, 20_001))  # about 2 LSB apart
    p = np.array([x_mm * 1000, ((x_mm - 15) ** 2 / 15 - 15) * 1000 + offset_mm * 1000])
    u, q = nearest(curve, p)
    best = float(np.min(np.hypot(*(dense - p).T)))
    # never farther than the dense search's best, but for the golden search's own precision
    # (0.618^40 of two grid spacings: about 1e-5 LSB along this curve; a point on the curve
    # is that far from it, not its square)
    assert math.dist(q, p) <= best + 1e-4
    _, tangent, _ = derivatives(curve, u)
    scale = 1e-4 * np.linalg.norm(tangent) * max(1.0, math.dist(q, p))  # 1e-4 LSB along
    assert u in (0.0, 1.0) or abs((q - p) @ tangent) <= scale  # eq. (4) holds


def test_a_helix_rises_in_proportion_to_the_angle():
    helix = piece(moves("G00 X10 Y0\nG03 X-10 Y0 Z4 I-10 J0 F600", axes=3)[1], 3)
    assert helix.at(np.array([0.5]))[0] == pytest.approx([0.0, 10000.0, 2000.0], abs=1e-6)


def test_every_model_is_the_perpendicular_on_a_line():
    path = Path(moves("G01 X10 Y10 F600")[:1], 2)
    reference, actual = np.array([5000.0, 5000.0]), np.array([3000.0, 3200.0])
    exact = np.array([100.0, -100.0])  # to the foot (3100, 3100)
    for controller in ("ccc", "vgccc", "cec"):
        assert error_vector(controller, path, 0, reference, actual) == pytest.approx(exact)


def test_on_a_circle_the_models_differ_as_the_paper_says():
    # Tool 1 mm outside a radius-10 circle, lagging the reference by a quarter turn.
    arc = Path(moves("G00 X10 Y0\nG03 X10 Y0 I-10 J0 F600")[1:], 2)
    reference = np.array([0.0, 10000.0])  # the centre is the origin
    actual = np.array([11000.0, 0.0])
    cec = error_vector("cec", arc, 0, reference, actual)
    vgccc = error_vector("vgccc", arc, 0, reference, actual)
    ccc = error_vector("ccc", arc, 0, reference, actual)
    assert cec == pytest.approx([-1000.0, 0.0], abs=1e-3)  # the true contour error
    assert vgccc == pytest.approx([-1000.0, 0.0], abs=1)   # the osculating circle is the path
    assert ccc == pytest.approx([0.0, 10000.0], abs=1)  # to the tangent line at the reference


def test_the_pid_integrates_and_differentiates_the_error_vector():
    config = ContourConfig(controller="cec", kcp=2.0, kci=10.0, kcd=0.1)
    controller = ContourController(config, moves("G01 X10 Y0 F600"), 2, 0.001)
    first = controller.correction(0, [5000, 0], [5000, -10])   # 10 LSB below the line
    assert first == pytest.approx([0.0, 2 * 10 + 10 * 10 * 0.001])
    second = controller.correction(0, [6000, 0], [6000, -4])
    assert second == pytest.approx([0.0, 2 * 4 + 10 * 14 * 0.001 + 0.1 * (4 - 10) / 0.001])


def test_a_controller_needs_a_choice():
    with pytest.raises(ValueError, match="controller other than 'none'"):
        ContourController(ContourConfig(), moves("G01 X1 F600"), 2, 0.001)
    with pytest.raises(ValueError, match="controller must be one of"):
        ContourConfig(controller="pid")


def test_the_contour_table_reaches_the_job(tmp_path):
    path = tmp_path / "job.toml"
    path.write_text('[contour]\ncontroller = "vgccc"\nperiod_ms = 2\nkcp = 3\nkci = 0\n'
                    'kcd = 0.1\n[program]\ngcode = "G01 X1 F100"\n')
    job = load_job(path)
    assert job.contour == ContourConfig("vgccc", 2.0, 3.0, 0.0, 0.1)
    assert job.to_dict()["contour"]["controller"] == "vgccc"
