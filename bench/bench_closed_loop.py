"""Cycles per second of the closed-loop two-axis demo on each backend, in one run.

Run with ``pytest bench/bench_closed_loop.py --benchmark-only -s``. The compiled backend runs
the whole demo (the paper's circle, about 6e6 cycles); Amaranth's simulator runs its first
``PYSIM_CYCLES`` cycles (the whole demo would take hours). Both include the firmware model,
the sampling and the report; builds are excluded (the compiled model is built before timing).

The second benchmark runs a dwell-heavy job (:data:`DWELL_GCODE`: short moves, 20 s of dwell)
and the paper's low-feed circle (:data:`LOW_FEED_GCODE`) on the compiled backend with and
without idle skipping and prints the speed-ups.
"""

from __future__ import annotations

import pytest

from k37.firmware_model.job import Job, demo_job, gcode_job
from k37.sim.run.runner import RunOptions, build_backend, run_job

PYSIM_CYCLES = 20_000
SPEEDS: dict[str, float] = {}

#: Four short moves, each followed by a 5 s dwell (a spot-drilling cycle's shape).
DWELL_GCODE = """G21 G91 F1200
G01 X2.0
G04 P5
G01 Y2.0
G04 P5
G01 X-2.0
G04 P5
G01 Y-2.0
G04 P5
M30
"""
#: The paper's low feed (feed word 0x00FF, 88 FP/s = 5.3 mm/min) on a 1 mm circle.
LOW_FEED_GCODE = "G21 G91 F5.3\nG03 X0 Y0 I0.5 J0\nM30\n"
SKIP_JOBS = {"dwell-heavy": DWELL_GCODE, "low-feed circle": LOW_FEED_GCODE}
SKIP_SPEEDS: dict[str, dict[bool, float]] = {}


def _run(backend_kind: str, max_cycles: int, job: Job | None = None,
         skip_idle: bool = True) -> dict:
    job = job or demo_job()
    backend = build_backend(job, backend_kind)  # built (or loaded) outside the timing
    report = run_job(job, RunOptions(max_cycles=max_cycles, skip_idle=skip_idle),
                     backend).report
    backend.close()
    return report


@pytest.mark.parametrize(("kind", "cycles"), [("cxxrtl", 10**9), ("pysim", PYSIM_CYCLES)])
def test_closed_loop_demo_speed(benchmark, kind, cycles):
    report = benchmark.pedantic(_run, args=(kind, cycles), rounds=1, iterations=1)
    SPEEDS[kind] = report["cycles_per_second"]
    print(f"\n{kind}: {report['cycles']:,} cycles in {report['wall_seconds']:.1f} s = "
          f"{SPEEDS[kind]:,.0f} cycles/s ({SPEEDS[kind] / 1e6:.3f}x real time at 1 MHz)")
    if len(SPEEDS) == 2:
        print(f"cxxrtl / pysim = {SPEEDS['cxxrtl'] / SPEEDS['pysim']:.0f}x")


@pytest.mark.parametrize("skip_idle", [False, True])
@pytest.mark.parametrize("name", list(SKIP_JOBS))
def test_idle_skipping_speed_up(benchmark, name, skip_idle):
    job = gcode_job(name, SKIP_JOBS[name], f"<{name}>")
    report = benchmark.pedantic(_run, args=("cxxrtl", 10**9, job, skip_idle), rounds=1,
                                iterations=1)
    speeds = SKIP_SPEEDS.setdefault(name, {})
    speeds[skip_idle] = report["cycles_per_second"]
    print(f"\n{name}, skip_idle={skip_idle}: {report['cycles']:,} cycles "
          f"({report['skipped_cycles']:,} skipped) in {report['wall_seconds']:.2f} s = "
          f"{speeds[skip_idle]:,.0f} cycles/s ({speeds[skip_idle] / 1e6:.1f}x real time)")
    if len(speeds) == 2:
        print(f"{name}: idle skipping speed-up {speeds[True] / speeds[False]:.1f}x")
