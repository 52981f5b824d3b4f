"""``k37 sweep``: a study's runs on a pool of workers, one results table.

Each worker process keeps its compiled machines (one per set of
:func:`~k37.sim.run.runner.design_key`) and resets them between runs, so a study pays one
build per worker, not one per run. Runs go to local worker processes (``jobs`` of them) or,
with a scheduler address, to a Dask distributed cluster (``dask scheduler`` and ``dask
worker`` processes anywhere): the same function runs each, so the table is the same.

The study is checked whole before any run (:func:`check_study`: every run's job loads, no
factor is named as a column of the table). ``DIR/results.csv`` gets one row per run as it
finishes (its number, its factors' levels, :data:`METRICS`), appended whole or not at all; a
last row cut short by a crash is dropped when the study is run again into the same folder,
which skips the runs already there. A local worker that dies (killed, out of memory) makes
its run a row with status ``error`` naming the signal, and a new worker takes the next run;
such a row, and one whose run failed for another reason outside its job (an ``OSError``: a
full disk, a missing compiler; ``MemoryError``), has a reason beginning :data:`OUTSIDE`, and
a sweep run again into the folder retries it (``retry_errors``: every ``error`` row);
an interrupted sweep (KeyboardInterrupt, which the command line raises for SIGINT and
SIGTERM) ends its workers before it returns. When every run is in, the rows are sorted by
run number and ``DIR/results.parquet`` written.
"""

from __future__ import annotations

import contextlib
import csv
import ctypes
import io
import math
import multiprocessing
import os
import signal
import time
from collections.abc import Callable, Iterator
from multiprocessing.connection import Connection, wait
from pathlib import Path
from typing import Any

from k37.sim.files import atomic_open, atomic_path, why
from k37.sim.run.ballbar import FIGURES, BallbarError, ballbar
from k37.sim.run.jobfile import JobError
from k37.sim.run.output import write_html
from k37.sim.run.runner import OptionError, RunOptions, reused_backend, run_job
from k37.sim.study.html_report import RUN_REPORTS
from k37.sim.study.studyfile import Study, StudyRun

__all__ = ["METRICS", "OUTSIDE", "WORKER_STOP_SECONDS", "SweepError", "check_study",
           "end_with_parent", "run_one", "stop_workers", "sweep"]

#: The columns each run fills after its factors.
METRICS = ("status", "reason", "cycles", "machine_seconds", "wall_seconds", "backend",
           "max_contour_error", "rms_contour_error", "x_max_following_error",
           "y_max_following_error", "end_reached", *FIGURES)

#: How the reason of an ``error`` row begins when the run failed outside its job (a rerun
#: retries it).
OUTSIDE = "outside the job: "

#: How long a stopped worker has to end on SIGTERM before it is killed.
WORKER_STOP_SECONDS = 5.0


class SweepError(ValueError):
    """A results folder that cannot take this study's table."""


def run_one(study: Study, run: StudyRun, pages: Path | None = None) -> dict[str, Any]:
    """Run ``run`` of ``study`` and return its row (a bad job is a row with status
    ``error``, never an exception); with ``pages``, write its ``--html`` report there as
    ``RUN.html`` (a page that cannot be written says so in the row's reason)."""
    start = time.perf_counter()
    row: dict[str, Any] = {"run": run.number, **dict(run.levels)}
    try:
        job = study.job(run)
        result = run_job(job, RunOptions(max_cycles=study.max_cycles,
                                         sample_every=study.sample_every), reused_backend(job))
    except (JobError, OptionError, ValueError) as e:
        return row | {"status": "error", "reason": str(e)}
    except (OSError, MemoryError) as e:
        return row | {"status": "error", "reason": f"{OUTSIDE}{type(e).__name__}: {e}"}
    except Exception as e:  # any other failure of one run is that run's row, not the sweep's
        return row | {"status": "error", "reason": f"{type(e).__name__}: {e}"}
    report = result.report
    row |= {"status": report["status"], "reason": report["reason"], "cycles": report["cycles"],
            "machine_seconds": report["machine_seconds"], "backend": report["backend"],
            "max_contour_error": report["path"]["max_contour_error"],
            "rms_contour_error": report["path"]["rms_contour_error"],
            "end_reached": report["end_point"]["reached"]}
    for axis, values in report["axes"].items():
        row[f"{axis}_max_following_error"] = values["max_abs_error"]
    circle = None
    with contextlib.suppress(BallbarError):  # not a circle: no ballbar figures
        circle = ballbar(result, study.settle_deg)
        row |= circle.figures()
    if pages is not None:
        page = pages / f"{run.number}.html"
        try:
            write_html(result, page, circle)
        except OSError as e:
            row["reason"] += f"; {page}: not written: {why(e)}"
    row["wall_seconds"] = time.perf_counter() - start
    return row


