"""``k37 serve``: a simulated board, the machine behind a TCP socket speaking the host bridge's
protocol."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from k37.sim.cli.shared import check, interrupted, print_error, stopped

__all__ = ["add_commands"]


def _port(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a port number") from None
    if not 0 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"{value} is not a port number (0 to 65535; 0: any "
                                         f"free port)")
    return value


def _cycles_per_bit(text: str) -> int:
    from k37.hdl.bridge.protocol import check_cycles_per_bit

    try:
        return check_cycles_per_bit(int(text))
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def _cycles(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of cycles") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"{value}: give a number of cycles >= 0")
    return value


def _span(text: str) -> tuple[int, int | None]:
    """``CYCLE`` or ``CYCLE:RELEASE`` as (cycle, release cycle or None)."""
    at, _, until = text.partition(":")
    cycle = _cycles(at)
    release = _cycles(until) if until else None
    if release is not None and release <= cycle:
        raise argparse.ArgumentTypeError(f"{text}: the release cycle must come after "
                                         f"{cycle}")
    return cycle, release


def _changes(name: str, text: str) -> tuple:
    from k37.sim.serve.board import InputChange

    cycle, release = _span(text)
    return (InputChange(cycle, name),
            *(() if release is None else (InputChange(release, name, active=False),)))


def _estop(text: str) -> tuple:
    return _changes("estop", text)


def _limit(text: str) -> tuple:
    axis, at, span = text.partition("@")
    if not at or not axis:
        raise argparse.ArgumentTypeError(f"{text!r}: give AXIS@CYCLE[:RELEASE], e.g. x@300000")
    return _changes(axis.lower(), span)


def _cmd_serve(args: argparse.Namespace) -> int:
    from k37.firmware_model.gcode.parser import GcodeError

    if not check([("--trace", args.trace)]):
        return 2
    from k37.sim.run.jobfile import JobError, load_job
    from k37.sim.serve.server import Session, SimulatedBoard

    try:
        job = load_job(args.job)
        line = None if args.uart is None else (args.uart, args.turnaround)
        board = SimulatedBoard(job, args.backend, args.host, args.port, args.sample_every,
                               line=line, trace=args.trace, probes=not args.no_probe,
                               changes=tuple(c for cs in (*args.estop_at, *args.limit)
                                             for c in cs))
    except (JobError, GcodeError) as e:
        print_error(e)
        return 2
    except ValueError as e:  # a limit of an axis the machine lacks
        print(f"k37: error: --limit: {e}", file=sys.stderr)
        return 2
    except OSError as e:
        print(f"k37: error: --port {args.port}: cannot listen on {args.host}: "
              f"{e.strerror or e}", file=sys.stderr)
        return 2

    def report(session: Session) -> None:
        print(f"k37 serve: {session.peer}: {session.received:,} bytes received, "
              f"{session.cycles:,} cycles run", file=sys.stderr, flush=True)

    print(f"k37 serve: the {job.machine.axes}-axis machine of {job.name} on "
          f"tcp://{args.host}:{board.port} ({board.backend.name}, {board.backend.reason}); "
          f"Ctrl-C ends",
          file=sys.stderr, flush=True)
    if board.board.changes:
        print(f"k37 serve: {'; '.join(map(str, board.board.changes))}", file=sys.stderr,
              flush=True)
    try:
        board.serve(args.sessions, report)
    except KeyboardInterrupt:
        print(f"k37 serve: {stopped()}", file=sys.stderr)
        return interrupted()
    finally:
        board.close()
    return 0


def add_commands(sub: argparse._SubParsersAction) -> None:
    """Add ``serve`` to the command line."""
    from k37.sim.backends.factory import BACKEND_NAMES
    from k37.sim.cli.shared import positive_int

    p = sub.add_parser("serve", help="serve a simulated board: the job's machine behind a TCP "
                                     "socket, for `k37 run --link tcp://HOST:PORT`")
    p.add_argument("job", nargs="?", help="job file whose machine to serve (.toml, or G-code "
                                          "for the default machine; default: the demo's)")
    p.add_argument("--port", type=_port, required=True,
                   help="TCP port to listen on (0: any free port, printed)")
    p.add_argument("--host", default="127.0.0.1",
                   help="address to listen on (default 127.0.0.1: this computer only)")
    p.add_argument("--backend", choices=BACKEND_NAMES, default=BACKEND_NAMES[0],
                   help="simulation backend (auto: the engine when a C++ compiler exists "
                        "and no waveform is asked for, else the compiled RTL, or pysim "
                        "without a compiler; lockstep: the engine checked against the "
                        "compiled RTL)")
    p.add_argument("--sessions", type=positive_int, default=None, metavar="N",
                   help="end after serving N connections (default: serve until Ctrl-C)")
    p.add_argument("--uart", type=_cycles_per_bit, default=None, metavar="CYCLES_PER_BIT",
                   help="let the machine's time include a UART's at this bit time, as a real "
                        "board's does (8: 125 kBd at 1 MHz; default: no line time)")
    p.add_argument("--turnaround", type=_cycles, default=0, metavar="CYCLES",
                   help="with --uart: the host's time from a reply to its next frame "
                        "(default 0)")
    p.add_argument("--trace", metavar="PATH.csv", type=Path,
                   help="write the machine's samples since it started as CSV when each "
                        "session ends (the columns of `k37 run --trace`)")
    p.add_argument("--sample-every", type=positive_int, default=1000,
                   help="sample the machine every N cycles for --trace")
    p.add_argument("--no-probe", action="store_true",
                   help="answer as a real board does: no PROBE, so a linked run reads what a "
                        "host can (no block pulses)")
    p.add_argument("--estop-at", type=_estop, action="append", default=[],
                   metavar="CYCLE[:RELEASE]",
                   help="press the board's E-stop at this machine cycle (since the board "
                        "started), held until RELEASE or for good: the board holds the feed, "
                        "puts 0 V out and drops drive-enable (e.g. 300000)")
    p.add_argument("--limit", type=_limit, action="append", default=[],
                   metavar="AXIS@CYCLE[:RELEASE]",
                   help="open this axis's limit switch at this machine cycle, until RELEASE "
                        "or for good: the board holds the feed (e.g. x@300000)")
    p.set_defaults(func=_cmd_serve)
