"""A cocotb testbench of the exported two-axis chipset, for HDL users: the chip pins driven
as an 8085 would, in Icarus Verilog.

Export the chipset (``k37 export-verilog --block chipset -o build/``), then run these tests
with cocotb's runner (``tests/sim/fpga/test_cocotb.py`` shows how) on ``build/chipset.v`` and
``chipset_tb.v``. Every bus access is one cycle of the 1 MHz clock with /CS and /RD or /WR
low; a read's byte is on D in the next cycle. Port addresses come from the chipset's map
(:func:`k37.hdl.chipset.map.port`), as the firmware's do.
"""

from __future__ import annotations

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge, RisingEdge

from k37.hdl.chipset.map import AXES, port


async def start(dut) -> None:
    """Start the clock, idle the bus and the encoders, and reset for one cycle."""
    cocotb.start_soon(Clock(dut.clk, 1, unit="us").start(start_high=False))
    dut.cs_n.value, dut.rd_n.value, dut.wr_n.value = 1, 1, 1
    dut.addr.value, dut.host_d.value, dut.host_drives.value = 0, 0, 0
    for axis in AXES:
        for line, level in (("a", 0), ("a_n", 1), ("b", 0), ("b_n", 1)):
            getattr(dut, f"{axis}_{line}").value = level
    dut.rst.value = 1
    await RisingEdge(dut.clk)
    dut.rst.value = 0


async def write(dut, addr: int, data: int) -> None:
    """One write cycle: the byte is taken at the rising edge that ends it."""
    await FallingEdge(dut.clk)
    dut.addr.value, dut.host_d.value, dut.host_drives.value = addr, data, 1
    dut.cs_n.value, dut.wr_n.value = 0, 0
    await RisingEdge(dut.clk)
    await FallingEdge(dut.clk)
    dut.cs_n.value, dut.wr_n.value, dut.host_drives.value = 1, 1, 0


async def read(dut, addr: int) -> int:
    """One read cycle; the chip drives the byte on D in the next cycle."""
    await FallingEdge(dut.clk)
    dut.addr.value, dut.cs_n.value, dut.rd_n.value = addr, 0, 0
    await RisingEdge(dut.clk)
    await FallingEdge(dut.clk)
    dut.cs_n.value, dut.rd_n.value = 1, 1
    return int(dut.d.value)


async def write_register(dut, chip: str, register: str, value: int, nbytes: int) -> None:
    """A multi-byte register, least significant byte first (the last byte commits)."""
    for k in range(nbytes):
        await write(dut, port(chip, register, k), (value >> 8 * k) & 0xFF)


@cocotb.test()
async def a_register_written_over_the_bus_reads_back(dut):
    await start(dut)
    await write_register(dut, "K3702_Y", "POSITION_ZONE", 0x0A0B0C, 3)
    got = [await read(dut, port("K3702_Y", "POSITION_ZONE", k)) for k in range(3)]
    assert got == [0x0C, 0x0B, 0x0A]


@cocotb.test()
async def the_error_counter_drives_the_d_a_word(dut):
    await start(dut)
    await RisingEdge(dut.clk)
    half = 1 << 11                      # DAC_BITS is 12 after reset: 0 V is 2^11
    assert int(dut.x_dac.value) == half and int(dut.x_alarm_n.value) == 1
    await write_register(dut, "K3702_X", "ERROR", 100, 3)
    await RisingEdge(dut.clk)
    assert int(dut.x_dac.value) == half + 100
    await write_register(dut, "K3702_X", "ERROR", (1 << 24) - 5000, 3)   # -5000: saturates
    await RisingEdge(dut.clk)
    assert int(dut.x_dac.value) == 0
