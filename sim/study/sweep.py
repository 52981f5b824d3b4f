"""``k37 sweep``: a study's runs on a pool of workers, one results table.

Each worker process keeps its compiled machines (one per set of
:func:`~sim.run.runner.design_key`) and resets them between runs, so a study pays one
build per worker, not one per run. Runs go to a local process pool (``jobs`` processes) or,
with a scheduler address, to a Dask distributed cluster (``dask scheduler`` and ``dask
worker`` processes anywhere): the same function runs each, so the table is the same.

``DIR/results.csv`` gets one row per run as it finishes (its number, its factors' levels,
:data:`METRICS`); running the study again into the same folder skips the runs already there.
When every run is in, the rows are sorted by run number and ``DIR/results.parquet`` written.
"""

from __future__ import annotations

import contextlib
import csv
import math
import os
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

from sim.run.ballbar import FIGURES, BallbarError, ballbar
from sim.run.jobfile import JobError
from sim.run.runner import OptionError, RunOptions, reused_backend, run_job
from sim.study.studyfile import Study, StudyRun

__all__ = ["METRICS", "SweepError", "run_one", "sweep"]

#: The columns each run fills after its factors.
METRICS = ("status", "reason", "cycles", "machine_seconds", "wall_seconds",
           "max_contour_error", "rms_contour_error", "x_max_following_error",
           "y_max_following_error", "end_reached", *FIGURES)

class SweepError(ValueError):
    """A results folder that cannot take this study's table."""


def run_one(study: Study, run: StudyRun) -> dict[str, Any]:
    """Run ``run`` of ``study`` and return its row (a bad job is a row with status
    ``error``, never an exception)."""
    start = time.perf_counter()
    row: dict[str, Any] = {"run": run.number, **dict(run.levels)}
    try:
        job = study.job(run)
        result = run_job(job, RunOptions(backend="cxxrtl", max_cycles=study.max_cycles,
                                         sample_every=study.sample_every), reused_backend(job))
    except (JobError, OptionError, ValueError) as e:
        return row | {"status": "error", "reason": str(e)}
    report = result.report
    row |= {"status": report["status"], "reason": report["reason"], "cycles": report["cycles"],
            "machine_seconds": report["machine_seconds"],
            "max_contour_error": report["path"]["max_contour_error"],
            "rms_contour_error": report["path"]["rms_contour_error"],
            "end_reached": report["end_point"]["reached"]}
    for axis, values in report["axes"].items():
        row[f"{axis}_max_following_error"] = values["max_abs_error"]
    with contextlib.suppress(BallbarError):  # not a circle: no ballbar figures
        row |= ballbar(result, study.settle_deg).figures()
    row["wall_seconds"] = time.perf_counter() - start
    return row


def _header(study: Study) -> list[str]:
    return ["run", *study.factors, *METRICS]


def _done(study: Study, path: Path) -> set[int]:
    """The runs ``path`` already holds (checking it is this study's table)."""
    if not path.exists():
        return set()
    with open(path, newline="") as f:
        reader = csv.reader(f)
        header = next(reader, None)
        if header != _header(study):
            raise SweepError(f"{path}: its columns are not this study's; give another --out "
                             f"or remove the file")
        runs = {r.number: r for r in study.runs}
        done = set()
        for values in reader:
            number = int(values[0])
            levels = [str(v) for _, v in runs[number].levels] if number in runs else None
            if levels != values[1:1 + len(study.factors)]:
                raise SweepError(f"{path}: run {number} has other levels than this study's")
            done.add(number)
    return done


def _executor(jobs: int, scheduler: str | None) -> Callable[[Study, list[StudyRun]],
                                                            Iterator[dict[str, Any]]]:
    def local(study: Study, runs: list[StudyRun]) -> Iterator[dict[str, Any]]:
        with ProcessPoolExecutor(jobs) as pool:
            futures = [pool.submit(run_one, study, run) for run in runs]
            for future in as_completed(futures):
                yield future.result()

    def dask(study: Study, runs: list[StudyRun]) -> Iterator[dict[str, Any]]:
        from distributed import Client
        from distributed import as_completed as dask_completed

        with Client(scheduler, timeout="20s") as client:
            futures = [client.submit(run_one, study, run, pure=False) for run in runs]
            for future in dask_completed(futures):
                yield future.result()

    return dask if scheduler else local


def sweep(study: Study, out: Path, *, jobs: int = 2, scheduler: str | None = None,
          report: Callable[[str], None] | None = None) -> Path:
    """Run every run of ``study`` not yet in ``out/results.csv``; return the CSV's path."""
    out.mkdir(parents=True, exist_ok=True)
    path = out / "results.csv"
    done = _done(study, path)
    todo = [run for run in study.runs if run.number not in done]
    header = _header(study)
    start = time.perf_counter()
    new = not path.exists()
    with open(path, "a", newline="") as f:
        writer = csv.DictWriter(f, header, restval="")
        if new:
            writer.writeheader()
        for k, row in enumerate(_executor(jobs, scheduler)(study, todo), 1):
            writer.writerow(row)
            f.flush()
            os.fsync(f.fileno())
            if report:
                elapsed = time.perf_counter() - start
                eta = elapsed / k * (len(todo) - k)
                report(f"run {row['run']}: {row['status']} ({k + len(done)}/{len(study.runs)}, "
                       f"ETA {_duration(eta)})")
    _finish(path)
    return path


def _duration(seconds: float) -> str:
    minutes, secs = divmod(math.ceil(seconds), 60)
    return f"{minutes}m{secs:02d}s" if minutes else f"{secs}s"


def _finish(path: Path) -> None:
    """Sort the table by run number and write its Parquet twin."""
    import pyarrow.csv
    import pyarrow.parquet

    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    body = sorted(rows[1:], key=lambda r: int(r[0]))
    with open(path, "w", newline="") as f:
        csv.writer(f).writerows([rows[0], *body])
    pyarrow.parquet.write_table(pyarrow.csv.read_csv(path), path.with_suffix(".parquet"))
