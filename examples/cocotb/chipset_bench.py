"""A cocotb testbench of the exported two-axis chipset (``chipset.v`` in ``chipset_tb.v``), for
HDL users: the chip pins driven as an 8085 and the encoders would, in Icarus Verilog.

Port addresses come from the chipset's map (:func:`k37.hdl.chipset.map.port`), as the
firmware's do.
"""

from __future__ import annotations

from functools import partial

import cocotb
from cocotb.triggers import ClockCycles, RisingEdge
from host_bus import read_register, start, write_register

from k37.hdl.chipset.map import AXES, chip_register, port

#: The encoder lines at rest: A and B low, their complements high.
ENCODERS_AT_REST = {f"{axis}_{line}": level for axis in AXES
                    for line, level in (("a", 0), ("a_n", 1), ("b", 0), ("b_n", 1))}
#: One quadrature cycle of (A, B), A leading: four edges, four counts in x4 decoding.
QUADRATURE = ((1, 0), (1, 1), (0, 1), (0, 0))


async def write_reg(dut, chip: str, register: str, value: int) -> None:
    await write_register(dut, chip_register(chip, register), value,
                         partial(port, chip, register))


async def read_reg(dut, chip: str, register: str) -> int:
    return await read_register(dut, chip_register(chip, register), partial(port, chip, register))


async def turn(dut, axis: str, cycles: int, hold: int = 20) -> None:
    """Turn ``axis``'s encoder ``cycles`` quadrature cycles (backwards if negative), each level
    held ``hold`` cycles (longer than the line filter's K)."""
    steps = QUADRATURE if cycles > 0 else tuple(reversed((QUADRATURE[-1], *QUADRATURE[:-1])))
    for _ in range(abs(cycles)):
        for a, b in steps:
            getattr(dut, f"{axis}_a").value, getattr(dut, f"{axis}_a_n").value = a, 1 - a
            getattr(dut, f"{axis}_b").value, getattr(dut, f"{axis}_b_n").value = b, 1 - b
            await ClockCycles(dut.clk, hold)


@cocotb.test()
async def a_register_written_over_the_bus_reads_back(dut):
    await start(dut, **ENCODERS_AT_REST)
    await write_reg(dut, "K3702_Y", "POSITION_ZONE", 0x0A0B0C)
    assert await read_reg(dut, "K3702_Y", "POSITION_ZONE") == 0x0A0B0C


@cocotb.test()
async def the_error_counter_drives_the_d_a_word(dut):
    await start(dut, **ENCODERS_AT_REST)
    await RisingEdge(dut.clk)
    half = 1 << 11                      # DAC_BITS is 12 after reset: 0 V is 2^11
    assert int(dut.x_dac.value) == half and int(dut.x_alarm_n.value) == 1
    await write_reg(dut, "K3702_X", "ERROR", 100)
    await RisingEdge(dut.clk)
    assert int(dut.x_dac.value) == half + 100
    await write_reg(dut, "K3702_X", "ERROR", -5000)      # saturates
    await RisingEdge(dut.clk)
    assert int(dut.x_dac.value) == 0


@cocotb.test()
async def the_encoder_s_counts_come_off_the_error_counter(dut):
    await start(dut, **ENCODERS_AT_REST)
    await ClockCycles(dut.clk, 10)    # the filter takes the lines at rest as the start levels
    await turn(dut, "x", 3)                              # 12 counts forward (x4)
    assert await read_reg(dut, "K3702_X", "ERROR") == -12
    await turn(dut, "x", -5)                             # 20 back
    assert await read_reg(dut, "K3702_X", "ERROR") == 8
    assert await read_reg(dut, "K3702_Y", "ERROR") == 0
    assert await read_reg(dut, "ENCODER_X", "STATUS") == 0   # no fault, A and B low


@cocotb.test()
async def an_error_beyond_the_alarm_zone_raises_alarm_and_its_interrupt(dut):
    await start(dut, **ENCODERS_AT_REST)
    assert int(dut.irq_alarm.value) == 0 and int(dut.y_alarm_n.value) == 1
    await write_reg(dut, "K3702_Y", "ALARM_ZONE", 6)
    await ClockCycles(dut.clk, 10)
    await turn(dut, "y", 2)                              # 8 counts: beyond the zone
    await ClockCycles(dut.clk, 2)
    assert int(dut.y_alarm_n.value) == 0 and int(dut.irq_alarm.value) == 1
    assert int(dut.x_alarm_n.value) == 1
