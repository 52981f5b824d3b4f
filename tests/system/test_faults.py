"""Faults injected around the commands: unwritable outputs, full file systems, outputs that
are inputs, closed or full stdout, overflowing numbers, endless inputs, killed workers, SIGINT
and SIGTERM. Each ends in an exit code and one line per problem naming it, never a traceback;
every output is whole or absent; no worker outlives its command."""

from __future__ import annotations

import contextlib
import csv
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from k37.sim.cli import main
from k37.sim.cli.shared import EXIT_OUTPUT
from k37.sim.files import OutputError, atomic_open, check_outputs
from k37.sim.run import runner
from k37.sim.run.fst import convert_in_child
from k37.sim.study import sweep as sweep_module
from k37.sim.study.studyfile import load_study
from k37.sim.study.sweep import sweep
from tests.paths import ROOT

CIRCLE = ROOT / "examples" / "circle.toml"
#: A folder in which no file can be made (procfs), on any Linux machine, root or not.
UNWRITABLE = Path("/proc/k37-no-such-folder-can-be-made")
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


def _no_simulation(*_: object) -> None:
    raise AssertionError("the machine was built: the outputs were not checked first")


def _one_error(err: str, *parts: str) -> None:
    assert err.count("\n") == 1 and err.startswith("k37: error: "), err
    assert "Traceback" not in err
    for part in parts:
        assert part in err, err


@pytest.fixture
def small_fs(tmp_path: Path) -> Iterator[Path]:
    """A 64 KiB tmpfs: a file system that fills (needs root and the right to mount)."""
    folder = tmp_path / "small"
    folder.mkdir()
    if os.geteuid() != 0:
        pytest.skip("mounting a small file system needs root")
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(folder)],
                          capture_output=True, text=True, check=False)
    if done.returncode:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.strip()}")
    try:
        yield folder
    finally:
        subprocess.run(["umount", "-l", str(folder)], check=False)


# --- outputs proven writable before any work ----------------------------------------------

@pytest.mark.parametrize("option", ["--json", "--trace", "--plot", "--vcd", "--ballbar"])
def test_an_output_in_an_unwritable_folder_is_refused_before_the_run(
        monkeypatch, capsys, option):
    monkeypatch.setattr(runner, "build_backend", _no_simulation)
    suffix = {"--json": ".json", "--trace": ".csv", "--vcd": ".vcd"}.get(option, ".png")
    target = UNWRITABLE.parent / f"k37-out{suffix}"
    assert main(["run", str(CIRCLE), "-q", option, str(target)]) == 2
    _one_error(capsys.readouterr().err, f"{option} {target}: cannot write in /proc: ")


def test_a_full_device_as_an_output_is_refused_before_the_run(monkeypatch, capsys):
    monkeypatch.setattr(runner, "build_backend", _no_simulation)
    assert main(["run", str(CIRCLE), "-q", "--json", "/dev/full"]) == 2
    _one_error(capsys.readouterr().err, "--json /dev/full: cannot write: No space left")


