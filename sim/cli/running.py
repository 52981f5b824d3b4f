"""``k37 run`` and ``k37 plan``: a job's program, planned or run on the simulated machine."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from k37.sim.cli.shared import (
    EXIT_OUTPUT,
    check,
    interrupted,
    positive_int,
    print_error,
    stdout,
    stopped,
)

__all__ = ["add_commands"]


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
    from k37.firmware_model.feeds import FirmwareError
    from k37.firmware_model.gcode.parser import GcodeError
    from k37.sim.files import STDIO
    from k37.sim.machine.servo import load_step_fault
    from k37.sim.run.ballbar import BallbarError, check_settle
    from k37.sim.run.jobfile import JobError, load_job
    from k37.sim.run.linked import LinkError, run_linked
    from k37.sim.run.output import OutputError, add_ballbar, check_outputs, write_outputs
    from k37.sim.run.progress import ProgressPrinter
    from k37.sim.run.runner import OptionError, RunOptions, run_job

    progress = None if args.quiet else ProgressPrinter(sys.stderr)
    try:
        job = load_job(args.job, frontend=args.frontend, arc_tolerance=args.arc_tolerance)
        check_outputs(json_path=args.json, trace=args.trace, plot=args.plot, vcd=args.vcd,
                      gtkw=args.gtkw, ballbar=args.ballbar, html=args.html,
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
        if args.link is not None and (args.trace or args.plot or args.ballbar or args.gtkw
                                      or args.html):
            raise OptionError("--trace, --plot, --ballbar, --gtkw, --html: not with --link: "
                              "the samples are the served machine's")
        if args.watchdog is not None and args.link is None:
            raise OptionError("--watchdog: only with --link (it is the board's)")
        result = (run_linked(job, options, args.link, args.watchdog) if args.link
                  else run_job(job, options))
    except (OutputError, OptionError, JobError, GcodeError, FirmwareError, LinkError) as e:
        print_error(e)
        return 2
    except KeyboardInterrupt:  # outside the run itself (building the machine, the report)
        print(f"k37: {stopped()}; nothing written", file=sys.stderr)
        return interrupted()
    finally:
        if progress is not None:
            progress.finish()
    outputs = [str(path) for path in (args.ballbar, args.trace, args.plot, args.html, args.gtkw)
               if path is not None] + ([args.json] if args.json not in (None, STDIO) else [])
    was_stopped = result.report["status"] == "interrupted"
    announced = bool(outputs) and not args.quiet and bool(args.plot or args.ballbar or args.html
                                                          or args.trace or was_stopped)
    if announced:
        head = f"{stopped(result.stopped_by)} at cycle {result.report['cycles']:,}; " \
            if was_stopped else ""
        print(f"k37: {head}writing {', '.join(outputs)} ...", file=sys.stderr, flush=True)
    try:
        circle, failures = (add_ballbar(result, args.ballbar, args.ballbar_settle)
                            if args.ballbar else (None, []))
        failures += write_outputs(result, json_path=args.json, trace=args.trace, plot=args.plot,
                                  gtkw=args.gtkw, vcd=args.vcd, vcd_start=args.vcd_start,
                                  quiet=args.quiet, html=args.html, ballbar=circle)
    except KeyboardInterrupt:
        print(f"k37: {stopped()} while writing the outputs; those not yet written are not "
              f"written (no partial files)", file=sys.stderr)
        return interrupted()
    for failure in failures:
        print(f"k37: error: {failure}", file=sys.stderr)
    if was_stopped:
        if failures or not announced:  # else the line naming what it writes said it all
            written = "outputs written" if not failures else "the other outputs written"
            print(f"k37: {stopped(result.stopped_by)} at cycle {result.report['cycles']:,}; "
                  f"{written}", file=sys.stderr)
        return interrupted(result.stopped_by)
    if failures:
        return EXIT_OUTPUT
    return 0 if result.ok else 1


def _cmd_plan(args: argparse.Namespace) -> int:
    import json

    from k37.firmware_model.feeds import FirmwareError, check_program, clamped_feeds
    from k37.firmware_model.gcode.parser import GcodeError
    from k37.sim.run.jobfile import JobError, load_job
    from k37.sim.run.plan import plan_rows, plan_table

    if not check():
        return 2
    try:
        job = load_job(args.job, frontend=args.frontend, arc_tolerance=args.arc_tolerance)
        check_program(job)
    except (JobError, GcodeError, FirmwareError) as e:
        print_error(e)
        return 2
    if args.json:
        text = json.dumps({"program": job.program.to_dict(), "items": plan_rows(job)}) + "\n"
    else:
        text = plan_table(job)
    code = stdout(lambda: sys.stdout.write(text))
    for warning in (*job.program.notes, *clamped_feeds(job)):
        print(f"k37: warning: {warning}", file=sys.stderr)
    return code


def _program_options(p: argparse.ArgumentParser) -> None:
    from k37.firmware_model.gcode.canon import FRONTENDS

    p.add_argument("--frontend", choices=list(FRONTENDS), default="builtin",
                   help="G-code front end: builtin (default), or linuxcnc (full RS-274/NGC "
                        "through LinuxCNC's rs274, Debian package linuxcnc-uspace)")
    p.add_argument("--arc-tolerance", type=_tolerance, default=None, metavar="LSB",
                   help="largest difference between an arc's start and end radii (default: "
                        "LinuxCNC's, 0.028 mm in G21, 0.0028 in in G20)")


def _tolerance(text: str) -> float:
    from k37.firmware_model.gcode.units import ARC_TOLERANCE_LIMIT

    try:
        return ARC_TOLERANCE_LIMIT.check("arc tolerance", float(text))
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def add_commands(sub: argparse._SubParsersAction) -> None:
    """Add ``run`` and ``plan`` to the command line."""
    from k37.hdl.chipset.map import ALL_AXES
    from k37.sim.backends.factory import BACKEND_NAMES

    p = sub.add_parser("run", help="run a job (TOML or G-code); no job: the built-in demo")
    p.add_argument("job", nargs="?", help="job file: .toml, or G-code run on the default machine")
    p.add_argument("--backend", choices=BACKEND_NAMES, default=BACKEND_NAMES[0],
                   help="simulation backend (auto: the engine when a C++ compiler exists "
                        "and no waveform is asked for, else the compiled RTL, or pysim "
                        "without a compiler; lockstep: the engine checked against the "
                        "compiled RTL)")
    p.add_argument("--max-cycles", type=positive_int, default=None,
                   help="stop after this many clock cycles (default: twice the program's "
                        "planned machine time and 10 s)")
    p.add_argument("--sample-every", type=positive_int, default=1000,
                   help="sample the machine every N cycles for trace, plot and path error")
    p.add_argument("--no-skip-idle", action="store_true",
                   help="evaluate every cycle, even where the machine provably stands still "
                        "(results are identical; for timing comparisons)")
    p.add_argument("--json", metavar="PATH", help="write the JSON report ('-': stdout)")
    p.add_argument("--trace", metavar="PATH.csv", type=Path, help="write the samples as CSV")
    p.add_argument("--plot", metavar="PATH.png", type=Path,
                   help="plot path, contour error, following error, speeds and DAC volts")
    p.add_argument("--html", metavar="PATH.html", type=Path,
                   help="write an interactive report: one self-contained page (no network "
                        "needed) with the part coloured by contour error, the time series, "
                        "the sortable per-block table, the summary, the job and the ballbar")
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
                        "drive's table) at this time (e.g. x:0.05@1.5)")
    p.add_argument("--link", metavar="URL",
                   help="run the firmware against a board over the host bridge: "
                        "tcp://HOST:PORT (`k37 serve`) or serial:///dev/ttyUSB0[?baud=N]")
    p.add_argument("--watchdog", type=float, metavar="SECONDS",
                   help="with --link: arm the board's watchdog for the run (it stops the "
                        "drives when the host sends nothing this long; e.g. 0.5) and read "
                        "the board's STATUS after every quarter of it spent waiting: a stop "
                        "latched mid-run (E-stop, a limit, the watchdog) ends the run as a "
                        "fault at once")
    p.add_argument("-q", "--quiet", action="store_true", help="no summary, no progress line")
    _program_options(p)
    p.set_defaults(func=_cmd_run)
    p = sub.add_parser("plan", help="parse and plan a job's program only: its blocks, lines, "
                                    "end points, FP counts and events")
    p.add_argument("job", nargs="?", help="job file: .toml, or G-code (default: the demo)")
    p.add_argument("--json", action="store_true", help="JSON on stdout instead of a table")
    _program_options(p)
    p.set_defaults(func=_cmd_plan)
