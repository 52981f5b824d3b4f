"""Faults injected around the commands: unwritable outputs, full file systems, outputs that
are inputs, closed or full stdout, overflowing numbers, endless inputs, killed workers, SIGINT
and SIGTERM. Each ends in an exit code and one line per problem naming it, never a traceback;
every output is whole or absent; no worker outlives its command."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from k37.sim.cli import main
from k37.sim.cli.shared import EXIT_OUTPUT
from k37.sim.files import OutputError, atomic_open, check_outputs
from k37.sim.run import runner
from k37.sim.run.fst import convert_in_child
from tests.paths import ROOT
from tests.system.checks import ENV, one_error

CIRCLE = ROOT / "examples" / "circle.toml"
#: A folder in which no file can be made (procfs), on any Linux machine, root or not.
UNWRITABLE = Path("/proc/k37-no-such-folder-can-be-made")


def _no_simulation(*_: object) -> None:
    raise AssertionError("the machine was built: the outputs were not checked first")


# --- outputs proven writable before any work ----------------------------------------------

@pytest.mark.parametrize("option", ["--json", "--trace", "--plot", "--vcd", "--ballbar"])
def test_an_output_in_an_unwritable_folder_is_refused_before_the_run(
        monkeypatch, capsys, option):
    monkeypatch.setattr(runner, "build_backend", _no_simulation)
    suffix = {"--json": ".json", "--trace": ".csv", "--vcd": ".vcd"}.get(option, ".png")
    target = UNWRITABLE.parent / f"k37-out{suffix}"
    assert main(["run", str(CIRCLE), "-q", option, str(target)]) == 2
    one_error(capsys.readouterr().err, f"{option} {target}: cannot write in /proc: ")


def test_a_full_device_as_an_output_is_refused_before_the_run(monkeypatch, capsys):
    monkeypatch.setattr(runner, "build_backend", _no_simulation)
    assert main(["run", str(CIRCLE), "-q", "--json", "/dev/full"]) == 2
    one_error(capsys.readouterr().err, "--json /dev/full: cannot write: No space left")


def test_an_output_that_is_the_job_file_is_refused_and_the_job_is_untouched(
        tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(runner, "build_backend", _no_simulation)
    job = tmp_path / "job.toml"
    job.write_text(CIRCLE.read_text())
    assert main(["run", str(job), "-q", "--json", str(job)]) == 2
    one_error(capsys.readouterr().err, f"--json {job}: would overwrite the input {job}")
    assert job.read_text() == CIRCLE.read_text()


def test_an_output_that_is_the_program_file_is_refused(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(runner, "build_backend", _no_simulation)
    (tmp_path / "p.ngc").write_text("G21 G91 F600\nG01 X1\nM30\n")
    (tmp_path / "job.toml").write_text('[program]\nfile = "p.ngc"\n')
    assert main(["run", str(tmp_path / "job.toml"), "-q", "--trace",
                 str(tmp_path / "p.ngc")]) == 2
    one_error(capsys.readouterr().err, "would overwrite the input")


def test_two_outputs_at_one_path_are_refused(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(runner, "build_backend", _no_simulation)
    x = tmp_path / "X"
    assert main(["run", str(CIRCLE), "-q", "--json", str(x), "--trace", str(x)]) == 2
    one_error(capsys.readouterr().err, f"--trace {x}: is the same file as --json {x}")
    assert not x.exists()


def test_a_closed_stdout_is_refused_before_the_run(monkeypatch, capsys):
    monkeypatch.setattr(runner, "build_backend", _no_simulation)
    monkeypatch.setattr(sys, "stdout", None)
    assert main(["run", str(CIRCLE), "--json", "-"]) == 2
    one_error(capsys.readouterr().err, "--json stdout: closed")


def test_a_full_stdout_is_an_error_naming_it_and_the_files_are_written(tmp_path):
    with open("/dev/full", "w") as full:
        done = subprocess.run([sys.executable, "-m", "k37.sim.cli", "run", str(CIRCLE), "--json",
                               str(tmp_path / "r.json")], stdout=full, stderr=subprocess.PIPE,
                              text=True, env=ENV, timeout=600, check=False)
    assert done.returncode == EXIT_OUTPUT
    one_error(done.stderr, "stdout: not written: No space left on device")
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
    one_error(capsys.readouterr().err, f"{UNWRITABLE}: cannot write in /proc: ")


def test_a_folder_where_an_output_folder_should_be_a_file_is_refused(tmp_path, capsys):
    (tmp_path / "f").write_text("")
    assert main(["export-verilog", "-o", str(tmp_path / "f")]) == 2
    one_error(capsys.readouterr().err, "is a file, not a folder")


def test_plan_to_a_closed_or_full_stdout_is_an_error_not_a_traceback(monkeypatch, capsys):
    monkeypatch.setattr(sys, "stdout", None)
    assert main(["plan", str(CIRCLE)]) == 2
    one_error(capsys.readouterr().err, "stdout: closed")
    with open("/dev/full", "w") as full:
        done = subprocess.run([sys.executable, "-m", "k37.sim.cli", "plan", str(CIRCLE)],
                              stdout=full, stderr=subprocess.PIPE, text=True, env=ENV,
                              timeout=120, check=False)
    assert done.returncode == EXIT_OUTPUT
    one_error(done.stderr, "stdout: not written: No space left on device")


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
    one_error(capsys.readouterr().err, f"--vcd {wave}: not written: No space left on device")
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
    one_error(capsys.readouterr().err, "big.ngc:2:", message, "is outside")


@pytest.mark.parametrize(("step", "message"), [
    ("x:1e308@1", "beyond the drive's torque range"),
    ("x:0.01@1e308", "load step time must be >= 0 and <= "),
])
def test_an_overflowing_load_step_is_an_error(tmp_path, monkeypatch, capsys, step, message):
    monkeypatch.setattr(runner, "build_backend", _no_simulation)
    (tmp_path / "t.toml").write_text('[servo]\ndrive = "torque"\n[program]\n'
                                     'gcode = "G21 G91 F600\\nG01 X1\\nM30"\n')
    assert main(["run", str(tmp_path / "t.toml"), "-q", "--load-step", step]) == 2
    one_error(capsys.readouterr().err, message)


def test_a_time_limit_beyond_the_cycle_limit_leaves_the_cycle_limit(make_job):
    from dataclasses import replace

    from k37.firmware_model.job import RunConfig

    job = replace(make_job("G21 G91 F600\nG01 X1\nM30"), run=RunConfig(max_time_s=1e308))
    assert runner.cycle_limit(job, runner.RunOptions(max_cycles=5000))[0] == 5000


@pytest.mark.parametrize("argv", [["plan", "/dev/zero"], ["run", "/dev/zero"]])
def test_a_program_that_is_not_a_regular_file_is_refused(capsys, argv):
    assert main(argv) == 2
    one_error(capsys.readouterr().err, "/dev/zero: not a regular file")


def test_a_program_file_that_is_not_a_regular_file_is_refused(tmp_path, capsys):
    (tmp_path / "z.toml").write_text('[program]\nfile = "/dev/zero"\n')
    assert main(["plan", str(tmp_path / "z.toml")]) == 2
    one_error(capsys.readouterr().err, "program.file /dev/zero: not a regular file")


def test_a_program_beyond_the_size_limit_is_refused(tmp_path, monkeypatch, capsys):
    import k37.sim.files

    monkeypatch.setattr(k37.sim.files, "MAX_INPUT_BYTES", 1000)
    monkeypatch.setattr(k37.sim.files.read_input_text, "__kwdefaults__", {"encoding": "utf-8",
                                                                     "limit": 1000})
    (tmp_path / "long.ngc").write_text("G21 G91 F600\n" + "G01 X0.001\n" * 200 + "M30\n")
    assert main(["plan", str(tmp_path / "long.ngc")]) == 2
    one_error(capsys.readouterr().err, "more than the 1,000 bytes a job or program may have")


@pytest.mark.parametrize("text", ["", "(only a comment)\n; and another\n", "%\nM30\n%\n",
                                  "G21 G90 F100 S1000 M3\nG0 X0 Y0\nM5 M30\n"])
@pytest.mark.parametrize("command", ["plan", "run"])
def test_a_program_without_motion_is_one_error_naming_the_file(tmp_path, capsys, text,
                                                                command):
    (tmp_path / "still.ngc").write_text(text)
    assert main([command, str(tmp_path / "still.ngc"), "-q"][:2 if command == "plan" else 3]
                ) == 2
    one_error(capsys.readouterr().err, f"{tmp_path / 'still.ngc'}: no motion in the program")


def test_an_inline_program_without_motion_names_the_job(tmp_path, capsys):
    (tmp_path / "still.toml").write_text('[program]\ngcode = "M30"\n')
    assert main(["plan", str(tmp_path / "still.toml")]) == 2
    one_error(capsys.readouterr().err, "still.toml:program.gcode: no motion in the program")


def test_a_program_read_from_stdin_plans(monkeypatch, capsys):
    import io

    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(b"G21 G91 F600\nG01 X1\nM30\n")))
    assert main(["plan", "-"]) == 0
    assert "1 blocks, 1000 FP" in capsys.readouterr().out