def test_an_output_that_is_the_job_file_is_refused_and_the_job_is_untouched(
        tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(runner, "build_backend", _no_simulation)
    job = tmp_path / "job.toml"
    job.write_text(CIRCLE.read_text())
    assert main(["run", str(job), "-q", "--json", str(job)]) == 2
    _one_error(capsys.readouterr().err, f"--json {job}: would overwrite the input {job}")
    assert job.read_text() == CIRCLE.read_text()


def test_an_output_that_is_the_program_file_is_refused(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(runner, "build_backend", _no_simulation)
    (tmp_path / "p.ngc").write_text("G21 G91 F600\nG01 X1\nM30\n")
    (tmp_path / "job.toml").write_text('[program]\nfile = "p.ngc"\n')
    assert main(["run", str(tmp_path / "job.toml"), "-q", "--trace",
                 str(tmp_path / "p.ngc")]) == 2
    _one_error(capsys.readouterr().err, "would overwrite the input")


def test_two_outputs_at_one_path_are_refused(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(runner, "build_backend", _no_simulation)
    x = tmp_path / "X"
    assert main(["run", str(CIRCLE), "-q", "--json", str(x), "--trace", str(x)]) == 2
    _one_error(capsys.readouterr().err, f"--trace {x}: is the same file as --json {x}")
    assert not x.exists()


def test_a_closed_stdout_is_refused_before_the_run(monkeypatch, capsys):
    monkeypatch.setattr(runner, "build_backend", _no_simulation)
    monkeypatch.setattr(sys, "stdout", None)
    assert main(["run", str(CIRCLE), "--json", "-"]) == 2
    _one_error(capsys.readouterr().err, "--json stdout: closed")


def test_a_full_stdout_is_an_error_naming_it_and_the_files_are_written(tmp_path):
    with open("/dev/full", "w") as full:
        done = subprocess.run([sys.executable, "-m", "k37.sim.cli", "run", str(CIRCLE), "--json",
                               str(tmp_path / "r.json")], stdout=full, stderr=subprocess.PIPE,
                              text=True, env=ENV, timeout=600, check=False)
    assert done.returncode == EXIT_OUTPUT
    _one_error(done.stderr, "stdout: not written: No space left on device")
    assert json.loads((tmp_path / "r.json").read_text())["status"] == "ok"


@pytest.mark.parametrize("argv", [
    ["sweep", str(ROOT / "examples" / "study_kp.toml"), "--out", str(UNWRITABLE)],
    ["reproduce", "--quick", "--out", str(UNWRITABLE)],
    ["export-verilog", "-o", str(UNWRITABLE)],
    ["synth", "--work-dir", str(UNWRITABLE)],
    ["docs", "-o", str(UNWRITABLE)],
], ids=["sweep", "reproduce", "export-verilog", "synth", "docs"])
def test_every_command_refuses_an_unwritable_output_folder_before_any_work(capsys, argv):
    assert main(argv) == 2
    _one_error(capsys.readouterr().err, f"{UNWRITABLE}: cannot write in /proc: ")


def test_a_folder_where_an_output_folder_should_be_a_file_is_refused(tmp_path, capsys):
    (tmp_path / "f").write_text("")
    assert main(["export-verilog", "-o", str(tmp_path / "f")]) == 2
    _one_error(capsys.readouterr().err, "is a file, not a folder")


def test_plan_to_a_closed_or_full_stdout_is_an_error_not_a_traceback(monkeypatch, capsys):
    monkeypatch.setattr(sys, "stdout", None)
    assert main(["plan", str(CIRCLE)]) == 2
    _one_error(capsys.readouterr().err, "stdout: closed")
    with open("/dev/full", "w") as full:
        done = subprocess.run([sys.executable, "-m", "k37.sim.cli", "plan", str(CIRCLE)],
                              stdout=full, stderr=subprocess.PIPE, text=True, env=ENV,
                              timeout=120, check=False)
    assert done.returncode == EXIT_OUTPUT
    _one_error(done.stderr, "stdout: not written: No space left on device")


def test_the_check_names_a_device_written_in_place_as_writable(tmp_path):
    check_outputs({"--json": "/dev/null", "--trace": tmp_path / "t.csv"})
    with pytest.raises(OutputError, match="is a folder, not a file"):
        check_outputs({"--json": tmp_path})


# --- writes that fail during or after the work ---------------------------------------------

def test_an_interrupted_atomic_write_leaves_the_old_file_and_no_partial_one(tmp_path):
    target = tmp_path / "r.json"
    target.write_text("old")
    def write_half() -> None:
        with atomic_open(target) as f:
            f.write("new, half")
            raise RuntimeError("the writer failed")

    with pytest.raises(RuntimeError, match="the writer failed"):
        write_half()
    assert target.read_text() == "old" and list(tmp_path.iterdir()) == [target]


def test_a_full_disk_costs_only_the_outputs_on_it_each_reported_by_name(
        tmp_path, small_fs, capsys):
    trace, wave, report = small_fs / "t.csv", small_fs / "w.fst", tmp_path / "r.json"
    assert main(["run", str(CIRCLE), "-q", "--trace", str(trace), "--vcd", str(wave),
                 "--vcd-stop", "2000", "--json", str(report)]) == EXIT_OUTPUT
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert f"k37: error: --trace {trace}: not written: No space left on device" in err
    assert f"k37: error: --vcd {wave}: not written: " in err
    written = json.loads(report.read_text())
    assert written["status"] == "ok"
    assert any(w.startswith(f"--trace {trace}: not written") for w in written["warnings"])
    assert list(small_fs.iterdir()) == []  # no partial file left


def test_a_waveform_that_fills_the_disk_is_reported_and_removed(tmp_path, small_fs, capsys):
    wave = small_fs / "w.vcd"
    assert main(["run", str(CIRCLE), "-q", "--vcd", str(wave), "--vcd-stop", "2000",
                 "--json", str(tmp_path / "r.json")]) == EXIT_OUTPUT
    _one_error(capsys.readouterr().err, f"--vcd {wave}: not written: No space left on device")
    assert list(small_fs.iterdir()) == []


def test_a_failed_fst_conversion_is_an_error_message_not_a_signal(tmp_path):
    bad = tmp_path / "bad.vcd"
    bad.write_text("$timescale 7 parsecs $end\n")
    with pytest.raises(OSError, match="unreadable VCD time scale"):
        convert_in_child(bad, tmp_path / "w.fst")


# --- signals, overflows and endless inputs -------------------------------------------------

def _start_run(tmp_path: Path) -> subprocess.Popen:
    """``k37 run`` of the demo, slow enough to be stopped (every cycle evaluated), once its
    waveform's temporary file shows that the run has begun."""
    process = subprocess.Popen(
        [sys.executable, "-m", "k37.sim.cli", "run", "--no-skip-idle", "--json", "r.json",
         "--trace", "t.csv", "--vcd", "w.vcd", "--vcd-stop", "10"],
        cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV)
    deadline = time.monotonic() + 300
    while not list(tmp_path.glob(".w.vcd.*")) and process.poll() is None:
        assert time.monotonic() < deadline, "the run never began"
        time.sleep(0.01)
    return process


def test_sigterm_stops_a_run_as_ctrl_c_does_and_exits_143(tmp_path):
    process = _start_run(tmp_path)
    time.sleep(0.2)
    process.send_signal(signal.SIGTERM)
    _, err = process.communicate(timeout=120)
    assert process.returncode == 143, err
    assert err.startswith("k37: stopped by SIGTERM at cycle ") and "Traceback" not in err
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["status"] == "interrupted"
    assert report["reason"].startswith("stopped by SIGTERM at cycle ")
    rows = (tmp_path / "t.csv").read_text().splitlines()
    assert len(rows) == 1 + report["path"]["samples"]
    assert (tmp_path / "w.vcd").exists() and not list(tmp_path.glob(".*partial*"))


def test_sigterm_before_the_run_exits_143_with_one_line(tmp_path):
    process = subprocess.Popen(
        [sys.executable, "-c", "import time, sys; from k37.sim.cli import main; "
         "from k37.sim.run import jobfile; load = jobfile.load_job; "
         "jobfile.load_job = lambda *a, **k: (print('loading', flush=True), time.sleep(60), "
         "load(*a, **k))[2]; sys.exit(main(['run', '-q']))"],
        cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV)
    assert process.stdout is not None
    assert process.stdout.readline() == "loading\n"
    process.send_signal(signal.SIGTERM)
    _, err = process.communicate(timeout=120)
    assert process.returncode == 143
    assert err == "k37: stopped by SIGTERM; nothing written\n"


@pytest.mark.parametrize(("program", "message"), [
    (f"G21 G90 F600\nG02 X10 Y0 R{'9' * 309}\nM30\n", "the radius "),
    (f"G21 G90 F600\nG01 X{'9' * 309}\nM30\n", "the position "),
])
def test_an_overflowing_gcode_number_is_an_error_naming_its_word(tmp_path, monkeypatch,
                                                                 capsys, program, message):
    monkeypatch.setattr(runner, "build_backend", _no_simulation)
    (tmp_path / "big.ngc").write_text(program)
    assert main(["run", str(tmp_path / "big.ngc"), "-q"]) == 2
    _one_error(capsys.readouterr().err, "big.ngc:2:", message, "is outside")


@pytest.mark.parametrize(("step", "message"), [
    ("x:1e308@1", "beyond the drive's torque range"),
    ("x:0.01@1e308", "load step time must be >= 0 and <= "),
])
def test_an_overflowing_load_step_is_an_error(tmp_path, monkeypatch, capsys, step, message):
    monkeypatch.setattr(runner, "build_backend", _no_simulation)
    (tmp_path / "t.toml").write_text('[servo]\ndrive = "torque"\n[program]\n'
                                     'gcode = "G21 G91 F600\\nG01 X1\\nM30"\n')
    assert main(["run", str(tmp_path / "t.toml"), "-q", "--load-step", step]) == 2
    _one_error(capsys.readouterr().err, message)


def test_a_time_limit_beyond_the_cycle_limit_leaves_the_cycle_limit(make_job):
    from dataclasses import replace

    from k37.firmware_model.job import RunConfig

    job = replace(make_job("G21 G91 F600\nG01 X1\nM30"), run=RunConfig(max_time_s=1e308))
    assert runner.cycle_limit(job, runner.RunOptions(max_cycles=5000))[0] == 5000


@pytest.mark.parametrize("argv", [["plan", "/dev/zero"], ["run", "/dev/zero"]])
def test_a_program_that_is_not_a_regular_file_is_refused(capsys, argv):
    assert main(argv) == 2
    _one_error(capsys.readouterr().err, "/dev/zero: not a regular file")


def test_a_program_file_that_is_not_a_regular_file_is_refused(tmp_path, capsys):
    (tmp_path / "z.toml").write_text('[program]\nfile = "/dev/zero"\n')
    assert main(["plan", str(tmp_path / "z.toml")]) == 2
    _one_error(capsys.readouterr().err, "program.file /dev/zero: not a regular file")


def test_a_program_beyond_the_size_limit_is_refused(tmp_path, monkeypatch, capsys):
    import k37.sim.files

    monkeypatch.setattr(k37.sim.files, "MAX_INPUT_BYTES", 1000)
    monkeypatch.setattr(k37.sim.files.read_input_text, "__kwdefaults__", {"encoding": "utf-8",
                                                                     "limit": 1000})
    (tmp_path / "long.ngc").write_text("G21 G91 F600\n" + "G01 X0.001\n" * 200 + "M30\n")
    assert main(["plan", str(tmp_path / "long.ngc")]) == 2
    _one_error(capsys.readouterr().err, "more than the 1,000 bytes a job or program may have")


@pytest.mark.parametrize("text", ["", "(only a comment)\n; and another\n", "%\nM30\n%\n",
                                  "G21 G90 F100 S1000 M3\nG0 X0 Y0\nM5 M30\n"])
@pytest.mark.parametrize("command", ["plan", "run"])
def test_a_program_without_motion_is_one_error_naming_the_file(tmp_path, capsys, text,
                                                                command):
    (tmp_path / "still.ngc").write_text(text)
    assert main([command, str(tmp_path / "still.ngc"), "-q"][:2 if command == "plan" else 3]
                ) == 2
    _one_error(capsys.readouterr().err, f"{tmp_path / 'still.ngc'}: no motion in the program")


def test_an_inline_program_without_motion_names_the_job(tmp_path, capsys):
    (tmp_path / "still.toml").write_text('[program]\ngcode = "M30"\n')
    assert main(["plan", str(tmp_path / "still.toml")]) == 2
    _one_error(capsys.readouterr().err, "still.toml:program.gcode: no motion in the program")


def test_a_program_read_from_stdin_plans(monkeypatch, capsys):
    import io

    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(b"G21 G91 F600\nG01 X1\nM30\n")))
    assert main(["plan", "-"]) == 0
    assert "1 blocks, 1000 FP" in capsys.readouterr().out


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
    _one_error(capsys.readouterr().err, "study.toml: every run: ", "unknown key servo.kpp")
    assert not (tmp_path / "out").exists()


def test_a_level_out_of_range_is_refused_naming_the_run(tmp_path, capsys):
    study = _study(tmp_path, 'feed = [600]\nradius = [5]\n"servo.kp" = [20.0, -3.0]')
    assert main(["sweep", str(study), "--out", str(tmp_path / "out"), "-q"]) == 2
    _one_error(capsys.readouterr().err, "run 1 (feed = 600, radius = 5, servo.kp = -3.0)",
               "servo.kp")


def test_a_factor_named_as_a_metric_is_refused(tmp_path, capsys):
    study = _study(tmp_path, 'feed = [600]\nradius = [5]\n"status" = [1]')
    (tmp_path / "base.toml").write_text(BASE.replace("M30", "(status {status})\nM30"))
    assert main(["sweep", str(study), "--out", str(tmp_path / "out"), "-q"]) == 2
    _one_error(capsys.readouterr().err, "factor status has the name of a column")


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
    _one_error(capsys.readouterr().err, "--metric circ: not a metric of ",
               "its metrics are circularity")


def test_effects_refuses_a_figure_it_could_not_write(tmp_path, capsys):
    _table(tmp_path, [(20, 5, 600, 4.0)])
    (tmp_path / "effects_circularity.png").mkdir()
    assert main(["effects", str(tmp_path), "--metric", "circularity"]) == 2
    _one_error(capsys.readouterr().err, "effects_circularity.png: is a folder, not a file")
