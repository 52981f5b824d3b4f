"""The three-axis machine (``machine.axes = 3``) end to end: 3-D lines, arcs in the G17, G18
and G19 planes and helices through firmware, chipset and plants; the compiled backend and the
engine equal to Amaranth's simulator, idle skipping exact; the job key and the automatic
choice of axes."""

from __future__ import annotations

import json

import numpy as np
import pytest

from k37.firmware_model.gcode.parser import GcodeError
from k37.firmware_model.job import MachineConfig, gcode_job
from k37.sim.run.runner import RunOptions, run_job
from tests.sim.backends.test_backend_equivalence import comparable
from tests.sim.backends.test_idle_skip import skipped_equals_stepped

#: Every kind of three-axis move, each ending on its programmed point.
PROGRAM = """G21 G90 F900
G01 X0.4 Y0.2 Z0.15
G18 G02 X0.6 Z0.35 I0.1 K0.1
G19 G03 Y0.35 Z0.2 J0 K-0.15
G17 G02 I0.1 J0 Z-0.05
G00 X0 Y0 Z0
M30
"""


def test_a_program_that_moves_z_gets_three_axes_and_ends_every_block_on_its_point():
    job = gcode_job("z", PROGRAM, "<z>")
    assert job.machine.axes == 3 and list(job.servo) == ["x", "y", "z"]
    result = run_job(job, RunOptions(backend="cxxrtl"))
    r = result.report
    assert r["status"] == "ok" and r["end_point"]["reached"]
    moves = list(job.program.items)
    assert [b["end_command"] for b in r["blocks"]] == [list(it.end) for it in moves]
    assert [b["fp_pulses"] for b in r["blocks"]] == [it.plan.fp for it in moves]
    helix = r["blocks"][3]["steps"]
    assert helix["z-"] - helix["z+"] == 250 and r["path"]["max_contour_error"] < 30
    assert result.store.columns[:4] == ("cycle", "x_command", "y_command", "z_command")


def test_a_program_in_the_xy_plane_keeps_the_papers_two_axes():
    job = gcode_job("xy", "G21 G90 F600\nG01 X1 Y1\nM30", "<xy>")
    assert job.machine.axes == 2 and job.program.final_position == (1000, 1000)


@pytest.mark.parametrize("curve", ["G06 X6 Y0 I3 J-2", "G06.1 X5 Y3 K4", "G06.2 X5 Y3 K-3"])
def test_a_curve_in_the_xy_plane_keeps_two_axes(curve):
    job = gcode_job("curve", f"G21 G90 F300\n{curve}\nM30", "<curve>")
    assert job.machine.axes == 2 and job.program.items[0].end[:2] in ((6000, 0), (5000, 3000))


#: Parabolas and exponentials between moves of Z: the three-axis machine runs them in XY.
CURVES_AND_Z = """G21 G90 F300
G01 Z0.2
G06 X3 Y0 I1.5 J-1
G01 Z0.4
G06.1 X5.5 Y1.5 K2
G06.2 X8 Y3 K-1.5
G00 X0 Y0 Z0
M30
"""


def test_curves_in_a_program_that_moves_z_run_on_three_axes_ending_on_their_points():
    job = gcode_job("both", CURVES_AND_Z, "<both>")
    assert job.machine.axes == 3
    r = run_job(job, RunOptions(backend="cxxrtl")).report
    assert r["status"] == "ok" and r["end_point"]["reached"]
    moves = list(job.program.items)
    assert [b["kind"] for b in r["blocks"]] == [
        "linear", "parabolic", "linear", "exponential", "exponential", "linear"]
    assert [b["end_command"] for b in r["blocks"]] == [list(it.end) for it in moves]
    assert [b["fp_pulses"] for b in r["blocks"]] == [it.plan.fp for it in moves]
    assert moves[4].end == (8000, 3000, 400)
    assert r["path"]["max_contour_error"] < 10  # measured against the curves in space


def test_a_job_file_of_curves_on_a_three_axis_machine_runs_them_to_their_ends(job_file, k37):
    path = job_file("G21 G90 F300\nG06 X3 Y0 I1.5 J-1\nG06.2 X5.5 Y1.5 K-1.5\nM30",
                    machine="axes = 3")
    done = k37("run", "-q", "--json", "-", str(path))
    assert done.returncode == 0, done.stderr
    report = json.loads(done.stdout)
    assert "z" in report["axes"] and report["end_point"]["reached"]
    assert [(b["kind"], b["end_command"]) for b in report["blocks"]] == [
        ("parabolic", [3000, 0, 0]), ("exponential", [5500, 1500, 0])]


