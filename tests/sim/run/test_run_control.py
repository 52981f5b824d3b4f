"""A run a person can stop and trust: outputs checked before the run, Ctrl-C, every limit in
every phase, progress against the program's plan, summaries with units and the end point,
faults reported when they happen, memory flat in the run's length."""

from __future__ import annotations

import io
import json
import math
import os
import signal
import subprocess
import sys
import threading
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from k37.firmware_model.feeds import FirmwareError, check_program
from k37.firmware_model.firmware import TIMER_TICK_SECONDS
from k37.firmware_model.job import MachineConfig, RunConfig, demo_job
from k37.sim.cli import main
from k37.sim.link.simulated import SimulatedLink
from k37.sim.run import runner
from k37.sim.run.contour import contour_errors, contour_summary
from k37.sim.run.jobfile import load_job
from k37.sim.run.output import summary, write_trace
from k37.sim.run.progress import Progress, ProgressPrinter
from k37.sim.run.report import HOW_FIELDS, validate
from k37.sim.run.runner import RunOptions, RunResult, run_job
from k37.sim.run.sampler import CHUNK_ROWS, PROGRESS_CYCLES, TRACE_COLUMNS, SampleStore
from tests.paths import ROOT


def _no_simulation(*_: object) -> None:
    raise AssertionError("the machine was built: the options were not checked first")


@pytest.mark.parametrize(("args", "message"), [
    (["--json", "nowhere/r.json"], "--json nowhere/r.json: the folder nowhere does not exist"),
    (["--trace", "nowhere/t.csv"], "--trace nowhere/t.csv: the folder nowhere does not exist"),
    (["--plot", "nowhere/p.png"], "--plot nowhere/p.png: the folder nowhere does not exist"),
    (["--vcd", "nowhere/v.vcd"], "--vcd nowhere/v.vcd: the folder nowhere does not exist"),
    (["--vcd", "v.vcd", "--gtkw", "nowhere/g.gtkw"], "--gtkw nowhere/g.gtkw: the folder"),
    (["--json", "."], "--json .: is a folder, not a file"),
    (["--plot", "p.xyz"], "--plot p.xyz: matplotlib cannot write the suffix .xyz; it writes "),
    (["--gtkw", "g.gtkw"], "--gtkw g.gtkw: needs --vcd"),
    (["--html", "nowhere/r.html"], "--html nowhere/r.html: the folder nowhere does not exist"),
    (["--html", "r.txt"], "--html r.txt: name the report .html"),
    (["--vcd", "v.ghw"], "--vcd v.ghw: the suffix .ghw names no waveform format; use .vcd or .fst"),
    (["--vcd", "v.vcd", "--vcd-start", "500", "--vcd-stop", "400"],
     "--vcd-start 500 must come before --vcd-stop 400"),
    (["--vcd", "v.vcd", "--vcd-start", "400", "--vcd-stop", "400"],
     "--vcd-start 400 must come before --vcd-stop 400"),
    (["--vcd", "v.vcd", "--vcd-start", "2000", "--max-cycles", "2000"],
     "--vcd-start 2,000 is at or past --max-cycles 2,000: the waveform window would never"),
])
def test_bad_outputs_exit_2_with_one_line_naming_the_option_before_any_simulation(
        tmp_path, monkeypatch, capsys, args, message):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(runner, "build_backend", _no_simulation)
    assert main(["run", *args]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("k37: error: ") and message in err, err
    assert list(tmp_path.iterdir()) == []


def test_plot_suffix_error_names_the_formats_matplotlib_writes(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["run", "--plot", "p.xyz"]) == 2
    formats = capsys.readouterr().err.split("it writes ")[1]
    assert {".png", ".pdf", ".svg"} <= set(formats.strip().split(", "))


@pytest.mark.parametrize("wave", ["w.vcd", "w.fst"])
def test_a_waveform_window_the_run_never_reached_leaves_no_file_and_warns(
        tmp_path, monkeypatch, capsys, job_file, wave):
    monkeypatch.chdir(tmp_path)
    job = job_file("G04 P0.05\nM30")
    assert main(["run", str(job), "--vcd", wave, "--vcd-start", "500000", "--gtkw",
                 "w.gtkw", "--json", "r.json", "--max-cycles", "1000000"]) == 0
    report = json.loads(Path("r.json").read_text())
    assert report["cycles"] < 500_000
    assert report["warnings"] == [f"--vcd {wave}: the run ended at cycle {report['cycles']:,}, "
                                  f"before --vcd-start 500,000: no waveform written (nor a "
                                  f"GTKWave save file)"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["job.toml", "r.json"]
    assert f"  warning: --vcd {wave}: the run ended" in capsys.readouterr().out


def test_ctrl_c_stops_the_run_writes_every_output_as_interrupted_and_exits_130(tmp_path):
    # --no-skip-idle: the demo then takes seconds; the VCD's temporary file (beside it, renamed
    # when whole) appears when the run begins.
    process = subprocess.Popen(
        [sys.executable, "-m", "k37.sim.cli", "run", "--no-skip-idle", "--json", "r.json",
         "--trace", "t.csv", "--vcd", "w.vcd", "--vcd-stop", "10"],
        cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)})
    deadline = time.monotonic() + 120
    while not list(tmp_path.glob(".w.vcd.*")) and process.poll() is None:
        assert time.monotonic() < deadline, "the run never began"
        time.sleep(0.01)
    time.sleep(0.3)
    sent = time.monotonic()
    process.send_signal(signal.SIGINT)
    out, err = process.communicate(timeout=60)
    latency = time.monotonic() - sent
    assert process.returncode == 130, err
    assert err.splitlines() == [err.strip()] and err.startswith("k37: interrupted at cycle ")
    assert "Traceback" not in out + err
    report = json.loads((tmp_path / "r.json").read_text())
    validate(report)
    assert report["status"] == "interrupted"
    assert report["reason"].startswith("stopped on request (Ctrl-C) at cycle ")
    assert 0 < report["cycles"] < 6_000_000 and report["cycles"] % PROGRESS_CYCLES == 0
    rows = (tmp_path / "t.csv").read_text().splitlines()
    assert len(rows) == 1 + report["path"]["samples"] == 1 + report["cycles"] // 1000
    assert out.startswith("k37 run demo: interrupted: stopped on request")
    assert latency < 10


