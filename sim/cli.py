"""The ``k37`` command line."""

from __future__ import annotations

import argparse
import math
import os
import signal
import sys
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

__all__ = ["main"]


#: Exit code of a command stopped by Ctrl-C (128 + SIGINT, as a shell reports it); a
#: command stopped by SIGTERM exits 128 + SIGTERM = 143.
EXIT_INTERRUPTED = 130


class _Stop:
    """The signal that last stopped a command (SIGINT or SIGTERM)."""

    signal = signal.SIGINT


@contextmanager
def _signals_interrupt() -> Iterator[None]:
    """While it lasts, SIGTERM stops a command as Ctrl-C does (KeyboardInterrupt), so outputs
    are finished or removed and worker processes ended; :func:`_interrupted` gives the exit
    code. (Only in the main thread: elsewhere signals cannot be handled.)"""
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum: int, _: object) -> None:
        _Stop.signal = signal.Signals(signum)
        raise KeyboardInterrupt

    _Stop.signal = signal.SIGINT
    previous = {s: signal.signal(s, handler) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, before in previous.items():
            signal.signal(s, signal.SIG_DFL if before is None else before)


def _interrupted(signum: signal.Signals | None = None) -> int:
    """The exit code of a command stopped by ``signum`` (default: the last signal)."""
    return 128 + (signum or _Stop.signal)


def _stopped(signum: signal.Signals | None = None) -> str:
    """How a command was stopped, in words."""
    signum = signum or _Stop.signal
    return "interrupted" if signum == signal.SIGINT else f"stopped by {signum.name}"


def _check(files: Sequence[tuple[str, str | Path | None]] = (), *,
           folders: dict[str, str | Path | None] | None = None,
           inputs: Sequence[str | Path | None] = (), stdout: bool = True) -> bool:
    """:func:`sim.files.check_outputs`, its error printed: whether the outputs can be
    written."""
    from sim.files import OutputError, check_outputs

    try:
        check_outputs(files, folders=folders, inputs=inputs, stdout=stdout)
    except OutputError as e:
        _print_error(e)
        return False
    return True


def _stdout(write: Callable[[], object]) -> int:
    """Print to stdout with ``write``: 0, or 1 with one error line if stdout fails (full,
    closed)."""
    from sim.files import why

    try:
        write()
        sys.stdout.flush()
    except OSError as e:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        print(f"k37: error: stdout: not written: {why(e)}", file=sys.stderr)
        return 1
    return 0


def _cmd_docs(args: argparse.Namespace) -> int:
    from sim.docs import documents

    if not _check(folders={"-o": args.output}):
        return 2
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    for name, text in documents().items():
        (out / name).write_text(text)
        print(f"k37 docs: wrote {out / name}")
    return 0


def _load_step(text: str) -> tuple[str, float, float]:
    """``AXIS:NM@SECONDS`` of ``--load-step``."""
    try:
        axis, rest = text.split(":", 1)
        torque, at_s = rest.split("@", 1)
        numbers = float(torque), float(at_s)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not AXIS:NM@SECONDS (e.g. x:0.05@1.5)") \
            from None
    if not all(map(math.isfinite, numbers)):
        raise argparse.ArgumentTypeError(f"{text!r}: the torque and the time must be finite "
                                         f"numbers")
    return axis, *numbers


def _settle(text: str) -> float:
    """A ``--ballbar-settle`` angle: a finite number of degrees >= 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of degrees") from None
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"{text!r}: give a number of degrees >= 0")
    return value


def _cmd_run(args: argparse.Namespace) -> int:
    from firmware_model.firmware import FirmwareError
    from firmware_model.gcode.parser import GcodeError
    from sim.files import STDIO
    from sim.run.ballbar import BallbarError, check_settle
    from sim.run.jobfile import JobError, load_job, load_step_fault
    from sim.run.output import OutputError, add_ballbar, check_outputs, write_outputs
    from sim.run.progress import ProgressPrinter
    from sim.run.runner import OptionError, RunOptions, run_job

    progress = None if args.quiet else ProgressPrinter(sys.stderr)
    try:
        job = load_job(args.job, frontend=args.frontend, arc_tolerance=args.arc_tolerance)
        check_outputs(json_path=args.json, trace=args.trace, plot=args.plot, vcd=args.vcd,
                      gtkw=args.gtkw, ballbar=args.ballbar,
                      inputs=[args.job, job.program.source],
                      stdout=args.json == STDIO or not args.quiet)
        if args.ballbar:
            try:
                check_settle(job, args.ballbar_settle)
            except BallbarError as e:
                raise OptionError(f"--ballbar-settle {args.ballbar_settle:g}: {e}") from None
        faults = {axis: {"stall": 1} for axis in args.stall}
        for axis in args.break_line:
            faults.setdefault(axis, {})["break_a"] = 1
        for axis, torque, at_s in args.load_step:
            try:
                faults.setdefault(axis, {}).update(load_step_fault(job, axis, torque, at_s))
            except ValueError as e:
                raise OptionError(f"--load-step {axis}:{torque:g}@{at_s:g}: {e}") from None
        options = RunOptions(backend=args.backend, max_cycles=args.max_cycles,
                             sample_every=args.sample_every, vcd=args.vcd,
                             vcd_start=args.vcd_start, vcd_stop=args.vcd_stop,
                             signals=tuple(g for g in args.signals.split(",") if g),
                             progress=progress, faults=faults, skip_idle=not args.no_skip_idle,
                             sigint=True)
        result = run_job(job, options)
    except (OutputError, OptionError, JobError, GcodeError, FirmwareError) as e:
        _print_error(e)
        return 2
    except KeyboardInterrupt:  # outside the run itself (building the machine, the report)
        print(f"k37: {_stopped()}; nothing written", file=sys.stderr)
        return _interrupted()
    finally:
        if progress is not None:
            progress.finish()
    outputs = [str(path) for path in (args.ballbar, args.trace, args.plot, args.gtkw)
               if path is not None] + ([args.json] if args.json not in (None, STDIO) else [])
    stopped = result.report["status"] == "interrupted"
    announced = bool(outputs) and not args.quiet and bool(args.plot or args.ballbar
                                                          or args.trace or stopped)
    if announced:
        head = f"{_stopped(result.stopped_by)} at cycle {result.report['cycles']:,}; " \
            if stopped else ""
        print(f"k37: {head}writing {', '.join(outputs)} ...", file=sys.stderr, flush=True)
    try:
        failures = add_ballbar(result, args.ballbar, args.ballbar_settle) if args.ballbar else []
        failures += write_outputs(result, json_path=args.json, trace=args.trace, plot=args.plot,
                                  gtkw=args.gtkw, vcd=args.vcd, vcd_start=args.vcd_start,
                                  quiet=args.quiet)
    except KeyboardInterrupt:
        print(f"k37: {_stopped()} while writing the outputs; those not yet written are not "
              f"written (no partial files)", file=sys.stderr)
        return _interrupted()
    for failure in failures:
        print(f"k37: error: {failure}", file=sys.stderr)
    if stopped:
        if failures or not announced:  # else the line naming what it writes said it all
            written = "outputs written" if not failures else "the other outputs written"
            print(f"k37: {_stopped(result.stopped_by)} at cycle {result.report['cycles']:,}; "
                  f"{written}", file=sys.stderr)
        return _interrupted(result.stopped_by)
    return 0 if result.ok and not failures else 1


def _print_error(e: Exception) -> None:
    """One ``k37: error:`` line per error (a program's errors come all at once)."""
    for line in str(e).splitlines() or [""]:
        print(f"k37: error: {line}", file=sys.stderr)


def _cmd_plan(args: argparse.Namespace) -> int:
    import json

    from firmware_model.firmware import FirmwareError, check_program, clamped_feeds
    from firmware_model.gcode.parser import GcodeError
    from sim.run.jobfile import JobError, load_job
    from sim.run.plan import plan_rows, plan_table

    if not _check():
        return 2
    try:
        job = load_job(args.job, frontend=args.frontend, arc_tolerance=args.arc_tolerance)
        check_program(job)
    except (JobError, GcodeError, FirmwareError) as e:
        _print_error(e)
        return 2
    if args.json:
        text = json.dumps({"program": job.program.to_dict(), "items": plan_rows(job)}) + "\n"
    else:
        text = plan_table(job)
    code = _stdout(lambda: sys.stdout.write(text))
    for warning in (*job.program.notes, *clamped_feeds(job)):
        print(f"k37: warning: {warning}", file=sys.stderr)
    return code


def _cmd_reproduce(args: argparse.Namespace) -> int:
    from sim.reproduce.experiments import reproduce

    def progress(message: str) -> None:
        if not args.quiet:
            print(f"k37 reproduce: {message}", file=sys.stderr, flush=True)

    out = Path(args.out)
    if not _check(folders={"--out": out}):
        return 2
    try:
        result = reproduce(out, quick=args.quick, progress=progress)
    except KeyboardInterrupt:
        print(f"k37 reproduce: {_stopped()}; the workers are stopped", file=sys.stderr)
        return _interrupted()
    except OSError as e:
        from sim.files import why

        print(f"k37: error: {e.filename or out}: not written: {why(e)}", file=sys.stderr)
        return 1
    failed = [row for row in result.rows if not row.passed]

    def lines() -> None:
        print(f"k37 reproduce: {len(result.rows) - len(failed)} of {len(result.rows)} rows "
              f"pass ({result.seconds:.0f} s); wrote {out / 'report.md'} and "
              f"{sum(1 for s in result.sections if s.figure)} figures")
        for row in failed:
            print(f"  FAIL: {row.what}: {row.emulator} (tolerance: {row.tolerance})")

    return _stdout(lines) or (0 if not failed else 1)


def _cmd_sweep(args: argparse.Namespace) -> int:
    from sim.run.jobfile import JobError
    from sim.study.studyfile import load_study
    from sim.study.sweep import SweepError, sweep

    def progress(message: str) -> None:
        if not args.quiet:
            print(f"k37 sweep: {message}", file=sys.stderr, flush=True)

    out = Path(args.out)
    try:
        study = load_study(args.study)
    except JobError as e:
        _print_error(e)
        return 2
    outputs = [("", out / "results.csv"), ("", out / "results.parquet")] if out.is_dir() else []
    if not _check(outputs, folders={"--out": out},
                  inputs=[args.study, study.base_path, *study.inputs]):
        return 2
    try:
        path = sweep(study, out, jobs=args.jobs, scheduler=args.scheduler, report=progress)
    except (JobError, SweepError) as e:
        _print_error(e)
        return 2
    except OSError as e:
        from sim.files import why

        print(f"k37: error: {e.filename or out}: {why(e)}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"k37 sweep: {_stopped()}; the workers are stopped and the finished runs are in "
              f"{out / 'results.csv'} (run the same command to go on)", file=sys.stderr)
        return _interrupted()
    return _stdout(lambda: print(f"k37 sweep: {len(study.runs)} runs of {study.name} "
                                 f"({study.design}) in {path} and "
                                 f"{path.with_suffix('.parquet')}"))


def _cmd_effects(args: argparse.Namespace) -> int:
    import csv

    from sim.files import atomic_path, why
    from sim.study.analysis import (
        AnalysisError,
        effects_figure,
        main_effects,
        response_surface,
        surface_needs,
    )

    table = Path(args.dir) / "results.csv"
    figure = Path(args.dir) / f"effects_{args.metric}.png"
    if not _check([("", figure)], inputs=[table]):
        return 2
    try:
        with open(table, newline="") as f:
            reader = csv.DictReader(f)
            header = list(reader.fieldnames or [])
            rows = [r for r in reader if r.get("status") == "ok"]
        if "status" not in header or header[:1] != ["run"]:
            raise ValueError("no run and status columns")
    except (OSError, ValueError, csv.Error) as e:
        print(f"k37: error: {table}: not a results table ({why(e)})", file=sys.stderr)
        return 2
    study_factors = header[1:header.index("status")]
    metrics = [c for c in header[header.index("status") + 1:] if c != "reason"]
    if args.metric not in metrics:
        print(f"k37: error: --metric {args.metric}: not a metric of {table}; its metrics are "
              f"{', '.join(metrics)}", file=sys.stderr)
        return 2
    factors = args.factors.split(",") if args.factors else study_factors
    unknown = [f for f in factors if f not in study_factors]
    if unknown:
        print(f"k37: error: --factors {unknown[0]}: not a factor of {table}; its factors are "
              f"{', '.join(study_factors)}", file=sys.stderr)
        return 2
    try:
        effects = main_effects(rows, factors, args.metric)
        needs = surface_needs(rows, factors)
        surface = response_surface(rows, factors, args.metric) if needs is None else None
    except AnalysisError as e:
        print(f"k37: error: {table}: {e}", file=sys.stderr)
        return 2

    def lines() -> None:
        print(f"main effects on {args.metric} ({len(rows)} runs with status ok):")
        for factor, points in effects.items():
            print(f"  {factor}: " + ", ".join(f"{lv:g} -> {m:.4g}" for lv, m in points))
        if surface is None:
            print(f"no response surface: {needs}")
            return
        print(f"second-order response surface (the motion-errors paper's eq (19), "
              f"coded factors), "
              f"R^2 = {surface.r_squared:.4f}:")
        for term, beta in zip(surface.terms, surface.coefficients, strict=True):
            print(f"  {term:>30s}  {beta:+.5g}")
        if surface.stationary is not None:
            print("  stationary point (eq (20)): " + ", ".join(
                f"{f} = {v:.4g}" for f, v in zip(surface.factors, surface.stationary,
                                                  strict=True)))

    if _stdout(lines):
        return 1
    try:
        with atomic_path(figure) as tmp:
            effects_figure(effects, args.metric, f"{table}: main effects").savefig(tmp,
                                                                                   dpi=110)
    except OSError as e:
        print(f"k37: error: {figure}: not written: {why(e)}", file=sys.stderr)
        return 1
    return _stdout(lambda: print(f"k37 effects: wrote {figure}"))


def _cmd_export_verilog(args: argparse.Namespace) -> int:
    from sim.files import why
    from sim.fpga.export import export_verilog

    if not _check(folders={"-o": args.output}):
        return 2
    try:
        paths = export_verilog(args.block or None, Path(args.output))
    except OSError as e:
        print(f"k37: error: {e.filename or args.output}: not written: {why(e)}",
              file=sys.stderr)
        return 1
    return _stdout(lambda: print("\n".join(f"k37 export-verilog: wrote {p}" for p in paths)))


def _cmd_synth(args: argparse.Namespace) -> int:
    from sim.fpga.synth import synthesize

    if not _check(folders={"--work-dir": args.work_dir}):
        return 2
    try:
        report = synthesize(args.device, args.block or None,
                            work_dir=Path(args.work_dir) if args.work_dir else None)
    except (ImportError, FileNotFoundError) as e:
        print(f"k37: error: synthesis needs the fpga extra (pip install -e '.[fpga]'): {e}",
              file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"k37 synth: {_stopped()}", file=sys.stderr)
        return _interrupted()
    if _stdout(lambda: print(report.format_table())):
        return 1
    for failure in report.failures:
        print(f"k37 synth: {failure}", file=sys.stderr)
    return 0 if report.ok else 1


def _positive_int(text: str) -> int:
    value = int(text.replace("_", ""))
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, not {text}")
    return value


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="k37", description="Cycle-accurate emulator of the TOKO KM3701/KM3702 NC chipset.")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    from hdl.chipset.map import ALL_AXES
    from sim.backends.factory import BACKEND_NAMES

    p = sub.add_parser("run", help="run a job (TOML or G-code); no job: the built-in demo")
    p.add_argument("job", nargs="?", help="job file: .toml, or G-code run on the default machine")
    p.add_argument("--backend", choices=BACKEND_NAMES, default=BACKEND_NAMES[0],
                   help="simulation backend (auto: compiled when a C++ compiler exists)")
    p.add_argument("--max-cycles", type=_positive_int, default=None,
                   help="stop after this many clock cycles (default: twice the program's "
                        "planned machine time and 10 s)")
    p.add_argument("--sample-every", type=_positive_int, default=1000,
                   help="sample the machine every N cycles for trace, plot and path error")
    p.add_argument("--no-skip-idle", action="store_true",
                   help="evaluate every cycle, even where the machine provably stands still "
                        "(results are identical; for timing comparisons)")
    p.add_argument("--json", metavar="PATH", help="write the JSON report ('-': stdout)")
    p.add_argument("--trace", metavar="PATH.csv", type=Path, help="write the samples as CSV")
    p.add_argument("--plot", metavar="PATH.png", type=Path,
                   help="plot path, contour error, following error, speeds and DAC volts")
    p.add_argument("--vcd", metavar="PATH", type=Path,
                   help="write a waveform: VCD, or FST when PATH ends in .fst (GTKWave's "
                        "compressed format, about a tenth of the size)")
    p.add_argument("--vcd-start", type=int, default=0, metavar="CYCLE",
                   help="first cycle of the waveform window")
    p.add_argument("--vcd-stop", type=int, default=None, metavar="CYCLE",
                   help="end of the waveform window (exclusive; default: the end of the run)")
    p.add_argument("--signals", default="", metavar="GLOB[,GLOB...]",
                   help="dump only the signals matching these globs over the dotted paths "
                        "below the top (e.g. 'chipset.k3701.*,x__*'; default: every signal)")
    p.add_argument("--gtkw", metavar="PATH", type=Path,
                   help="write a GTKWave save file for the waveform (needs --vcd)")
    p.add_argument("--ballbar", metavar="PATH.png", type=Path,
                   help="a circular program: write the ballbar polar plot and put the ballbar "
                        "figures (circularity, 2-theta ellipse, ...) in the report")
    p.add_argument("--ballbar-settle", type=_settle, default=None, metavar="DEG",
                   help="leave out the first DEG degrees round the circle (less than the "
                        "program's arcs sweep; 0 keeps every sample) instead of the default, "
                        "ISO 230-4's: leave out the feed-in and the feed-out, where the tool "
                        "is off its steady speed")
    p.add_argument("--stall", action="append", default=[], choices=list(ALL_AXES),
                   help="fault: block this axis's motor")
    p.add_argument("--break-line", action="append", default=[], choices=list(ALL_AXES),
                   help="fault: break this axis's /A encoder line")
    p.add_argument("--load-step", action="append", default=[], type=_load_step,
                   metavar="AXIS:NM@SECONDS",
                   help="fault: a load torque step on this axis's torque drive (on a two-mass "
                        "drive's table) at this time "
                        "(e.g. x:0.05@1.5)")
    p.add_argument("-q", "--quiet", action="store_true", help="no summary, no progress line")
    _program_options(p)
    p.set_defaults(func=_cmd_run)

    p = sub.add_parser("plan", help="parse and plan a job's program only: its blocks, lines, "
                                    "end points, FP counts and events")
    p.add_argument("job", nargs="?", help="job file: .toml, or G-code (default: the demo)")
    p.add_argument("--json", action="store_true", help="JSON on stdout instead of a table")
    _program_options(p)
    p.set_defaults(func=_cmd_plan)

    from sim.fpga.blocks import BLOCKS
    from sim.fpga.synth import DEVICES

    names = [b.name for b in BLOCKS]
    p = sub.add_parser("export-verilog", help="write one Verilog file per chip and the top")
    p.add_argument("--block", action="append", choices=[*names, "all"],
                   help="block to export (repeatable; default: all)")
    p.add_argument("-o", "--output", required=True, help="output folder")
    p.set_defaults(func=_cmd_export_verilog)

    p = sub.add_parser("synth", help="synthesise and place on an iCE40 (needs the fpga extra)")
    p.add_argument("--device", choices=list(DEVICES), default="ice40-hx8k")
    p.add_argument("--block", action="append", choices=names,
                   help="block to synthesise (repeatable; default: every block and the top)")
    p.add_argument("--work-dir", help="keep netlists, logs and reports here")
    p.set_defaults(func=_cmd_synth)

    p = sub.add_parser("docs", help="write the generated documentation (register maps, JSON "
                                    "schema, job keys)")
    p.add_argument("-o", "--output", default="docs", help="folder (default: docs)")
    p.set_defaults(func=_cmd_docs)

    p = sub.add_parser("sweep", help="run a study (a base job, factors, a design) into one "
                                     "results table")
    p.add_argument("study", help="study file (.toml)")
    p.add_argument("--out", required=True, metavar="DIR",
                   help="folder for results.csv and results.parquet (runs already there are "
                        "skipped)")
    p.add_argument("-j", "--jobs", type=_positive_int, default=os.cpu_count() or 1,
                   help="local worker processes (default: one per core)")
    p.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                   help="run on this Dask distributed scheduler instead of local processes")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
    p.set_defaults(func=_cmd_sweep)

    p = sub.add_parser("effects", help="main effects and a second-order response surface of "
                                       "a metric over a sweep's factors")
    p.add_argument("dir", help="a sweep's folder (its results.csv)")
    p.add_argument("--metric", required=True, help="a column of results.csv")
    p.add_argument("--factors", help="comma-separated factors (default: all of the study's)")
    p.set_defaults(func=_cmd_effects)

    p = sub.add_parser("reproduce", help="run the paper's experiments; write figures and "
                                         "report.md (paper vs emulator, pass/fail per row)")
    p.add_argument("--out", default="docs/reproduce", metavar="DIR",
                   help="folder for report.md and the PNG figures (default: docs/reproduce)")
    p.add_argument("--quick", action="store_true",
                   help="smaller runs (the scale CI checks); the report says what shrank")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
    p.set_defaults(func=_cmd_reproduce)
    return parser


