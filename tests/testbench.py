"""Amaranth-simulator helpers shared by the tests: running a bench, host-bus accesses.

Waveforms are written only when ``K37_VCD_DIR`` names a folder (one VCD per simulation,
named after the bench), so a test run leaves nothing behind by default.
"""

from __future__ import annotations

import os
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any, NamedTuple

from amaranth.lib import wiring
from amaranth.sim import Simulator

from k37.hdl.bus.registers import Register

__all__ = [
    "CLOCK_PERIOD",
    "BusOp",
    "bus_read",
    "bus_write",
    "drive_bus",
    "read_ops",
    "read_reg",
    "simulate",
    "write_ops",
    "write_reg",
]

#: The paper's system clock, 1 MHz.
CLOCK_PERIOD = 1e-6

Bench = Callable[[Any], Awaitable[None]]


def simulate(dut: wiring.Component, *benches: Bench, background: tuple[Bench, ...] = (),
             name: str | None = None) -> None:
    """Run ``benches`` (async testbenches) against ``dut`` on a 1 MHz clock until they end.

    ``background`` benches (stimulus sources, plant models) run alongside and are dropped when
    the foreground benches finish.
    """
    sim = Simulator(dut)
    sim.add_clock(CLOCK_PERIOD)
    for bench in benches:
        sim.add_testbench(bench)
    for bench in background:
        sim.add_testbench(bench, background=True)
    vcd_dir = os.environ.get("K37_VCD_DIR")
    if vcd_dir:
        label = name or (benches[0].__name__ if benches else type(dut).__name__)
        path = Path(vcd_dir) / f"{label}.vcd"
        path.parent.mkdir(parents=True, exist_ok=True)
        with sim.write_vcd(str(path)):
            sim.run()
    else:
        sim.run()


async def bus_write(ctx, bus, addr: int, data: int) -> None:
    """One host write cycle: ``data`` is taken at the edge that ends it."""
    ctx.set(bus.addr, addr)
    ctx.set(bus.w_data, data)
    ctx.set(bus.w_stb, 1)
    await ctx.tick()
    ctx.set(bus.w_stb, 0)


async def bus_read(ctx, bus, addr: int) -> int:
    """One host read cycle; returns the byte the chip presents in the following cycle."""
    ctx.set(bus.addr, addr)
    ctx.set(bus.r_stb, 1)
    await ctx.tick()
    ctx.set(bus.r_stb, 0)
    return ctx.get(bus.r_data)


async def write_reg(ctx, bus, reg: Register, value: int) -> None:
    """Write a whole register, LSB first (the MSB commits it)."""
    for k, byte in enumerate(reg.to_bytes(value)):
        await bus_write(ctx, bus, reg.addr + k, byte)


async def read_reg(ctx, bus, reg: Register) -> int:
    """Read a whole register, LSB first (the LSB snapshots it)."""
    data = [await bus_read(ctx, bus, reg.addr + k) for k in range(reg.nbytes)]
    return reg.from_bytes(data)


class BusOp(NamedTuple):
    """One host bus cycle: write ``data`` to ``addr``, or read ``addr`` when ``data`` is None.

    For benches that drive the bus cycle by cycle alongside other inputs.
    """

    addr: int
    data: int | None = None


def write_ops(reg: Register, value: int, *, check: bool = True) -> list[BusOp]:
    """The bus cycles writing a whole register, LSB first (the last one commits it).

    ``check=False`` sends any value (also one outside ``reg.valid``), cut to the width.
    """
    data = (reg.to_bytes(value) if check
            else [(value >> (8 * k)) & 0xFF for k in range(reg.nbytes)])
    return [BusOp(reg.addr + k, byte) for k, byte in enumerate(data)]


def read_ops(reg: Register) -> list[BusOp]:
    """The bus cycles reading a whole register, LSB first (the first one snapshots it)."""
    return [BusOp(reg.addr + k) for k in range(reg.nbytes)]


def drive_bus(ctx, bus, op: BusOp | None) -> None:
    """Present ``op``, or an idle bus, for the clock edge that ends the current cycle.

    A read's byte is on ``bus.r_data`` after that edge.
    """
    ctx.set(bus.w_stb, op is not None and op.data is not None)
    ctx.set(bus.r_stb, op is not None and op.data is None)
    if op is not None:
        ctx.set(bus.addr, op.addr)
        ctx.set(bus.w_data, op.data or 0)
