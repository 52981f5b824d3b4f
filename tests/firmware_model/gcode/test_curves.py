"""Host side of the K3701's curves: G06 parabolas and G06.1/G06.2 exponentials parsed, checked
and measured."""

from __future__ import annotations

import numpy as np
import pytest

from k37.firmware_model.feeds import FirmwareError, check_program
from k37.firmware_model.gcode.parser import GcodeError, parse
from k37.firmware_model.job import Job, MachineConfig, RunConfig, ServoConfig
from k37.firmware_model.motion.curves import MIN_VERTEX_RADIUS
from k37.firmware_model.motion.program import Exponential, Parabola
from k37.hdl.k3701.block import Block, Kind
from k37.hdl.k3701.model.chip import plan
from k37.sim.run.report import HOW_FIELDS
from k37.sim.run.runner import RunOptions, run_job
from tests.firmware_model.gcode.test_gcode import error_of

PAPER_PARABOLA = "G21 G90 F1000\nG06 X30 Y0 I15 J-15\nM30"


def test_g06_loads_the_contour_error_papers_parabola_as_one_block_ending_exactly():
    (item,) = parse(PAPER_PARABOLA).items
    assert isinstance(item, Parabola)
    assert item.block == Block.parabola(30_000, 0, 15_000, -15_000, sqrt2=True)
    assert item.block.kind is Kind.PARABOLIC and not item.block.swap
    assert item.plan == plan(item.block) and item.plan.end == (30_000, 0)
    assert item.end == (30_000, 0)


def test_g06_tangent_point_is_relative_to_the_start_in_both_distance_modes():
    absolute = parse("G90 G01 X1 Y1 F100\nG06 X31 Y1 I15 J-15").items[1]
    incremental = parse("G91 G01 X1 Y1 F100\nG06 X30 Y0 I15 J-15").items[1]
    assert absolute.block == incremental.block
    assert (absolute.i, absolute.j) == (15_000, -15_000)
    assert absolute.start == (1_000, 1_000)


def test_g06_with_its_axis_parallel_to_x_swaps_the_abscissa():
    (item,) = parse("G21 G91 F500\nG06 X-2 Y-20 I-8 J-10").items
    assert item.block.swap and item.plan.end == (-2_000, -20_000)


def test_g06_is_modal_like_the_other_motion_words():
    items = parse("G21 G91 F500\nG06 X10 Y0 I5 J-2\nX10 Y0 I5 J2").items
    assert [type(it) for it in items] == [Parabola, Parabola]
    assert items[1].start == (10_000, 0)


@pytest.mark.parametrize(("text", "message"), [
    ("G91 F100 G06 X10 Y0", "t.ngc:1:10: G06 needs I and/or J (the tangent point)"),
    ("G91 F100 G06 X10 Y4 I3 J-2", "t.ngc:1:10: the K3701 draws parabolas whose axis is "
                                   "parallel to X or Y"),
    ("G91 F100 G06 X0.02 Y0 I0.01 J-0.01", "t.ngc:1:10: the parabola is too sharp for the "
                                           "K3701: radius of curvature 5.00 LSB"),
    ("G90 F100 G01 Y-8000\nG06 X20 Y-8000 I10 J-1000", "t.ngc:2:1: the parabola leaves the "
                                                      "coordinate range on Y"),
])
def test_g06_errors_name_line_column_and_reason(text, message):
    assert error_of(text).startswith(message)


def test_sharpest_accepted_parabola_has_the_minimum_vertex_radius():
    # A = 20^2 = 400, B = 2 * 0 - 4 * (-3) = 12: radius 400 / 24 = 16.7 LSB.
    (item,) = parse("G91 F100 G06 X0.02 Y0 I0.01 J-0.003").items
    assert item.block.kind is Kind.PARABOLIC
    assert MIN_VERTEX_RADIUS <= 16.7


def test_parabola_distances_measure_the_true_curve_between_its_ends():
    (item,) = parse(PAPER_PARABOLA).items
    curve = item.polyline(301)
    assert np.abs(item.distances(curve)).max() < 1e-6
    # The vertex (15, -15) mm, 5 LSB below it, and a point beyond the end.
    points = np.array([[15_000, -15_005], [30_010, 0]], dtype=float)
    assert item.distances(points) == pytest.approx([5, 10], abs=1e-6)


def test_on_three_axes_curve_distances_count_the_height_off_the_curves_plane():
    line, parabola = parse("G91 F100 G01 Z0.007\n" + PAPER_PARABOLA.split("\n", 1)[1],
                           source="t.ngc", axes=3).items[:2]
    points = np.array([[15_000, -15_005, 7], [15_000, -15_000, 19]], dtype=float)
    assert parabola.start[2] == 7 and line.end[2] == 7
    assert parabola.distances(points) == pytest.approx([5, 12], abs=1e-3)


def test_firmware_refuses_a_parabola_faster_than_the_circular_step_rate():
    machine = MachineConfig()
    program = parse("G21 G91 F3000\nG06 X10 Y0 I5 J-2", source="p.ngc")
    job = Job("p", machine, {"x": ServoConfig(), "y": ServoConfig()}, program,
              RunConfig(strict_feed=True))
    with pytest.raises(FirmwareError, match="above the K3701's maximum for a parabolic block"):
        check_program(job)



#: A parabola; an exponential of X, then a flattening logarithm (an exponential of Y).
CURVE_JOBS = [pytest.param("G21 G91 F2400\nG06 X0.1 Y0 I0.05 J-0.02\nM30", marks=pytest.mark.slow),
              "G21 G91 F2400\nG06.1 X0.03 Y-0.012 K0.03\nG06.2 X-0.02 Y0.025 K-0.02\nM30"]