def test_a_stop_request_ends_the_run_at_the_next_tick_with_status_interrupted():
    stop = threading.Event()
    stop.set()
    result = run_job(demo_job(), RunOptions(backend="cxxrtl", stop=stop))
    assert result.report["status"] == "interrupted"
    assert result.report["cycles"] == PROGRESS_CYCLES
    assert result.report["end_point"] == {"programmed": [0, 0], "actual": [
        result.report["axes"]["x"]["actual"], result.report["axes"]["y"]["actual"]],
        "program_ran": False, "reached": False}
    assert len(result.samples) == PROGRESS_CYCLES // 1000


def test_max_cycles_stops_a_dwell_at_the_limit(make_job):
    job = make_job("G21 G90 F600\nG01 X0.1\nG04 P200\nM30", MachineConfig(accel="none"))
    report = run_job(job, RunOptions(backend="cxxrtl", max_cycles=1_000_000)).report
    assert report["status"] == "timeout"
    assert report["cycles"] == 1_000_000
    assert report["reason"] == ("the cycle limit, --max-cycles 1,000,000, ran out at cycle "
                                "1,000,000")
    assert report["blocks"][0]["end_cycle"] is not None, "the limit came in the dwell"


def test_the_jobs_max_time_s_limits_simulated_time_exactly_with_status_timeout(make_job):
    job = make_job("G21 G90 F600\nG01 X5\nG04 P2\nM30")  # 0.5 s of motion, then 2 s of dwell
    job = replace(job, run=RunConfig(max_time_s=1.25))
    report = run_job(job, RunOptions(backend="cxxrtl")).report
    assert report["status"] == "timeout"
    assert report["cycles"] == 1_250_000  # inside the dwell, to the cycle
    assert report["reason"] == ("the job's limit, run.max_time_s = 1.25 s (1,250,000 cycles), "
                                "ran out at cycle 1,250,000")
    # The fewer cycles win: --max-cycles below the job's limit is the one that stops it.
    report = run_job(job, RunOptions(backend="cxxrtl", max_cycles=400_000)).report
    assert report["cycles"] == 400_000 and "--max-cycles 400,000" in report["reason"]


