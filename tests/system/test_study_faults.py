"""Faults around the study commands: workers killed or out of space, rows torn or half
written, bad study files, sweeps stopped by SIGINT or SIGTERM or killed outright, and effects
of tables that cannot be analysed or figures that cannot be written. Each ends in an exit code
and one line naming the problem; finished rows stay; no worker outlives its command."""

from __future__ import annotations

import contextlib
import csv
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from k37.sim.cli import main
from k37.sim.study import sweep as sweep_module
from k37.sim.study.studyfile import load_study
from k37.sim.study.sweep import sweep
from tests.paths import ROOT
from tests.system.checks import ENV, one_error

CIRCLE = ROOT / "examples" / "circle.toml"


# --- sweeps --------------------------------------------------------------------------------

BASE = '''
[machine]
accel = "none"
[program]
gcode = """
G21 G90 F{feed}
G03 X0 Y0 I-{radius} J0
M30
"""
'''


def _study(folder: Path, factors: str = 'feed = [600, 900]\nradius = [5, 6]') -> Path:
    (folder / "base.toml").write_text(BASE)
    path = folder / "study.toml"
    path.write_text(f'base = "base.toml"\n[factors]\n{factors}\n')
    return path


def _fake_run(study, run, pages=None):  # noqa: ARG001 (the signature of run_one)
    """A run's row without a simulation; run 1 dies of SIGKILL in a worker process (unless
    ``_fake_run.parent`` is None)."""
    parent = _fake_run.parent  # type: ignore[attr-defined]
    if run.number == 1 and parent is not None and os.getpid() != parent:
        os.kill(os.getpid(), signal.SIGKILL)
    return {"run": run.number, **dict(run.levels), "status": "ok", "reason": "fake",
            "cycles": 1000 + run.number}


def _rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_a_worker_that_dies_is_an_error_row_naming_the_signal_and_the_sweep_goes_on(
        tmp_path, monkeypatch):
    _fake_run.parent = os.getpid()  # type: ignore[attr-defined]
    monkeypatch.setattr(sweep_module, "run_one", _fake_run)
    path = sweep(load_study(_study(tmp_path)), tmp_path / "out", jobs=2)
    rows = _rows(path)
    assert [r["run"] for r in rows] == ["0", "1", "2", "3"]
    assert rows[1]["status"] == "error" and "SIGKILL" in rows[1]["reason"]
    assert all(r["status"] == "ok" for r in rows if r["run"] != "1")
    assert (tmp_path / "out" / "results.parquet").exists()


def test_a_torn_last_row_is_dropped_on_resume_and_its_run_runs_once_again(
        tmp_path, monkeypatch):
    _fake_run.parent = None  # type: ignore[attr-defined]  # no run dies
    monkeypatch.setattr(sweep_module, "run_one", _fake_run)
    study = load_study(_study(tmp_path))
    path = sweep(study, tmp_path / "out", jobs=1)
    whole = path.read_text()
    lines = whole.splitlines(keepends=True)
    path.write_text("".join(lines[:3]) + lines[3][:5])  # run 2's row cut in the middle
    notes: list[str] = []
    assert sweep(study, tmp_path / "out", jobs=1, report=notes.append) == path
    assert any("last row was cut short" in n and "dropped" in n for n in notes)
    assert path.read_text() == whole
    assert sum(1 for n in notes if n.startswith("run ")) == 2  # runs 2 and 3, each once


def test_a_run_whose_worker_died_is_retried_when_the_sweep_runs_again(tmp_path, monkeypatch):
    _fake_run.parent = os.getpid()  # type: ignore[attr-defined]
    monkeypatch.setattr(sweep_module, "run_one", _fake_run)
    study = load_study(_study(tmp_path))
    path = sweep(study, tmp_path / "out", jobs=2)
    assert _rows(path)[1]["reason"].startswith(sweep_module.OUTSIDE)
    _fake_run.parent = None  # type: ignore[attr-defined]  # this time run 1 lives
    notes: list[str] = []
    sweep(study, tmp_path / "out", jobs=1, report=notes.append)
    rows = _rows(path)
    assert [(r["run"], r["status"], r["cycles"]) for r in rows] == [
        ("0", "ok", "1000"), ("1", "ok", "1001"), ("2", "ok", "1002"), ("3", "ok", "1003")]
    assert any("retrying 1 run that failed outside the job (run 1)" in n for n in notes)
    assert [n.split(":")[0] for n in notes if n.startswith("run ")] == ["run 1"]


