"""The 8085's side of the chips' host bus in cocotb, shared by the benches: the clock, reset
and one-cycle bus accesses on the exported pins.

Every bus access is one cycle of the 1 MHz clock with /CS and /RD or /WR low; a read's byte is
on D in the next cycle. Multi-byte registers are little-endian: the last byte written commits
the register, reading byte 0 snapshots it for the bytes after it.
"""

from __future__ import annotations

from collections.abc import Callable

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge, RisingEdge

from k37.hdl.bus.registers import Register


async def start(dut, **levels: int) -> None:
    """Start the clock, idle the bus, set the other inputs to ``levels`` and reset for one
    cycle."""
    cocotb.start_soon(Clock(dut.clk, 1, unit="us").start(start_high=False))
    dut.cs_n.value, dut.rd_n.value, dut.wr_n.value = 1, 1, 1
    dut.addr.value, dut.host_d.value, dut.host_drives.value = 0, 0, 0
    for name, level in levels.items():
        getattr(dut, name).value = level
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


async def write_register(dut, reg: Register, value: int,
                         address: Callable[[int], int] | None = None) -> None:
    """Write the whole of ``reg``, least significant byte first; ``address(k)`` is byte k's
    port address (``reg.addr + k`` for a chip on its own)."""
    for k, byte in enumerate(reg.to_bytes(value)):
        await write(dut, address(k) if address else reg.addr + k, byte)


async def read_register(dut, reg: Register, address: Callable[[int], int] | None = None) -> int:
    """Read the whole of ``reg``, least significant byte first (byte 0 snapshots it)."""
    return reg.from_bytes([await read(dut, address(k) if address else reg.addr + k)
                           for k in range(reg.nbytes)])