def test_a_curve_that_moves_z_is_refused_on_the_three_axis_machine():
    with pytest.raises(GcodeError, match=r"^<z>:2:1: G06: the curve moves Z by 1.000 mm: the "
                                         r"K3701's curves stay in their plane \(move Z with a "
                                         r"line\)$"):
        gcode_job("z", "G21 G90 F300\nG06 X6 Y0 Z1 I3 J-2\nM30", "<z>")


@pytest.mark.parametrize("accel", ["pre", pytest.param("post", marks=pytest.mark.slow),
                                   pytest.param("none", marks=pytest.mark.slow)])
def test_backends_give_identical_reports_and_traces_on_three_axes(accel, random_moves):
    job, faults, _ = random_moves(7 + len(accel), accel, dwell=False, axes=3)
    results = {backend: run_job(job, RunOptions(backend=backend, max_cycles=4000,
                                                sample_every=25, faults=faults))
               for backend in ("pysim", "cxxrtl", "engine")}
    py, cc, engine = results["pysim"], results["cxxrtl"], results["engine"]
    assert comparable(py.report) == comparable(cc.report) == comparable(engine.report)
    assert "z" in py.report["axes"] and len(py.samples) >= 20
    assert np.array_equal(py.samples, cc.samples)
    assert np.array_equal(py.samples, engine.samples)


@pytest.mark.parametrize("seed", [13, pytest.param(18, marks=pytest.mark.slow)])
def test_backends_give_identical_reports_and_traces_on_three_axes_with_curves(seed,
                                                                              random_moves):
    job, faults, _ = random_moves(seed, "pre", dwell=False, axes=3, curves=True)
    kinds = {type(item).__name__ for item in job.program.moves}
    assert {"Parabola", "Exponential"} <= kinds and job.machine.axes == 3
    results = {backend: run_job(job, RunOptions(backend=backend, max_cycles=60_000,
                                                sample_every=25, faults=faults))
               for backend in ("pysim", "cxxrtl", "engine")}
    py, cc, engine = results["pysim"], results["cxxrtl"], results["engine"]
    assert comparable(py.report) == comparable(cc.report) == comparable(engine.report)
    assert [b["kind"] for b in py.report["blocks"]][-2:] == ["parabolic", "exponential"]
    assert np.array_equal(py.samples, cc.samples)
    assert np.array_equal(py.samples, engine.samples)


@pytest.mark.parametrize(("accel", "seed"), [
    ("pre", 3), pytest.param("post", 4, marks=pytest.mark.slow),
    pytest.param("none", 5, marks=pytest.mark.slow)])
def test_skipping_idle_cycles_changes_no_signal_of_the_three_axis_machine(accel, seed,
                                                                         random_moves):
    job, faults, dwell = random_moves(seed, accel, dwell=True, axes=3)
    _, skipped = skipped_equals_stepped(job, faults, 10_007)
    assert skipped[3] > 0.5 * dwell * job.machine.clock_hz


def test_skipping_idle_cycles_changes_no_signal_of_a_three_axis_machine_drawing_curves(
        random_moves):
    job, faults, dwell = random_moves(13, "pre", dwell=True, axes=3, curves=True)
    assert {"Parabola", "Exponential"} <= {type(it).__name__ for it in job.program.moves}
    _, skipped = skipped_equals_stepped(job, faults, 10_007)
    assert skipped[3] > 0.5 * dwell * job.machine.clock_hz


def test_machine_axes_outside_2_and_3_is_refused_naming_the_key():
    with pytest.raises(ValueError, match="axes"):
        MachineConfig(axes=4)


def test_a_z_servo_table_on_a_two_axis_machine_is_one_error_naming_it(job_file, k37):
    path = job_file("G21 F600\nG01 X1\nM30", machine="axes = 2", servo="[servo.z]\nkp = 20")
    done = k37("run", "-q", str(path))
    assert done.returncode == 2 and "servo.z" in done.stderr
    assert "Traceback" not in done.stderr


def test_a_fault_on_z_of_a_two_axis_machine_is_one_error(k37):
    done = k37("run", "-q", "--stall", "z", "--max-cycles", "1000")
    assert done.returncode == 2 and "axis z" in done.stderr and "Traceback" not in done.stderr