def _no_space(*_args, **_kwargs):
    raise OSError(28, "No space left on device")


def test_a_run_failing_with_an_oserror_is_a_row_failed_outside_the_job(tmp_path, monkeypatch):
    monkeypatch.setattr(sweep_module, "reused_backend", lambda _job: None)
    monkeypatch.setattr(sweep_module, "run_job", _no_space)
    study = load_study(_study(tmp_path))
    row = sweep_module.run_one(study, study.runs[0])
    assert (row["status"], row["reason"]) == (
        "error", f"{sweep_module.OUTSIDE}OSError: [Errno 28] No space left on device")


def test_a_rerun_retries_rows_failed_outside_the_job_and_retry_errors_every_error_row(
        tmp_path, monkeypatch):
    monkeypatch.setattr(sweep_module, "run_one", lambda _study, run, _pages=None: _row_of(run))
    study = load_study(_study(tmp_path))
    path = tmp_path / "out" / "results.csv"
    (tmp_path / "out").mkdir()
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, ["run", "feed", "radius", *sweep_module.METRICS],
                                restval="")
        writer.writeheader()
        writer.writerow({"run": 0, "feed": 600, "radius": 5, "status": "error",
                         "reason": "a job error"})
        writer.writerow({"run": 1, "feed": 600, "radius": 6, "status": "error",
                         "reason": f"{sweep_module.OUTSIDE}OSError: disk full"})
    sweep(study, tmp_path / "out", jobs=1)
    assert [(r["run"], r["status"]) for r in _rows(path)] == [
        ("0", "error"), ("1", "ok"), ("2", "ok"), ("3", "ok")]
    sweep(study, tmp_path / "out", jobs=1, retry_errors=True)
    assert [(r["run"], r["status"]) for r in _rows(path)] == [
        ("0", "ok"), ("1", "ok"), ("2", "ok"), ("3", "ok")]


def _row_of(run):
    return {"run": run.number, **dict(run.levels), "status": "ok", "reason": "fake"}


def test_a_row_that_cannot_be_written_is_not_left_half_in_the_table(small_fs):
    header = ["run", "a", *sweep_module.METRICS]
    table = small_fs / "results.csv"
    table.write_text(",".join(header) + "\n")
    with open(small_fs / "filler", "wb", buffering=0) as filler:  # fill the disk
        with contextlib.suppress(OSError):
            while True:
                filler.write(b"x" * 512)
    before = table.read_bytes()
    fd = os.open(table, os.O_WRONLY | os.O_APPEND)
    try:
        with pytest.raises(OSError, match="No space left"):
            sweep_module._append(fd, header, {"run": 0, "a": "x" * 8192, "status": "ok"})
    finally:
        os.close(fd)
    assert table.read_bytes() == before


def test_a_misspelt_factor_key_is_refused_before_any_run(tmp_path, capsys):
    study = _study(tmp_path, 'feed = [600]\nradius = [5]\n"servo.kpp" = [20.0, 30.0]')
    assert main(["sweep", str(study), "--out", str(tmp_path / "out"), "-q"]) == 2
    one_error(capsys.readouterr().err, "study.toml: every run: ", "unknown key servo.kpp")
    assert not (tmp_path / "out").exists()


def test_a_level_out_of_range_is_refused_naming_the_run(tmp_path, capsys):
    study = _study(tmp_path, 'feed = [600]\nradius = [5]\n"servo.kp" = [20.0, -3.0]')
    assert main(["sweep", str(study), "--out", str(tmp_path / "out"), "-q"]) == 2
    one_error(capsys.readouterr().err, "run 1 (feed = 600, radius = 5, servo.kp = -3.0)",
               "servo.kp")


def test_a_factor_named_as_a_metric_is_refused(tmp_path, capsys):
    study = _study(tmp_path, 'feed = [600]\nradius = [5]\n"status" = [1]')
    (tmp_path / "base.toml").write_text(BASE.replace("M30", "(status {status})\nM30"))
    assert main(["sweep", str(study), "--out", str(tmp_path / "out"), "-q"]) == 2
    one_error(capsys.readouterr().err, "factor status has the name of a column")