def check_study(study: Study) -> None:
    """Refuse a study before any run: a factor named as a column of the table, or a run whose
    job does not load (a factor key the job does not have, a level out of range), naming the
    study file, the run and its levels.

    Raises
    ------
    JobError
        One line per distinct error (at most five) with the runs that have it.
    """
    clash = sorted(set(study.factors) & {"run", *METRICS})
    if clash:
        raise JobError(f"{study.source}: factor {clash[0]} has the name of a column of the "
                       f"results table; rename it")
    errors: dict[str, list[StudyRun]] = {}  # each error once, with the runs that have it
    for run in study.runs:
        try:
            study.job(run)
        except (JobError, ValueError) as e:
            errors.setdefault(str(e), []).append(run)
    lines = []
    for message, runs in list(errors.items())[:5]:
        if len(runs) == len(study.runs) > 1:
            which = "every run"
        else:
            which = "run " + ", ".join(str(r.number) for r in runs[:10]) + (
                ", ..." if len(runs) > 10 else "")
            if len(runs) == 1:
                which += " (" + ", ".join(f"{f} = {v!r}" for f, v in runs[0].levels) + ")"
        lines.append(f"{study.source}: {which}: {message}")
    if len(errors) > 5:
        lines.append(f"{study.source}: ... and {len(errors) - 5} more errors")
    if lines:
        raise JobError("\n".join(lines))


def _header(study: Study) -> list[str]:
    return ["run", *study.factors, *METRICS]


def _done(study: Study, path: Path, report: Callable[[str], None] | None,
          retry_errors: bool = False) -> set[int]:
    """The runs ``path`` already holds (checking it is this study's table); a last row cut
    short (no line end: the writer stopped within it) is dropped from the file, and so are
    the ``error`` rows to retry (:func:`_retried`)."""
    if not path.exists():
        return set()
    data = path.read_bytes()
    if data and not data.endswith(b"\n"):
        cut = data.rfind(b"\n") + 1
        with open(path, "r+b") as f:
            f.truncate(cut)
        if report:
            report(f"{path}: its last row was cut short (a write that did not finish); "
                   f"dropped, that run runs again")
        data = data[:cut]
    reader = csv.reader(io.StringIO(data.decode("utf-8", errors="replace"), newline=""))
    header = next(reader, None)
    if header is None:  # only a cut header: start the table again
        path.unlink()
        return set()
    if header != _header(study):
        raise SweepError(f"{path}: its columns are not this study's; give another --out "
                         f"or remove the file")
    runs = {r.number: r for r in study.runs}
    done = set()
    for line, values in enumerate(reader, 2):
        try:
            number = int(values[0])
        except (ValueError, IndexError):
            raise SweepError(f"{path}:{line}: not a row of this study's table; give another "
                             f"--out or remove the file") from None
        levels = [str(v) for _, v in runs[number].levels] if number in runs else None
        if levels != values[1:1 + len(study.factors)] or len(values) != len(header):
            raise SweepError(f"{path}:{line}: run {number} has other levels than this study's")
        done.add(number)
    retry = _retried(path, header.index("status"), header.index("reason"), retry_errors)
    if retry and report:
        report(f"{path}: retrying {len(retry)} run{'s' * (len(retry) > 1)} that failed "
               f"{'' if retry_errors else 'outside the job '}(run "
               f"{', '.join(map(str, sorted(retry)[:10]))}{', ...' * (len(retry) > 10)})")
    return done - retry