def _program_options(p: argparse.ArgumentParser) -> None:
    from firmware_model.gcode.canon import FRONTENDS

    p.add_argument("--frontend", choices=list(FRONTENDS), default="builtin",
                   help="G-code front end: builtin (default), or linuxcnc (full RS-274/NGC "
                        "through LinuxCNC's rs274, Debian package linuxcnc-uspace)")
    p.add_argument("--arc-tolerance", type=_tolerance, default=None, metavar="LSB",
                   help="largest difference between an arc's start and end radii (default: "
                        "LinuxCNC's, 0.028 mm in G21, 0.0028 in in G20)")


def _tolerance(text: str) -> float:
    from firmware_model.gcode.parser import ARC_TOLERANCE_LIMIT

    try:
        return ARC_TOLERANCE_LIMIT.check("arc tolerance", float(text))
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def main(argv: Sequence[str] | None = None) -> int:
    # NumPy's OpenBLAS starts a thread per core that spins for about 0.1 s of CPU per process
    # though K37 has no matrix work worth a thread: one thread leaves the cores to the runs.
    # Set before NumPy's first import; study workers inherit it.
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    args = build_parser().parse_args(argv)
    try:
        with _signals_interrupt():
            return args.func(args)
    except KeyboardInterrupt:  # a command without its own words for it
        print(f"k37: {_stopped()}", file=sys.stderr)
        return _interrupted()
    except BrokenPipeError:  # the reader of stdout went away (`k37 run | head`): no traceback
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1


if __name__ == "__main__":
    sys.exit(main())