@pytest.mark.parametrize("gcode", CURVE_JOBS)
def test_curve_job_is_identical_on_pysim_and_cxxrtl_with_idle_skipping(gcode):
    machine = MachineConfig(accel="none")
    program = parse(gcode, source="p.ngc")
    job = Job("p", machine, {"x": ServoConfig(), "y": ServoConfig()}, program)
    results = [run_job(job, RunOptions(backend=backend, max_cycles=2500, sample_every=25,
                                       skip_idle=skip))
               for backend, skip in (("pysim", False), ("cxxrtl", True), ("cxxrtl", False))]
    reports = [{k: v for k, v in r.report.items() if k not in HOW_FIELDS} for r in results]
    assert reports[0] == reports[1] == reports[2]
    assert all(np.array_equal(results[0].samples, r.samples) for r in results[1:])
    assert np.abs(results[0].samples[:, 1]).max() > 20, "the curve must have stepped"


def test_parabola_job_runs_to_its_exact_end_on_cxxrtl():
    job = Job("seed", MachineConfig(), {"x": ServoConfig(), "y": ServoConfig()},
              parse("G21 G90 F1000\nG06 X1 Y0 I0.5 J-0.5\nG04 P0.1\nM30"))
    result = run_job(job, RunOptions(backend="cxxrtl"))
    block = result.report["blocks"][0]
    assert result.report["status"] == "ok" and result.report["end_point"]["reached"]
    assert block["fp_pulses"] == block["fp_budget"] == job.program.items[0].plan.fp
    assert [result.report["axes"][a]["command"] for a in "xy"] == [1000, 0]


def test_g06_1_loads_an_exponential_of_x_ending_exactly():
    (item,) = parse("G21 G91 F500\nG06.1 X20 Y7 K9.618", source="e.ngc").items
    assert isinstance(item, Exponential) and item.code == "G06.1"
    assert item.block.kind is Kind.EXPONENTIAL and not item.block.swap
    assert (item.block.i, item.block.cw) == (9618, False)   # 1 / (e^(1 / 9618) - 1) = 9617.5
    assert item.plan == plan(item.block) and item.end == (20_000, 7_000)
    assert np.abs(item.distances(item.polyline(301))).max() < 1e-6


def test_g06_2_is_the_exponential_of_y_and_k_below_zero_flattens():
    (item,) = parse("G21 G90 F500\nG06.2 X-15 Y-20 K5", source="e.ngc").items
    assert item.code == "G06.2" and item.block.swap
    # p runs towards -Y, so e^(y / K) with K > 0 flattens along p.
    assert item.block.cw and item.end == (-15_000, -20_000)
    curve = item.polyline(5)
    assert curve[0] == pytest.approx([0, 0]) and curve[-1] == pytest.approx([-15_000, -20_000])
    # The logarithm y = K ln(1 + x (e^(ye / K) - 1) / xe) at x = -7.5 mm.
    x = -7_500.0
    y = 5_000 * np.log(1 + x * np.expm1(-20 / 5) / -15_000)
    assert item.distances(np.array([[x, y]])) == pytest.approx([0], abs=2)


@pytest.mark.parametrize(("text", "message"), [
    ("G91 F100 G06.1 X10 Y4", "t.ngc:1:10: G06.1 needs K (the curve's constant)"),
    ("G91 F100 G06.2 X10 Y0 K5", "t.ngc:1:10: G06.2: a logarithm needs a non-zero Y extent"),
    ("G91 F100 G06.1 X0.05 Y0.01 K0.005", "t.ngc:1:10: G06.1: the curve's constant 5 LSB is "
                                          "below the K3701's 8 LSB"),
    ("G91 F100 G06.1 X0.5 Y0.01 K0.02", "t.ngc:1:10: G06.1: the curve grows too fast"),
    ("G91 F100 G06.1 X0.01 Y10 K100", "t.ngc:1:10: G06.1: the curve is too nearly "
                                      "straight"),
    ("G91 F100 G18 G06.1 X1 Z1 K5", "t.ngc:1:14: G06.1 in G18: exponentials are in the XY"),
    ("G91 F100 G06.1 X1 Y1 I1 K5", "t.ngc:1:22: I1: I is only for arcs"),
])
def test_g06_1_errors_name_line_column_and_reason(text, message):
    assert error_of(text).startswith(message)


def test_three_axis_machine_plans_curves_in_xy_ending_exactly():
    program = parse("G21 G91 F100 G01 Z0.5\nG06 X6 Y0 I3 J-2\nG06.1 X5 Y3 K4\n"
                    "G06.2 X5 Y3 K-3", source="t.ngc", axes=3)
    curves = program.items[1:]
    assert [type(it) for it in curves] == [Parabola, Exponential, Exponential]
    assert [it.end for it in curves] == [(6000, 0, 500), (11000, 3000, 500),
                                         (16000, 6000, 500)]
    assert all(it.block.ze == 0 and it.block.plane == 0 for it in curves)


@pytest.mark.parametrize("text", ["G91 F100 G06 X6 Y0 Z1 I3 J-2", "G91 F100 G06.1 X1 Y1 Z-1 K5"])
def test_a_curve_that_moves_z_is_refused_naming_it(text):
    with pytest.raises(GcodeError, match=r"t.ngc:1:10: G06(\.1)?: the curve moves Z by "):
        parse(text, source="t.ngc", axes=3)