_SLOW_SWEEP = textwrap.dedent("""
    import os, sys, time
    from pathlib import Path
    from k37.sim.study import sweep
    def slow(study, run, pages=None):
        Path(sys.argv[2], f"worker-{os.getpid()}").write_text("")
        time.sleep(600)
    sweep.run_one = slow
    from k37.sim.cli import main
    sys.exit(main(["sweep", sys.argv[1], "--out", sys.argv[2] + "/out", "-j", "2", "-q"]))
""")


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    with open(f"/proc/{pid}/stat") as f:  # a zombie is dead, waiting for its parent
        return f.read().rsplit(")", 1)[1].split()[0] != "Z"


def _workers_of_a_slow_sweep(tmp_path: Path) -> tuple[subprocess.Popen, list[int]]:
    process = subprocess.Popen([sys.executable, "-c", _SLOW_SWEEP, str(_study(tmp_path)),
                                str(tmp_path)], stderr=subprocess.PIPE, text=True, env=ENV)
    deadline = time.monotonic() + 120
    while len(list(tmp_path.glob("worker-*"))) < 2:
        assert time.monotonic() < deadline and process.poll() is None, "no workers started"
        time.sleep(0.05)
    return process, [int(p.name.split("-")[1]) for p in tmp_path.glob("worker-*")]


def _gone(pids: list[int], seconds: float = 60) -> bool:
    deadline = time.monotonic() + seconds
    while any(_alive(pid) for pid in pids):
        if time.monotonic() > deadline:
            return False
        time.sleep(0.05)
    return True


@pytest.mark.parametrize(("sig", "code"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_stopped_sweep_ends_its_workers_and_says_where_its_rows_are(tmp_path, sig, code):
    process, workers = _workers_of_a_slow_sweep(tmp_path)
    process.send_signal(sig)
    _, err = process.communicate(timeout=120)
    assert process.returncode == code, err
    assert "the workers are stopped" in err and "Traceback" not in err
    assert _gone(workers)


def test_a_sweep_killed_outright_leaves_no_worker_behind(tmp_path):
    process, workers = _workers_of_a_slow_sweep(tmp_path)
    process.kill()
    process.communicate(timeout=60)
    assert _gone(workers)


# --- effects -------------------------------------------------------------------------------

def _table(folder: Path, rows: list[tuple[float, float, float, float]]) -> None:
    with open(folder / "results.csv", "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["run", "kp", "radius", "feed", "status", "reason", "circularity"])
        for n, (kp, radius, feed, y) in enumerate(rows):
            writer.writerow([n, kp, radius, feed, "ok", "", y])


def test_effects_of_a_small_study_prints_main_effects_and_what_the_surface_needs(
        tmp_path, capsys):
    _table(tmp_path, [(20, 5, 600, 4.0), (40, 5, 1200, 2.0), (20, 10, 1200, 4.3),
                      (40, 10, 600, 1.9)])
    assert main(["effects", str(tmp_path), "--metric", "circularity"]) == 0
    out = capsys.readouterr().out
    assert "kp: 20 -> 4.15, 40 -> 1.95" in out
    assert "no response surface: a second-order surface over 3 factors has 10 terms: 4 runs " \
           "are too few; it needs at least 10 runs" in out
    assert (tmp_path / "effects_circularity.png").exists()


def test_effects_of_a_wrong_metric_lists_the_metrics_of_the_table(tmp_path, capsys):
    _table(tmp_path, [(20, 5, 600, 4.0)])
    assert main(["effects", str(tmp_path), "--metric", "circ"]) == 2
    one_error(capsys.readouterr().err, "--metric circ: not a metric of ",
               "its metrics are circularity")


def test_effects_refuses_a_figure_it_could_not_write(tmp_path, capsys):
    _table(tmp_path, [(20, 5, 600, 4.0)])
    (tmp_path / "effects_circularity.png").mkdir()
    assert main(["effects", str(tmp_path), "--metric", "circularity"]) == 2
    one_error(capsys.readouterr().err, "effects_circularity.png: is a folder, not a file")
