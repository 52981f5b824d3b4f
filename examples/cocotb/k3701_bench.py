"""A cocotb testbench of the exported K3701 (``k3701.v`` in ``k3701_tb.v``): a block written
over the host bus, the feed pulses from the testbench, the step pulses and the interrupt
checked against what the datasheet says (``docs/chips/k3701.md``)."""

from __future__ import annotations

import cocotb
from cocotb.triggers import ClockCycles, FallingEdge, RisingEdge
from host_bus import read_register, start, write_register

from k37.hdl.k3701.map import K3701_MAP

#: Cycles between two feed pulses (the K3701 takes one FP at a time, then steps).
FP_EVERY = 32


async def feed(dut) -> None:
    """One feed pulse every ``FP_EVERY`` cycles, for ever."""
    while True:
        await FallingEdge(dut.clk)
        dut.fp.value = 1
        await FallingEdge(dut.clk)
        dut.fp.value = 0
        await ClockCycles(dut.clk, FP_EVERY - 2, rising=False)


async def count_steps(dut, counts: dict[str, int]) -> None:
    """Count each step output's one-cycle pulses, at the rising edge that ends each cycle."""
    while True:
        await RisingEdge(dut.clk)
        for name in counts:
            counts[name] += int(getattr(dut, name).value)


async def run_linear_block(dut, x: int, y: int) -> dict[str, int]:
    """Start a linear block to (x, y), feed it until its data request; the steps counted."""
    await write_register(dut, K3701_MAP["X"], x)
    await write_register(dut, K3701_MAP["Y"], y)
    await write_register(dut, K3701_MAP["CTRL"], 0)
    await write_register(dut, K3701_MAP["CMD"], K3701_MAP["CMD"].encode(start=1))
    counts = dict.fromkeys(("x_pos", "x_neg", "y_pos", "y_neg"), 0)
    counter = cocotb.start_soon(count_steps(dut, counts))
    feeder = cocotb.start_soon(feed(dut))
    for _ in range(4 * FP_EVERY * max(abs(x), abs(y)) + 1000):
        await RisingEdge(dut.clk)
        if int(dut.irq.value):
            break
    feeder.cancel()
    await ClockCycles(dut.clk, 2)
    counter.cancel()
    return counts


@cocotb.test()
async def a_linear_block_gives_its_step_pulses_and_then_the_interrupt(dut):
    await start(dut, fp=0)
    assert int(dut.busy.value) == 0 and int(dut.irq.value) == 0
    counts = await run_linear_block(dut, 40, -25)
    assert counts == {"x_pos": 40, "x_neg": 0, "y_pos": 0, "y_neg": 25}
    assert int(dut.irq.value) == 1 and int(dut.busy.value) == 0
    status = K3701_MAP["STATUS"]
    assert await read_register(dut, status) == status.encode(irq=1)
    await write_register(dut, K3701_MAP["CMD"], K3701_MAP["CMD"].encode(ack=1))
    await ClockCycles(dut.clk, 2)
    assert int(dut.irq.value) == 0
    assert await read_register(dut, status) == 0


@cocotb.test()
async def a_start_while_busy_is_refused_with_error(dut):
    await start(dut, fp=0)
    cmd, status = K3701_MAP["CMD"], K3701_MAP["STATUS"]
    await write_register(dut, K3701_MAP["X"], 10)
    await write_register(dut, K3701_MAP["Y"], 10)
    await write_register(dut, cmd, cmd.encode(start=1))
    await write_register(dut, cmd, cmd.encode(start=1))     # no feed: still busy
    await ClockCycles(dut.clk, 2)
    assert int(dut.busy.value) == 1 and int(dut.error.value) == 1
    assert await read_register(dut, status) == status.encode(busy=1, error=1)
    await write_register(dut, cmd, cmd.encode(clear=1))
    await ClockCycles(dut.clk, 2)
    assert int(dut.error.value) == 0
