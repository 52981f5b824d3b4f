"""Throughput of a study: ``k37 sweep`` against one ``k37 run`` process per run, in one run.

Run with ``pytest bench/bench_sweep.py --benchmark-only -s``. The study is the example L16
study (``examples/study_l16.toml``, sixteen circles); the sweep runs on
two local worker processes, each building (or loading) its compiled machine once and
resetting it between runs; the baseline starts one ``k37 run`` process per run, one after the
other, each with its own imports, cache lookup and model load. Both write the same runs; the
printed ratio should be 2x or more on two cores.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

from k37.sim.study.studyfile import load_study
from k37.sim.study.sweep import sweep

STUDY = Path(__file__).resolve().parent.parent / "examples" / "study_l16.toml"
TIMES: dict[str, float] = {}


def _sweep(out: Path) -> float:
    start = time.perf_counter()
    sweep(load_study(STUDY), out, jobs=2)
    return time.perf_counter() - start


def _processes(folder: Path) -> float:
    study = load_study(STUDY)
    start = time.perf_counter()
    for run in study.runs:
        job = folder / f"run{run.number}.toml"
        job.write_text(_job_toml(study, run))
        subprocess.run([sys.executable, "-m", "k37.sim.cli", "run", str(job), "-q",
                        "--max-cycles", str(study.max_cycles), "--sample-every",
                        str(study.sample_every)], check=True,
                       env=os.environ | {"PYTHONPATH": str(STUDY.parent.parent)})
    return time.perf_counter() - start


def _toml(data: dict, table: str = "") -> list[str]:
    """``data`` as TOML lines: its values in JSON (true, numbers, strings in JSON's escapes,
    which TOML's basic strings share, arrays), then each sub-table."""
    lines = [f"[{table}]"] if table else []
    lines += [f"{k} = {json.dumps(v)}" for k, v in data.items() if not isinstance(v, dict)]
    for k, v in data.items():
        if isinstance(v, dict):
            lines += _toml(v, f"{table}.{k}" if table else k)
    return lines


def _job_toml(study, run) -> str:
    """The run's job (:meth:`~k37.sim.study.studyfile.Study.job_data`) as a job file."""
    return "\n".join(_toml(study.job_data(run))) + "\n"


def test_sweep_throughput_against_a_process_per_run(benchmark, tmp_path):
    TIMES["process per run"] = _processes(tmp_path)
    TIMES["k37 sweep -j 2"] = benchmark.pedantic(_sweep, args=(tmp_path / "out",), rounds=1,
                                                 iterations=1)
    runs = len(load_study(STUDY).runs)
    for name, seconds in TIMES.items():
        print(f"\n{name}: {runs} runs in {seconds:.1f} s ({runs / seconds:.2f} runs/s)")
    print(f"sweep / process per run throughput = "
          f"{TIMES['process per run'] / TIMES['k37 sweep -j 2']:.2f}x (goal: 2x on 2 cores)")