def _retried(path: Path, status: int, reason: int, every_error: bool) -> set[int]:
    """The runs of ``path`` whose rows are ``error`` rows to run again: those that failed
    outside their job (their reason begins :data:`OUTSIDE`), or every ``error`` row
    (``every_error``). Their rows are taken out of the file (which is rewritten whole)."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    keep, retry = [rows[0]], set()
    for row in rows[1:]:
        if row[status] == "error" and (every_error or row[reason].startswith(OUTSIDE)):
            retry.add(int(row[0]))
        else:
            keep.append(row)
    if retry:
        with atomic_open(path, "w", newline="") as f:
            csv.writer(f).writerows(keep)
    return retry


def end_with_parent() -> None:
    """Have the kernel send this process SIGTERM when its parent dies (Linux), so a worker
    never outlives a sweep that was killed outright."""
    with contextlib.suppress(OSError, AttributeError):
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG


def _worker(study: Study, tasks: Connection, parent: int, pages: Path | None) -> None:
    """A worker process: runs of ``study`` received on ``tasks``, their rows sent back (and
    their reports written to ``pages``)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the sweep stops its workers itself
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    end_with_parent()
    if os.getppid() != parent:  # the parent died before the signal was set
        return
    while True:
        try:
            run = tasks.recv()
        except (EOFError, OSError):
            return
        if run is None:
            return
        tasks.send(run_one(study, run, pages))


class _Pool:
    """``jobs`` worker processes, one run each at a time; a worker that dies is replaced and
    its run reported as an error row."""

    def __init__(self, study: Study, jobs: int, pages: Path | None):
        self.study = study
        self.jobs = jobs
        self.pages = pages
        self.context = multiprocessing.get_context(
            "fork" if "fork" in multiprocessing.get_all_start_methods() else "spawn")
        self.workers: dict[Connection, tuple[multiprocessing.process.BaseProcess,
                                             StudyRun | None]] = {}

    def _start(self) -> Connection:
        mine, theirs = self.context.Pipe()
        process = self.context.Process(target=_worker, args=(self.study, theirs, os.getpid(),
                                                             self.pages), daemon=True)
        process.start()
        theirs.close()
        self.workers[mine] = (process, None)
        return mine

    def rows(self, runs: list[StudyRun]) -> Iterator[dict[str, Any]]:
        todo = list(reversed(runs))
        for _ in range(min(self.jobs, len(runs))):
            self._start()
        busy = 0
        while todo or busy:
            for conn, (process, run) in list(self.workers.items()):
                if run is None and todo:
                    run = todo.pop()
                    try:
                        conn.send(run)
                    except OSError:  # the worker died between runs: another takes it
                        todo.append(run)
                        process.join(WORKER_STOP_SECONDS)
                        del self.workers[conn]
                        conn.close()
                        self._start()
                        continue
                    self.workers[conn] = (process, run)
                    busy += 1
            waiting = {conn: conn for conn, (_, run) in self.workers.items() if run is not None}
            sentinels = {p.sentinel: conn for conn, (p, run) in self.workers.items()
                         if run is not None}
            if not waiting:  # a worker was replaced: give it a run first
                continue
            for ready in wait([*waiting, *sentinels]):
                conn = waiting.get(ready) or sentinels[ready]  # type: ignore[index]
                if conn not in self.workers:
                    continue
                process, run = self.workers[conn]
                assert run is not None
                try:
                    row = conn.recv() if conn.poll() else None
                except (EOFError, OSError):
                    row = None
                if row is None:  # the worker died within the run
                    process.join(WORKER_STOP_SECONDS)
                    del self.workers[conn]
                    conn.close()
                    row = {"run": run.number, **dict(run.levels), "status": "error",
                           "reason": OUTSIDE + _death(process.exitcode)}
                    if todo:
                        self._start()
                else:
                    self.workers[conn] = (process, None)
                busy -= 1
                yield row

    def close(self) -> None:
        """End every worker: ask (no more runs), then SIGTERM, then SIGKILL."""
        for conn, (process, run) in self.workers.items():
            if run is None:
                with contextlib.suppress(OSError):
                    conn.send(None)
            else:
                process.terminate()
        deadline = time.monotonic() + WORKER_STOP_SECONDS
        for _, (process, _) in self.workers.items():
            process.join(max(0.0, deadline - time.monotonic()))
            if process.is_alive():
                process.kill()
                process.join()
        for conn in self.workers:
            conn.close()
        self.workers.clear()


def stop_workers(processes: list[multiprocessing.process.BaseProcess]) -> None:
    """End worker ``processes``: SIGTERM, then SIGKILL those still alive after
    :data:`WORKER_STOP_SECONDS`."""
    for process in processes:
        if process.is_alive():
            process.terminate()
    deadline = time.monotonic() + WORKER_STOP_SECONDS
    for process in processes:
        process.join(max(0.0, deadline - time.monotonic()))
        if process.is_alive():
            process.kill()
            process.join()


