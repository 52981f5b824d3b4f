"""The event-level engine against the compiled RTL backend, in one run.

Run with ``pytest bench/bench_engine.py --benchmark-only -s``. Each job runs on both backends
(built or loaded before the timing; the fastest of ``ROUNDS`` runs, or of fewer once they
have taken ``BUDGET / ROUNDS`` seconds), and the reports must be equal (the fields of how a
run was computed aside). Printed per job: machine seconds per wall second on each backend,
the engine's speed-up, the cycles each evaluated (the rest skipped in closed form), the
process CPU time (steadier than wall time on a shared machine), what stepping every axis's
plant every cycle would cost against the engine's CPU time (one plant's update timed alone,
times the cycles and the axes), and the engine on the same job with its first-order plants
updated every ``HELD`` cycles (servo ``update_cycles``), with both runs' largest and RMS
contour error. The jobs: the demo, the K3701's top feed on a 100 mm line, a dwell-heavy job,
the paper's low feed, fourteen programs of the G-code corpus in several writers' styles (two
and three axes) on the default machine (exact stop after every block), and
:mod:`bench_cam`'s pocket (three axes, accel/decel after the K3701). It ends with the
corpus's range and median of the engine's real-time factor and of its ratio to the compiled
RTL backend, and the demo's cycles per second.
"""

from __future__ import annotations

import statistics
import time
from dataclasses import replace
from pathlib import Path

from bench_cam import cam_job
from bench_closed_loop import DWELL_GCODE, LOW_FEED_GCODE
from bench_goals import TOP_FEED_GCODE

from k37.firmware_model.job import Job, demo_job, gcode_job
from k37.sim.api import load
from k37.sim.run.report import HOW_FIELDS
from k37.sim.run.runner import RunOptions, build_backend, run_job

CORPUS = Path(__file__).parent.parent / "tests" / "gcode_corpus"
#: Programs of the corpus in several writers' styles: six of two axes, eight of three.
PROGRAMS = ("square_mm.ngc", "grbl_style_2d.nc", "inch_r_arcs.ngc", "ngc_subroutine.ngc",
            "offsets_g92_g53.ngc", "block_delete_comments.ngc", "linuxcnc_style_drill.ngc",
            "linuxcnc_style_helix.ngc", "fusion_style_contour.nc", "cambam_circle_passes.nc",
            "jscut_style.gcode", "pcbgcode_style_etch.tap", "partkam_style.ngc",
            "ngc_polar_bolt_circle.ngc")
ROUNDS = 5
#: A job's runs on one backend stop once they have taken ``BUDGET / ROUNDS`` seconds.
BUDGET = 30.0
#: The plants' update period of the engine's held runs (servo ``update_cycles``).
HELD = 64


def jobs() -> dict[str, Job]:
    return {"demo": demo_job(), "top-feed line": gcode_job("top", TOP_FEED_GCODE, "<top>"),
            "dwell-heavy": gcode_job("dwell", DWELL_GCODE, "<dwell>"),
            "low-feed circle": gcode_job("low", LOW_FEED_GCODE, "<low>"),
            **{name: load(CORPUS / name) for name in PROGRAMS},
            "bench_cam pocket": cam_job()}


def timed(job: Job, kind: str) -> tuple[dict, float, float]:
    """The report of the fastest of ``ROUNDS`` runs (fewer once they have taken
    ``BUDGET / ROUNDS`` seconds), its wall and CPU seconds."""
    backend = build_backend(job, kind)  # built (or loaded) outside the timing
    best = None
    start = time.perf_counter()
    for _ in range(ROUNDS):
        if best is not None and time.perf_counter() - start > BUDGET / ROUNDS:
            break
        backend.reset()
        cpu = time.process_time()
        report = run_job(job, RunOptions(backend=kind), backend).report
        cpu = time.process_time() - cpu
        if best is None or report["wall_seconds"] < best[1]:
            best = (report, report["wall_seconds"], cpu)
    backend.close()
    assert best is not None
    return best


