"""Cycles per second of the closed-loop two-axis demo on each backend, in one run.

Run with ``pytest bench/bench_closed_loop.py --benchmark-only -s``. The compiled backend runs
the whole demo (the paper's circle, about 6e6 cycles); Amaranth's simulator runs its first
``PYSIM_CYCLES`` cycles (the whole demo would take hours). Both include the firmware model,
the sampling and the report; builds are excluded (the compiled model is built before timing).
"""

from __future__ import annotations

import pytest

from firmware_model.job import demo_job
from sim.run import RunOptions, build_backend, run_job

PYSIM_CYCLES = 20_000
SPEEDS: dict[str, float] = {}


def _run(backend_kind: str, max_cycles: int) -> dict:
    job = demo_job()
    backend = build_backend(job, backend_kind)  # built (or loaded) outside the timing
    report = run_job(job, RunOptions(max_cycles=max_cycles), backend).report
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