def _death(exitcode: int | None) -> str:
    """Why a worker ended without its run's row, in words."""
    if exitcode is not None and exitcode < 0:
        name = signal.Signals(-exitcode).name
        return f"the worker process running it died of {name} (signal {-exitcode})"
    return f"the worker process running it exited with status {exitcode}"


def _executor(jobs: int, scheduler: str | None, pages: Path | None
              ) -> Callable[[Study, list[StudyRun]], Iterator[dict[str, Any]]]:
    def local(study: Study, runs: list[StudyRun]) -> Iterator[dict[str, Any]]:
        pool = _Pool(study, jobs, pages)
        try:
            yield from pool.rows(runs)
        finally:
            pool.close()

    def dask(study: Study, runs: list[StudyRun]) -> Iterator[dict[str, Any]]:
        try:
            from distributed import Client
            from distributed import as_completed as dask_completed
        except ImportError:
            raise SweepError("--scheduler needs Dask's distributed package, which the default "
                             "install leaves out: pip install 'k37[cluster]'") from None

        with Client(scheduler, timeout="20s") as client:
            futures = [client.submit(run_one, study, run, pages, pure=False) for run in runs]
            try:
                for future in dask_completed(futures):
                    yield future.result()
            finally:
                client.cancel(futures)

    return dask if scheduler else local


def _append(fd: int, header: list[str], row: dict[str, Any]) -> None:
    """Append ``row`` as one line in one write; a write that fails (a full disk) is cut off
    again, so the table holds the row whole or not at all."""
    buffer = io.StringIO()
    csv.DictWriter(buffer, header, restval="").writerow(row)
    line = buffer.getvalue().encode()
    size = os.lseek(fd, 0, os.SEEK_END)
    try:
        written = os.write(fd, line)
        if written != len(line):
            raise OSError(28, os.strerror(28))
        os.fsync(fd)
    except BaseException:
        with contextlib.suppress(OSError):
            os.ftruncate(fd, size)
        raise


def sweep(study: Study, out: Path, *, jobs: int = 2, scheduler: str | None = None,
          report: Callable[[str], None] | None = None, html: bool = False,
          retry_errors: bool = False) -> Path:
    """Run every run of ``study`` not yet in ``out/results.csv``, and those whose rows failed
    outside their job (``retry_errors``: every ``error`` row); return the CSV's path.
    ``html``: also write each run's ``--html`` report, ``out/runs/RUN.html`` (the workers
    write them: on a cluster, ``out`` must be a folder they share).

    Raises :class:`~k37.sim.run.jobfile.JobError` (:func:`check_study`) or :class:`SweepError`
    (a folder holding another table) before any run.
    """
    check_study(study)
    out.mkdir(parents=True, exist_ok=True)
    pages = out / RUN_REPORTS if html else None
    if pages is not None:
        pages.mkdir(exist_ok=True)
    path = out / "results.csv"
    done = _done(study, path, report, retry_errors)
    todo = [run for run in study.runs if run.number not in done]
    header = _header(study)
    start = time.perf_counter()
    if not path.exists():
        with atomic_open(path, "w", newline="") as f:
            csv.writer(f).writerow(header)
    fd = os.open(path, os.O_WRONLY | os.O_APPEND)
    try:
        for k, row in enumerate(_executor(jobs, scheduler, pages)(study, todo), 1):
            _append(fd, header, row)
            if report:
                elapsed = time.perf_counter() - start
                eta = elapsed / k * (len(todo) - k)
                report(f"run {row['run']}: {row['status']} ({k + len(done)}/{len(study.runs)}, "
                       f"ETA {_duration(eta)})")
    finally:
        os.close(fd)
    _finish(path)
    return path


def _duration(seconds: float) -> str:
    minutes, secs = divmod(math.ceil(seconds), 60)
    return f"{minutes}m{secs:02d}s" if minutes else f"{secs}s"


def _finish(path: Path) -> None:
    """Sort the table by run number and write its Parquet twin (each whole or not at all)."""
    import pyarrow.csv
    import pyarrow.parquet

    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    body = sorted(rows[1:], key=lambda r: int(r[0]))
    with atomic_open(path, "w", newline="") as f:
        csv.writer(f).writerows([rows[0], *body])
    with atomic_path(path.with_suffix(".parquet")) as tmp:
        pyarrow.parquet.write_table(pyarrow.csv.read_csv(path), tmp)