def contour(report: dict) -> str:
    """The run's largest and RMS contour error (LSB), or a dash where it has none."""
    path = report.get("path") or {}
    if path.get("max_contour_error") is None:
        return "-"
    return f"{path['max_contour_error']:.2f}, {path['rms_contour_error']:.3f}"


def plant_ns() -> float:
    """CPU nanoseconds of one plant's update per cycle, stepped alone (the faster of three)."""
    backend = build_backend(demo_job(), "engine")
    try:
        return min(backend.plant_ns(10**7) for _ in range(ROUNDS))
    finally:
        backend.close()


def held(job: Job) -> Job:
    """``job`` with its first-order plants updated every :data:`HELD` cycles."""
    return replace(job, servo={axis: replace(servo, update_cycles=HELD)
                               if servo.drive == "first_order" else servo
                               for axis, servo in job.servo.items()})


def compare_all() -> list[str]:
    plant = plant_ns()
    print(f"a plant's update: {plant:.2f} ns per cycle")
    rows = ["| job | machine s | cxxrtl x real time | engine x real time | engine / cxxrtl "
            "| evaluated cycles cxxrtl / engine | CPU s cxxrtl / engine "
            f"| plants stepped every cycle / engine CPU | engine, update_cycles {HELD}: "
            "x real time (CPU s) | contour error max, RMS (LSB): every cycle / held |",
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    corpus: list[tuple[float, float]] = []  # (engine x real time, engine / cxxrtl)
    demo_rate = 0.0
    for name, job in jobs().items():
        runs = {kind: timed(job, kind) for kind in ("cxxrtl", "engine")}
        runs["held"] = timed(held(job), "engine")
        (rtl, rtl_wall, rtl_cpu), (eng, eng_wall, eng_cpu) = runs["cxxrtl"], runs["engine"]
        hold, hold_wall, hold_cpu = runs["held"]
        assert ({k: v for k, v in rtl.items() if k not in HOW_FIELDS}
                == {k: v for k, v in eng.items() if k not in HOW_FIELDS}), name
        machine = rtl["machine_seconds"]
        rows.append(f"| {name} | {machine:,.1f} | {machine / rtl_wall:,.0f} | "
                    f"{machine / eng_wall:,.0f} | {rtl_wall / eng_wall:.1f} | "
                    f"{rtl['cycles'] - rtl['skipped_cycles']:,} / "
                    f"{eng['cycles'] - eng['skipped_cycles']:,} | "
                    f"{rtl_cpu:.2f} / {eng_cpu:.2f} | "
                    f"{rtl['cycles'] * job.machine.axes * plant * 1e-9 / eng_cpu:.0%} | "
                    f"{hold['machine_seconds'] / hold_wall:,.0f} ({hold_cpu:.2f}) | "
                    f"{contour(eng)} / {contour(hold)} |")
        print(rows[-1], flush=True)
        if name in PROGRAMS:
            corpus.append((machine / eng_wall, rtl_wall / eng_wall))
        if name == "demo":
            demo_rate = eng["cycles"] / eng_wall
    speeds, ratios = (sorted(column) for column in zip(*corpus, strict=True))
    rows.append(f"\nthe corpus's {len(speeds)} programs on the engine: {speeds[0]:,.0f}x to "
                f"{speeds[-1]:,.0f}x real time, median {statistics.median(speeds):,.0f}x; "
                f"{ratios[0]:.1f} to {ratios[-1]:.1f} times the compiled RTL backend, median "
                f"{statistics.median(ratios):.1f}; the demo at {demo_rate:.2e} cycles/s")
    return rows


def test_engine_against_the_rtl(benchmark):
    print()
    rows = benchmark.pedantic(compare_all, rounds=1, iterations=1)
    print("\n".join(rows))
