"""The ``k37`` command line: one module per family of commands."""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from importlib import metadata
from pathlib import Path

import k37.sim.cli.hardware
import k37.sim.cli.running
import k37.sim.cli.serving
import k37.sim.cli.studies
from k37.sim.cli.shared import EXIT_OUTPUT, Parser, check, interrupted, signals_interrupt, stopped

__all__ = ["build_parser", "main"]


def _cmd_docs(args: argparse.Namespace) -> int:
    from k37.sim.docs import documents

    if not check(folders={"-o": args.output}):
        return 2
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    for name, text in documents().items():
        (out / name).write_text(text)
        print(f"k37 docs: wrote {out / name}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(
        prog="k37", description="Cycle-accurate emulator of the TOKO KM3701/KM3702 NC chipset.")
    parser.add_argument("--version", action="version",
                        version=f"k37 {metadata.version('k37')}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    k37.sim.cli.running.add_commands(sub)
    k37.sim.cli.hardware.add_commands(sub)
    k37.sim.cli.serving.add_commands(sub)
    p = sub.add_parser("docs", help="write the generated documentation (register maps, JSON "
                                    "schema, job keys)")
    p.add_argument("-o", "--output", required=True, metavar="DIR",
                   help="folder to write them in (the manual's sources are in docs/)")
    p.set_defaults(func=_cmd_docs)
    k37.sim.cli.studies.add_commands(sub)
    parser.commands = sub.choices
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    # NumPy's OpenBLAS starts a thread per core that spins for about 0.1 s of CPU per process
    # though K37 has no matrix work worth a thread: one thread leaves the cores to the runs.
    # Set before NumPy's first import; study workers inherit it.
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    parser = build_parser()
    args, unknown = parser.parse_known_args(argv)
    if unknown:  # in the name of the command they were given to, not of k37
        parser.commands[args.command].error(f"unrecognized arguments: {' '.join(unknown)}")
    try:
        with signals_interrupt():
            return args.func(args)
    except KeyboardInterrupt:  # a command without its own words for it
        print(f"k37: {stopped()}", file=sys.stderr)
        return interrupted()
    except BrokenPipeError:  # the reader of stdout went away (`k37 run | head`): no traceback
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_OUTPUT
