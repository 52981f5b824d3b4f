"""``k37 export-verilog``, ``k37 synth`` and ``k37 build``: the gateware as Verilog, on an FPGA
and as a board's bitstream."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from k37.sim.cli.shared import EXIT_OUTPUT, check, interrupted, stdout, stopped

__all__ = ["add_commands"]


def _cmd_export_verilog(args: argparse.Namespace) -> int:
    from k37.sim.files import why
    from k37.sim.fpga.export import export_verilog
    from k37.sim.fpga.fusesoc import write_core

    if not check(folders={"-o": args.output}):
        return 2
    try:
        paths = export_verilog(args.block or None, Path(args.output))
        paths += write_core(paths, Path(args.output))
    except OSError as e:
        print(f"k37: error: {e.filename or args.output}: not written: {why(e)}",
              file=sys.stderr)
        return EXIT_OUTPUT
    return stdout(lambda: print("\n".join(f"k37 export-verilog: wrote {p}" for p in paths)))


def _cmd_synth(args: argparse.Namespace) -> int:
    from k37.sim.fpga.synth import MissingToolError, synthesize

    if not check(folders={"--work-dir": args.work_dir}):
        return 2
    try:
        report = synthesize(args.device, args.block or None,
                            work_dir=Path(args.work_dir) if args.work_dir else None)
    except (ImportError, FileNotFoundError, MissingToolError) as e:
        print(f"k37: error: synthesis needs the fpga extra (pip install -e '.[fpga]'): {e}",
              file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"k37 synth: {stopped()}", file=sys.stderr)
        return interrupted()
    if stdout(lambda: print(report.format_table())):
        return EXIT_OUTPUT
    for failure in report.failures:
        print(f"k37 synth: {failure}", file=sys.stderr)
    return 0 if report.ok else 1


def _cmd_build(args: argparse.Namespace) -> int:
    from k37.sim.files import why
    from k37.sim.fpga.build import BuildError, build

    out = args.out or f"build/{args.board}"
    if not check(folders={"--out": out}):
        return 2
    try:
        report = build(args.board, Path(out), axes=args.axes, plan_only=args.plan_only)
    except (ImportError, FileNotFoundError, RuntimeError) as e:
        if isinstance(e, BuildError):
            print(f"k37: error: build failed: {e}", file=sys.stderr)
            return 1
        print(f"k37: error: building a bitstream needs the fpga extra "
              f"(pip install -e '.[fpga]'): {e}", file=sys.stderr)
        return 2
    except OSError as e:
        print(f"k37: error: {e.filename or out}: not written: {why(e)}", file=sys.stderr)
        return EXIT_OUTPUT
    except KeyboardInterrupt:
        print(f"k37 build: {stopped()}", file=sys.stderr)
        return interrupted()
    done = "build plan" if report.plan_only else f"{report.name}.bit"
    return stdout(lambda: print(f"{report.format()}k37 build: wrote {done}, pins.md and "
                                f"report.md to {report.folder}"))


def add_commands(sub: argparse._SubParsersAction) -> None:
    """Add ``export-verilog``, ``synth`` and ``build`` to the command line."""
    from k37.sim.fpga.blocks import BLOCKS
    from k37.sim.fpga.build import BOARDS
    from k37.sim.fpga.synth import DEVICES

    names = [b.name for b in BLOCKS]
    p = sub.add_parser("export-verilog", help="write one Verilog file per chip and the top, "
                                              "and a FuseSoC core file (k37.core)")
    p.add_argument("--block", action="append", choices=[*names, "all"],
                   help="block to export (repeatable; default: all)")
    p.add_argument("-o", "--output", required=True, help="output folder")
    p.set_defaults(func=_cmd_export_verilog)
    p = sub.add_parser("synth", help="synthesise and place on an iCE40 (needs the fpga extra)")
    p.add_argument("--device", choices=list(DEVICES), default="ice40-hx8k")
    p.add_argument("--block", action="append", choices=names,
                   help="block to synthesise (repeatable; default: every block and the "
                        "two-axis top, the three-axis builds being the ECP5 board's)")
    p.add_argument("--work-dir", help="keep netlists, logs and reports here")
    p.set_defaults(func=_cmd_synth)
    p = sub.add_parser("build", help="build a board's bitstream (needs the fpga extra)")
    p.add_argument("--board", choices=list(BOARDS), required=True,
                   help="the board (its FPGA part: " + ", ".join(
                       f"{b} {part}" for b, part in BOARDS.items()) + ")")
    p.add_argument("--out", help="output folder (default: build/BOARD)")
    p.add_argument("--axes", type=int, choices=(2, 3), default=3,
                   help="the chipset's axes (2: the paper's; 3: lines, arcs and helices in "
                        "space too; both with every K3701 mode)")
    p.add_argument("--plan-only", action="store_true",
                   help="write Amaranth's build plan, the pin map and no bitstream (no "
                        "Yosys or nextpnr needed; the board's definition, amaranth-boards, "
                        "comes with the fpga extra)")
    p.set_defaults(func=_cmd_build)
