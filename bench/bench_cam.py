"""A CAM program of a few thousand blocks, as a user's part program: machine time against
wall time, and planning time.

Run with ``pytest bench/bench_cam.py --benchmark-only -s``. The program is written in the
style of CAM output (a pocket cleared in zigzag passes joined by small arcs, a helical entry,
a finishing contour of lines and arcs, rapids between), generated here so that its licence
is the project's. The machine has its accel/decel circuit per axis after the K3701
(``machine.accel = "post"``), as a machine for short CAM blocks would: the paper's FP control
stops exactly at every block (about 2 s each at its 300 ms time constant).
"""

from __future__ import annotations

import math
import time

from k37.firmware_model.feeds import program_seconds
from k37.firmware_model.job import Job, MachineConfig, ServoConfig, parse_for_machine
from k37.sim.run.runner import RunOptions, build_backend, run_job

#: Passes of the zigzag pocket (each a line and a joining arc).
PASSES = 600


def cam_program(passes: int = PASSES) -> str:
    """A pocket 60 mm wide cleared in ``passes`` zigzag passes 0.1 mm apart (a line and a
    half circle each), entered by a helical ramp, finished by a contour of 200 lines and 200
    arcs; G21, G90, feeds in mm/min."""
    lines = ["(K37 bench: a CAM-style pocket)", "G21 G90 G17", "G00 Z5", "G00 X2 Y2",
             "G01 Z0 F300", "G03 X2 Y2 Z-1 I1 J0 F600"]  # a helical ramp in
    y = 2.0
    for k in range(passes):
        x_end = 62.0 if k % 2 == 0 else 2.0
        lines.append(f"G01 X{x_end:.3f} Y{y:.3f} F1200")
        y_next = y + 0.1
        arc = "G02" if k % 2 == 0 else "G03"
        lines.append(f"{arc} X{x_end:.3f} Y{y_next:.3f} I0 J0.05")
        y = y_next
    lines.append("G00 Z5")
    centre, radius = (32.0, 32.0), 29.0
    lines.append(f"G00 X{centre[0] + radius:.3f} Y{centre[1]:.3f}")
    lines.append("G01 Z-1 F300")
    for k in range(1, 201):  # a wavy finishing contour: lines and arcs
        a = 2 * math.pi * k / 200
        r = radius + (0.5 if k % 2 else 0.0)
        lines.append(f"G01 X{centre[0] + r * math.cos(a):.3f} Y{centre[1] + r * math.sin(a):.3f} "
                     f"F900")
    lines += ["G00 Z5", "M05", "M30"]
    return "\n".join(lines) + "\n"


def cam_job() -> Job:
    machine, program = parse_for_machine(MachineConfig(accel="post"), cam_program(),
                                         source="<cam>")
    return Job("cam", machine, dict.fromkeys(machine.axis_names, ServoConfig()), program)


def test_planning_a_cam_program(benchmark):
    text = cam_program()
    job = benchmark.pedantic(cam_job, rounds=3, iterations=1)
    print(f"\nCAM program: {text.count(chr(10))} lines, {len(job.program.moves)} blocks; "
          f"planned in {benchmark.stats.stats.min:.3f} s; planned machine time "
          f"{program_seconds(job):.1f} s")


def test_running_a_cam_program_machine_time_against_wall_time(benchmark):
    job = cam_job()
    backend = build_backend(job, "cxxrtl")  # built (or loaded) outside the timing

    def run() -> dict:
        start = time.perf_counter()
        report = run_job(job, RunOptions(backend="cxxrtl"), backend).report
        report["bench_wall"] = time.perf_counter() - start
        return report

    report = benchmark.pedantic(run, rounds=1, iterations=1)
    backend.close()
    machine = report["cycles"] / job.machine.clock_hz
    assert report["status"] == "ok", report["reason"]
    print(f"\nCAM program: {len(report['blocks'])} blocks, {machine:.1f} s of machine time in "
          f"{report['bench_wall']:.1f} s wall: x{machine / report['bench_wall']:.1f} real time "
          f"(planned {program_seconds(job):.1f} s)")
