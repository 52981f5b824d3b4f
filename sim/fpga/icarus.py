"""The exported Verilog in Icarus Verilog: a block's file run on a recorded pin stimulus.

Icarus is an event-driven simulator with four-state values, unlike Verilator's two-state
cycle model, so it checks what another simulator reads from the file: the power-up values,
the start-up evaluation Yosys writes, the tristate host bus. :func:`simulate` writes a
testbench that clocks as Amaranth's simulator and the Verilator harness do (the clock starts
low; each cycle applies its row of input pins, then a falling edge, then a rising edge, so a
falling-edge domain sees the row first), lets the host drive ``d`` only where the row says so
(the chip drives it otherwise, and a clash reads as X), and prints every output pin (and
``d``) before the falling edge. Values holding X or Z come back as None.

Compiled as Verilog-2005 (``-g2005``), where a declaration's initialiser is an event at time
0: that is what fires the start-up evaluation of Yosys's ``always @*`` blocks, and it is also
a falling edge of a clock declared ``reg clk = 0``, so a falling-edge register (the K3702's)
loads X then. As on a board, the first row holds ``rst``: every register then starts from its
power-up value, as in the other simulators.
"""

from __future__ import annotations

import shutil
import subprocess
import tempfile
from collections.abc import Sequence
from pathlib import Path

from k37.sim.fpga.export import Pin, pins

__all__ = ["find_iverilog", "simulate"]

#: The testbench's per-cycle input that says the host drives ``d`` (the chip then must not).
HOST_DRIVES = "host_drives_d"


def find_iverilog() -> tuple[str, str] | None:
    """The ``iverilog`` and ``vvp`` executables, or None where Icarus is not installed."""
    iverilog, vvp = shutil.which("iverilog"), shutil.which("vvp")
    return (iverilog, vvp) if iverilog and vvp else None


def _stimulus_pins(ports: list[Pin]) -> list[Pin]:
    """The pins a stimulus row sets, in packing order: inputs, D, whether the host drives D."""
    driven = [p for p in ports if p.direction != "output" and p.name != "clk"]
    has_d = any(p.direction == "inout" for p in ports)
    return [*driven, *([Pin(HOST_DRIVES, "input", 1, "", "")] if has_d else [])]


def _testbench(name: str, ports: list[Pin], cycles: int) -> str:
    stim = _stimulus_pins(ports)
    shown = [p for p in ports if p.direction != "input"]
    total = sum(p.width for p in stim)
    fields, low = [], total
    for p in stim:  # the first pin in the highest bits of a row
        target = "host_d" if p.name == "d" else p.name
        fields.append(f"            {target} = k37_row[{low - 1}:{low - p.width}];")
        low -= p.width
    regs = [f"    reg [{p.width - 1}:0] {'host_d' if p.name == 'd' else p.name};" for p in stim]
    drive_d = ([f"    assign d = {HOST_DRIVES} ? host_d : 8'bzzzzzzzz;"]
               if any(p.name == HOST_DRIVES for p in stim) else [])
    conns = ", ".join(f".{p.name}({p.name})" for p in ports)
    fmt = " ".join(["%h"] * len(shown))
    args = ", ".join(p.name for p in shown)
    return "\n".join([
        "`timescale 1ns/1ns", "module tb;", "    reg clk = 1'b0;",
        f"    reg [{total - 1}:0] k37_stim [0:{cycles - 1}];",
        f"    reg [{total - 1}:0] k37_row;", *regs,
        *(f"    wire [{p.width - 1}:0] {p.name};" for p in shown), *drive_d,
        f"    {name} dut({conns});",
        "    integer k37_t, k37_out;",
        "    initial begin",
        '        $readmemh("stimulus.hex", k37_stim);',
        '        k37_out = $fopen("outputs.txt");',
        f"        for (k37_t = 0; k37_t < {cycles}; k37_t = k37_t + 1) begin",
        "            k37_row = k37_stim[k37_t];", *fields,
        "            #2;",
        f'            $fdisplay(k37_out, "{fmt}", {args});',
        "            clk = 1'b0; #3 clk = 1'b1; #1;",
        "        end",
        "        $fclose(k37_out);",
        "        $finish;",
        "    end",
        "endmodule", ""])


def simulate(name: str, verilog: str, rows: Sequence[dict[str, int]], *,
             libraries: Sequence[str] = ()) -> list[dict[str, int | None]]:
    """Run block ``name``'s exported file ``verilog`` in Icarus on ``rows``, one dict of input
    pins per cycle (``rst`` included; ``d`` with :data:`HOST_DRIVES` for blocks with a host
    bus; pins a row omits are 0), and return every output pin's value per cycle, as seen
    before that cycle's rising edge (None: X or Z).

    ``verilog`` may also be a synthesised netlist of the file (module ``name``, the same
    ports); ``libraries`` are the Verilog texts of its cells' simulation models."""
    tools = find_iverilog()
    if tools is None:
        raise FileNotFoundError("Icarus Verilog (iverilog, vvp) is not installed")
    ports = pins(name)
    stim = _stimulus_pins(ports)
    shown = [p for p in ports if p.direction != "input"]
    with tempfile.TemporaryDirectory(prefix="k37-icarus-") as tmp:
        folder = Path(tmp)
        (folder / "dut.v").write_text(verilog)
        (folder / "tb.v").write_text(_testbench(name, ports, len(rows)))
        hex_rows = []
        for row in rows:
            packed = 0
            for p in stim:
                packed = packed << p.width | (row.get(p.name, 0) & ((1 << p.width) - 1))
            hex_rows.append(f"{packed:x}")
        (folder / "stimulus.hex").write_text("\n".join(hex_rows) + "\n")
        libs = [f"lib{k}.v" for k in range(len(libraries))]
        for lib, text in zip(libs, libraries, strict=True):
            (folder / lib).write_text(text)
        for command in ([tools[0], "-g2005", "-s", "tb", "-o", "sim", "tb.v", "dut.v", *libs],
                        [tools[1], "sim"]):
            done = subprocess.run(command, cwd=folder, capture_output=True, text=True)
            if done.returncode:
                raise RuntimeError(f"{' '.join(command)} failed:\n{done.stderr}{done.stdout}")
        text = (folder / "outputs.txt").read_text().split("\n")
    return [{p.name: _value(word) for p, word in zip(shown, line.split(), strict=True)}
            for line in text[:len(rows)]]


def _value(word: str) -> int | None:
    try:
        return int(word, 16)
    except ValueError:  # x or z digits
        return None
