"""Co-simulation: the exported Verilog, in Verilator and in Icarus Verilog, against the
reference models (each chip) and Amaranth's simulator (the chipset top).

Each block's exported file (pin wrapper and Amaranth core, as ``k37 export-verilog`` writes
it) is driven through its chip pins with seeded random stimulus: random host bus traffic on
D/address//CS//RD//WR (whole registers, stray bytes, unmapped addresses, strobes while not
selected, junk on D), random block inputs and one reset pulse. Every output pin, and D with
its output enable, is compared cycle by cycle with the block's plain-Python reference model,
which sees the same inputs through a bus model of :class:`k37.hdl.bus.hostbus.RegisterBank`.

One Verilator build per block per session (and a disk cache keyed by the file's hash).
Icarus (four-state, event-driven: it reads the file as another simulator or a synthesis tool
would) runs the same stimulus as a batch; its tests skip, saying so, where Debian's
``iverilog`` is not installed.
"""

from __future__ import annotations

import pytest

from k37.sim.fpga.blocks import BLOCKS
from k37.sim.fpga.export import verilog_text
from k37.sim.fpga.icarus import HOST_DRIVES, simulate
from tests.sim.fpga.chips import CHIPS, CYCLES, SEEDS, DecelControlChip, DividerChip, K3702Chip
from tests.sim.fpga.cosim import (
    amaranth_chipset,
    chipset_stimulus,
    cosimulate,
    icarus_rows,
    needs_icarus,
)


@pytest.mark.slow
@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("name", list(CHIPS))
def test_exported_verilog_matches_the_reference_model_on_random_stimulus(name, seed):
    checks = cosimulate(CHIPS[name](), seed)
    assert checks >= CYCLES


def test_every_exported_chip_has_a_cosimulation():
    # The chipset tops are made of these chips; their own reference is the system simulation.
    assert set(CHIPS) == {b.name for b in BLOCKS if b.cosim}


def test_the_cosimulation_detects_a_wrong_output():
    class Inverted(DividerChip):
        def cycle(self, pins, write):
            expected, registers = super().cycle(pins, write)
            return {"stb": 1 - expected["stb"]}, registers

    with pytest.raises(AssertionError, match="divider seed 1 cycle 0"):
        cosimulate(Inverted(), 1, 10)


def test_the_cosimulation_detects_a_wrong_read_byte():
    class OffByOne(DecelControlChip):
        def cycle(self, pins, write):
            expected, registers = super().cycle(pins, write)
            return expected, {**registers, "REMAINING": registers["REMAINING"] + 1}

    with pytest.raises(AssertionError, match="d__out"):
        cosimulate(OffByOne(), 1)


@needs_icarus
@pytest.mark.slow
@pytest.mark.parametrize("name", list(CHIPS))
def test_exported_verilog_in_icarus_matches_the_reference_model(name):
    cycles = CYCLES // 4
    rows, expect = icarus_rows(CHIPS[name](), SEEDS[0], cycles)
    got = simulate(name, verilog_text(name), rows)
    assert sum(map(len, expect)) >= cycles
    for t, (g, e) in enumerate(zip(got, expect, strict=True)):
        assert {k: g[k] for k in e} == e, f"{name} cycle {t}: Icarus {g} != model {e}"


@needs_icarus
def test_exported_chipset_in_icarus_matches_amaranths_simulator():
    rows = chipset_stimulus(SEEDS[0], 6000)
    expect = amaranth_chipset(rows)
    for row, e in zip(rows, expect, strict=True):
        row[HOST_DRIVES] = e.pop(HOST_DRIVES)
    got = simulate("chipset", verilog_text("chipset"), rows)
    moving = {k for k in expect[0] if len({e[k] for e in expect}) > 1}
    assert {"irq_alarm", "x_dac", "y_dac", "d"} <= moving  # exercised
    for t, (g, e) in enumerate(zip(got, expect, strict=True)):
        assert g == e, f"chipset cycle {t}: Icarus {g} != Amaranth {e}"


@needs_icarus
def test_in_icarus_the_k3702_needs_its_power_up_reset_for_its_falling_edge_registers():
    rows, _ = icarus_rows(K3702Chip(), SEEDS[0], 300)
    rows[0]["rst"] = 0  # no reset: the time-0 falling edge of clk loads X (module docstring)
    got = simulate("k3702", verilog_text("k3702"), rows)
    assert got[1]["dac"] is None and got[1]["in_position"] is None
