"""A FuseSoC core file (CAPI2) for the exported Verilog: ``k37.core`` beside the files.

The core ``k37:chips:verilog:<version>`` has one fileset with every exported file and one
target per block (``lint_<block>``: Verilator lint of that block as the top level); its
``default`` target has the chipset top (or the first block) as its top level. Add the
folder to FuseSoC's library (``fusesoc library add k37 DIR``, or ``--cores-root DIR``) and
use the core from your own.
"""

from __future__ import annotations

from importlib import metadata
from pathlib import Path

__all__ = ["core_text"]


def core_text(paths: list[Path]) -> str:
    """The CAPI2 core of the exported files ``paths`` (``<block>.v``, in one folder)."""
    if not paths:
        raise ValueError("a core needs at least one exported file")
    blocks = [p.stem for p in paths]
    top = "chipset" if "chipset" in blocks else blocks[0]
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
        "targets:",
        "  default:",
        "    filesets: [rtl]",
        f"    toplevel: {top}",
    ]
    for block in blocks:
        lines += [
            f"  lint_{block}:",
            "    default_tool: verilator",
            "    filesets: [rtl]",
            "    tools:",
            "      verilator:",
            "        mode: lint-only",
            "        verilator_options: [-Wall]",
            f"    toplevel: {block}",
        ]
    return "\n".join(lines) + "\n"
