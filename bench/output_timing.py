"""What the benchmarks of a run's outputs (the PNG, the HTML page) share: a job run and timed
apart from the output written after it, and the two ways to print a measurement (under
pytest-benchmark, or as a script writing into a folder given on the command line)."""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from pathlib import Path

from k37.sim.run.jobfile import load_job
from k37.sim.run.runner import RunOptions, RunResult, run_job

Measure = Callable[[Path], list[str]]


def timed_run(job: Path, sample_every: int) -> tuple[RunResult, dict[str, float]]:
    """Run the job file ``job`` sampling every ``sample_every`` cycles: the result, and its
    block count, sample count and wall seconds (``blocks``, ``samples``, ``run``)."""
    start = time.perf_counter()
    result = run_job(load_job(job), RunOptions(sample_every=sample_every))
    return result, {"blocks": len(result.report["blocks"]),
                    "samples": result.report["path"]["samples"],
                    "run": time.perf_counter() - start}


def benchmark_measure(benchmark, measure: Measure, folder: Path) -> None:
    """Run ``measure`` once under pytest-benchmark and print its lines."""
    lines = benchmark.pedantic(measure, args=(folder,), rounds=1, iterations=1)
    print("\n" + "\n".join(lines))


def main(measure: Measure) -> None:
    """Run ``measure`` into the folder named by the first argument (default: here)."""
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path.cwd()
    out.mkdir(parents=True, exist_ok=True)
    print("\n".join(measure(out)))