def test_a_dwell_too_long_to_count_is_refused_naming_its_line(make_job, tmp_path, capsys):
    gcode = "G21 G90\nG04 P" + "9" * 400 + "\nM30"
    with pytest.raises(FirmwareError, match=r"^t.ngc:2: G04 P: the dwell is longer than the "
                                            r"simulated clock can count \(2\^64 cycles"):
        check_program(make_job(gcode, source="t.ngc"))
    path = tmp_path / "t.ngc"
    path.write_text(gcode)
    assert main(["run", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"k37: error: {path}:2: G04 P:")


def test_a_long_finite_dwell_runs_into_the_cycle_limit(make_job):
    job = make_job("G04 P999999999999\nM30")  # 1e12 s: 32,000 years
    report = run_job(job, RunOptions(backend="cxxrtl", max_cycles=2_000_000)).report
    assert (report["status"], report["cycles"]) == ("timeout", 2_000_000)


def test_progress_follows_the_programs_planned_length_at_ticks_only(make_job):
    job = make_job("G21 G90 F600\nG01 X5\nG04 P2\nG01 X0\nM30")
    seen: list[Progress] = []
    report = run_job(job, RunOptions(backend="cxxrtl", sample_every=100,
                                     progress=seen.append)).report
    assert report["status"] == "ok"
    # At ticks only: no call per sample (10,000 samples a second here).
    assert len(seen) == report["cycles"] // PROGRESS_CYCLES
    fractions = [p.fraction for p in seen]
    assert fractions == sorted(fractions) and fractions[0] > 0 and fractions[-1] <= 1
    assert {p.line for p in seen} == {2, 3, 4}
    in_dwell = [p for p in seen if p.line == 3]
    # The dwell is 2 s of the plan's 0.5 + 2 + 0.5 s: it spans 1/6 .. 5/6 of the program.
    assert in_dwell and all(1 / 6 <= p.fraction <= 5 / 6 for p in in_dwell)
    assert all(p.eta is not None and p.eta >= 0 for p in seen)
    assert "% of the program, line 3, " in in_dwell[0].text()


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_is_one_refreshed_line_on_a_terminal_and_plain_lines_elsewhere():
    def feed(printer: ProgressPrinter) -> None:
        for wall in (0.1, 0.6, 1.0, 5.5, 6.0, 10.6):
            printer(Progress(int(wall * 1e6), wall / 20, 7, wall, 1e6))
        printer.finish()

    plain = io.StringIO()
    feed(ProgressPrinter(plain))
    lines = plain.getvalue().splitlines()
    assert len(lines) == 2 and "\r" not in plain.getvalue()  # at 5.5 s and 10.6 s
    assert lines[0].startswith("k37 run:  27.5% of the program, line 7, 5.500 s machine time")
    terminal = _Terminal()
    feed(ProgressPrinter(terminal))
    text = terminal.getvalue()
    assert text.count("\r") == 4 and text.endswith("\n") and text.count("\n") == 1


def test_summary_gives_every_figure_with_its_unit_and_whether_the_end_was_reached(make_job):
    result = run_job(make_job("G21 G90 F1200\nG01 X1 Y0.5\nM30"), RunOptions(backend="cxxrtl"))
    text = summary(result)
    assert "end point (1.000, 0.500) mm = (1000, 500) LSB: reached (within the in-position " \
           "zone, 10 LSB)" in text
    assert " s machine time in " in text and " s wall " in text
    for axis in ("x", "y"):
        line = next(line for line in text.splitlines() if line.startswith(f"  {axis}: "))
        assert line.count(" LSB") == 4 and line.count(" mm") == 2 and line.endswith(
            " V at the D/A)")


def test_the_readme_stall_example_raises_the_alarm():
    readme = (ROOT / "README.md").read_text()
    assert "k37 run examples/stall.toml --stall x" in readme
    result = run_job(load_job(ROOT / "examples" / "stall.toml"),
                     RunOptions(backend="cxxrtl", faults={"x": {"stall": 1}}))
    assert result.report["status"] == "alarm"
    assert result.report["axes"]["x"]["actual"] == 0
    assert result.report["axes"]["x"]["max_abs_error"] == 2501  # the first count beyond A


def test_the_demo_with_a_stalled_x_peaks_exactly_at_the_alarm_zone_and_does_not_alarm():
    # |error| > A alarms (``docs/chips/k3702.md``): the circle's diameter is A itself.
    report = run_job(demo_job(), RunOptions(backend="cxxrtl", faults={"x": {"stall": 1}})).report
    assert report["axes"]["x"]["max_abs_error"] == demo_job().machine.alarm_limit
    assert report["status"] == "ok"


def test_a_broken_encoder_line_is_reported_within_a_timer_tick_and_stops_the_run():
    report = run_job(demo_job(), RunOptions(backend="cxxrtl",
                                            faults={"y": {"break_a": 1}})).report
    tick = round(TIMER_TICK_SECONDS * 1e6)
    assert report["status"] == "fault"
    assert [(a["axis"], a["kind"]) for a in report["alarms"]] == [("y", "encoder_line_fault_a")]
    assert report["alarms"][0]["cycle"] < tick + 100
    assert report["cycles"] < tick + 200
    assert report["blocks"][0]["end_cycle"] is None
    assert not report["end_point"]["reached"]


@pytest.mark.parametrize(("low_feed", "faults", "options"), [
    (False, {"y": {"break_a": 1}}, {}),  # a routine reads a fault: the run stops there
    (False, {}, {"vcd_start": 19_980, "vcd_stop": 20_090, "max_cycles": 300_000}),  # traced
    (True, {}, {"max_cycles": 3_000_123, "sample_every": 97}),  # a limit inside a wait
    (True, {}, {"max_cycles": 2_000_000}),  # a limit on a tick: no routine there
])
def test_the_compiled_timer_poll_equals_the_hosts_own_loop(make_job, monkeypatch, tmp_path,
                                                           low_feed, faults, options):
    """The compiled backend runs the firmware's waits with their 50 Hz encoder polls itself
    (Host8085.wait_polling); the host's own loop of waits and bus reads gives the same
    report, samples and waveform."""
    job = (make_job("G21 G91 F5.3\nG03 X0 Y0 I0.5 J0\nM30") if low_feed else demo_job())

    def run(name: str) -> tuple[dict, np.ndarray, bytes]:
        vcd = tmp_path / f"{name}.vcd" if "vcd_start" in options else None
        result = run_job(job, RunOptions(backend="cxxrtl", faults=faults, vcd=vcd, **options))
        report = {k: v for k, v in result.report.items() if k not in HOW_FIELDS}
        return report, result.samples, vcd.read_bytes() if vcd else b""

    polled = []
    wait_polling = SimulatedLink.wait_polling

    def counted(link: SimulatedLink, *args: object) -> object:
        polled.append(result := wait_polling(link, *args))
        return result

    monkeypatch.setattr(SimulatedLink, "wait_polling", counted)
    compiled = run("compiled")
    assert polled and None not in polled  # the compiled backend ran every wait
    monkeypatch.setattr(SimulatedLink, "wait_polling", lambda *_: None)  # the host's loop
    host = run("host")
    assert host[0] == compiled[0]
    assert np.array_equal(host[1], compiled[1])
    assert host[2] == compiled[2]


def test_samples_stream_to_the_store_in_bounded_chunks(make_job, monkeypatch):
    chunks: list[int] = []
    append = SampleStore.append

    def spy(store: SampleStore, raw: np.ndarray) -> None:
        chunks.append(len(raw))
        append(store, raw)

    monkeypatch.setattr(SampleStore, "append", spy)
    job = make_job("G21 G90 F1200\nG01 X3\nM30")
    result = run_job(job, RunOptions(backend="cxxrtl", sample_every=1, max_cycles=300_000))
    assert sum(chunks) == result.store.rows == 300_000
    assert max(chunks) == CHUNK_ROWS and len(chunks) > 300_000 // CHUNK_ROWS
    cycles = np.concatenate([c[:, 0] for c in result.store.chunks(50_000)])
    assert np.array_equal(cycles, np.arange(1, 300_001))


def test_contour_error_streamed_in_chunks_equals_the_whole_arrays_bit_for_bit(make_job):
    job = make_job("G21 G90 F600\nG01 X2\nG02 X4 Y0 I1 J0\nG01 Y-1\nM30")
    blocks = list(enumerate((100, 40_000, 90_000)))
    rng = np.random.default_rng(5)
    n = 12_345
    raw = np.zeros((n, len(TRACE_COLUMNS)), dtype=np.int64)
    raw[:, 0] = np.arange(1, n + 1) * 10
    raw[:, 3] = rng.integers(-500, 4500, n)
    raw[:, 4] = rng.integers(-1500, 1500, n)
    store = SampleStore(12)
    for start in range(0, n, 1000):
        store.append(raw[start:start + 1000])
    whole = contour_errors(job, blocks, store.array())
    expected = (float(whole.max()), float(math.sqrt(np.mean(whole**2))))
    for leaf in (100, 1000, CHUNK_ROWS):
        assert contour_summary(job, blocks, store, leaf=leaf) == expected


def test_trace_csv_is_written_from_the_store_chunk_by_chunk(tmp_path, monkeypatch):
    monkeypatch.setattr(SampleStore, "chunks", lambda self: (
        self.read(start, start + 7) for start in range(0, self.rows, 7)))
    store = SampleStore(12)
    raw = np.arange(30 * len(TRACE_COLUMNS), dtype=np.int64).reshape(30, -1) * 137 - 2000
    store.append(raw)
    write_trace(RunResult({}, store, demo_job()), tmp_path / "t.csv")
    lines = (tmp_path / "t.csv").read_text().splitlines()
    assert lines[0] == ",".join(TRACE_COLUMNS) and len(lines) == 31
    volts = 10 * (raw[4, 7] - 2048) / 2048
    assert lines[5].split(",")[7] == f"{volts:.4f}"
    assert lines[5].split(",")[:3] == [str(v) for v in raw[4, :3]]


@pytest.mark.parametrize(("argv", "message"), [
    (["run", "--max-cycles", "-5"],
     "k37 run: error: argument --max-cycles: must be a positive integer, not -5 "
     "(see k37 run --help)"),
    (["run", "--no-such-option"],
     "k37 run: error: unrecognized arguments: --no-such-option (see k37 run --help)"),
    (["sweep", "study.toml", "--out", "o", "--extra"],
     "k37 sweep: error: unrecognized arguments: --extra (see k37 sweep --help)"),
    (["reproduce", "--quick"],
     "k37 reproduce: error: the following arguments are required: --out"),
    (["docs"], "k37 docs: error: the following arguments are required: -o/--output"),
])
def test_a_bad_argument_is_one_line_naming_the_command_and_the_option(
        tmp_path, monkeypatch, capsys, argv, message):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(message), err
    assert list(tmp_path.iterdir()) == []  # nothing written, docs/ least of all


def test_k37_version_prints_the_installed_version(capsys):
    from importlib import metadata

    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0
    assert capsys.readouterr().out == f"k37 {metadata.version('k37')}\n"


@pytest.mark.parametrize(("exists", "what"), [
    (False, "no such folder"), (True, "no results.csv in it")])
def test_k37_effects_on_a_folder_without_a_study_says_so_first(tmp_path, capsys, exists, what):
    folder = tmp_path / "study"
    if exists:
        folder.mkdir()
    assert main(["effects", str(folder), "--metric", "circularity"]) == 2
    err = capsys.readouterr().err
    assert err == (f"k37: error: {folder}: not a study ({what}; `k37 sweep STUDY --out "
                   f"{folder}` makes one)\n")


@pytest.mark.parametrize(("before", "after"), [(None, "1"), ("3", "3")])
def test_the_command_line_gives_numpys_blas_one_thread_unless_told_otherwise(
        monkeypatch, tmp_path, before, after):
    """OpenBLAS's idle threads spin a tenth of a CPU second per process: ``k37`` (and the
    study workers it starts, which inherit its environment) ask for one thread, as a user's
    own setting may override."""
    if before is None:
        monkeypatch.delenv("OPENBLAS_NUM_THREADS", raising=False)
    else:
        monkeypatch.setenv("OPENBLAS_NUM_THREADS", before)
    assert main(["docs", "--output", str(tmp_path)]) == 0
    assert os.environ["OPENBLAS_NUM_THREADS"] == after
