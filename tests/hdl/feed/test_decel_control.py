# amaranth: UnusedElaboratable=no
"""Decel control: the FP budget gate passes exactly the loaded count, then closes.

Covering budgets 0..2**24-1 in bounded time: the gate's whole state is (remaining, hold), so
a gate loaded with v that has passed v - s pulses is in exactly the state of a gate loaded
with s. The gateware is therefore shown (1) equal to the model cycle by cycle on random
streams with reloads and holds, (2) to pass exactly s pulses for small loads s, spent rising
exactly when REMAINING reaches 0, and (3) to count down by one per passed pulse from loads
anywhere in the range, across byte borrows and from 2**24-1 itself (REMAINING read over the
bus). The model, cheap to run, passes exactly v pulses for v drawn over the whole range.
"""

import random
from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from k37.hdl.feed.decel_control import DecelControl
from k37.hdl.feed.map.decel_control import DECEL_MAP
from k37.hdl.feed.model.decel_control import DecelControlModel
from k37.hdl.feed.rates import BUDGET_WIDTH
from tests.testbench import read_reg, simulate, write_reg

BUDGET, REMAINING, CTRL, STATUS = (DECEL_MAP[name] for name in
                                   ("BUDGET", "REMAINING", "CTRL", "STATUS"))
FULL = (1 << BUDGET_WIDTH) - 1


def status_bits(status: int) -> tuple[int, int]:
    """(spent, open) from a STATUS value."""
    return STATUS.field("spent").decode(status), STATUS.field("open").decode(status)


@dataclass
class Cycle:
    """One cycle of stimulus and what the model sees in it."""

    inp: bool
    bus: tuple[int, int] | None = None      # (address, byte) written in this cycle
    load: int | None = None                 # BUDGET commit seen by the chip in this cycle
    hold: bool | None = None                # CTRL commit seen by the chip in this cycle


def random_schedule(rng: random.Random, cycles: int, max_budget: int) -> list[Cycle]:
    """Random pulses with BUDGET loads and CTRL hold writes, byte by byte as the host does."""
    schedule: list[Cycle] = []
    effect: dict = {}
    while len(schedule) < cycles:
        r = rng.random()
        writes: list[tuple[int, int]] = []
        if r < 0.02:
            value = rng.choice((0, rng.randrange(max_budget)))
            writes = [(BUDGET.addr + k, b) for k, b in enumerate(BUDGET.to_bytes(value))]
            new_effect = {"load": value}
        elif r < 0.03:
            hold = rng.random() < 0.5
            writes = [(CTRL.addr, CTRL.encode(hold=hold))]
            new_effect = {"hold": hold}
        for bus in writes or [None]:
            schedule.append(Cycle(rng.random() < 0.6, bus, **effect))
            effect = {}
        if writes:
            effect = new_effect                  # seen by the chip in the following cycle
    return schedule


def run_gateware(schedule: list[Cycle]) -> list[tuple[int, int, int]]:
    """Per cycle ``(out, spent, remaining)`` of the gateware."""
    dut = DecelControl()
    seen = []

    async def bench(ctx):
        for cycle in schedule:
            ctx.set(dut.inp, cycle.inp)
            ctx.set(dut.bus.w_stb, cycle.bus is not None)
            if cycle.bus:
                ctx.set(dut.bus.addr, cycle.bus[0])
                ctx.set(dut.bus.w_data, cycle.bus[1])
            seen.append((ctx.get(dut.out), ctx.get(dut.spent), ctx.get(dut.remaining)))
            await ctx.tick()

    simulate(dut, bench)
    return seen


@settings(derandomize=True, max_examples=8, deadline=None)
@given(st.integers(0, 2**32))
def test_gateware_equals_model_with_reloads_and_holds(seed):
    schedule = random_schedule(random.Random(seed), 1500, 60)
    model = DecelControlModel()
    passed = 0
    for cycle, (out, spent, remaining) in zip(schedule, run_gateware(schedule), strict=True):
        if cycle.hold is not None:
            model.hold = cycle.hold
        assert (spent, remaining) == (model.spent, model.remaining)
        assert out == model.step(cycle.inp, cycle.load)
        passed += out
    assert passed > 0


async def feed(ctx, dut: DecelControl, pulses: int, rng: random.Random) -> list[int]:
    """Offer ``pulses`` input pulses with random gaps; returns the cycles ``out`` was high."""
    passed = []
    cycle = 0
    while pulses:
        pulse = rng.random() < 0.7
        ctx.set(dut.inp, pulse)
        if ctx.get(dut.out):
            passed.append(cycle)
        pulses -= pulse
        cycle += 1
        await ctx.tick()
    ctx.set(dut.inp, 0)
    return passed


async def spent_rises_exactly_at_zero(ctx, dut: DecelControl, remaining: int) -> None:
    """Pass the last ``remaining`` (small) pulses one at a time, watching ``spent``."""
    for left in range(remaining, 0, -1):
        assert not ctx.get(dut.spent)
        assert ctx.get(dut.remaining) == left
        ctx.set(dut.inp, 1)
        assert ctx.get(dut.out)
        await ctx.tick()
    ctx.set(dut.inp, 0)
    assert ctx.get(dut.spent)


@settings(derandomize=True, max_examples=10, deadline=None)
@given(st.integers(0, 300), st.integers(0, 2**32))
@example(0, 1)
@example(1, 1)
@example(256, 1)
def test_small_budget_passes_exactly_that_many_then_spent_rises(budget, seed):
    rng = random.Random(seed)
    dut = DecelControl()

    async def bench(ctx):
        await write_reg(ctx, dut.bus, BUDGET, budget)
        await ctx.tick()                           # the cycle the load is seen
        last = min(budget, 3)
        assert len(await feed(ctx, dut, budget - last, rng)) == budget - last
        await spent_rises_exactly_at_zero(ctx, dut, last)
        assert await feed(ctx, dut, 50, rng) == []
        assert await read_reg(ctx, dut.bus, REMAINING) == 0
        assert status_bits(await read_reg(ctx, dut.bus, STATUS)) == (1, 0)

    simulate(dut, bench)


@settings(derandomize=True, max_examples=8, deadline=None)
@given(st.integers(1, FULL), st.integers(1, 200), st.integers(0, 2**32))
@example(FULL, 200, 1)
@example(0x800000, 3, 1)
@example(0x010000, 2, 1)
@example(0x000100, 3, 1)
def test_any_budget_counts_down_one_per_passed_pulse(budget, pulses, seed):
    pulses = min(pulses, budget)
    rng = random.Random(seed)
    dut = DecelControl()

    async def bench(ctx):
        await write_reg(ctx, dut.bus, BUDGET, budget)
        assert len(await feed(ctx, dut, pulses, rng)) == pulses
        assert await read_reg(ctx, dut.bus, REMAINING) == budget - pulses
        assert ctx.get(dut.spent) == (budget == pulses)

    simulate(dut, bench)


@pytest.mark.slow
def test_budget_2_pow_24_minus_1_counts_down_across_a_16_bit_borrow():
    dut = DecelControl()
    pulses = (1 << 16) + 5                   # 0xFFFFFF -> 0xFEFFFA: every byte borrows

    async def bench(ctx):
        await write_reg(ctx, dut.bus, BUDGET, FULL)
        ctx.set(dut.inp, 1)
        await ctx.tick().repeat(pulses)
        ctx.set(dut.inp, 0)
        assert await read_reg(ctx, dut.bus, REMAINING) == FULL - pulses
        assert not ctx.get(dut.spent)

    simulate(dut, bench)


def test_hold_closes_the_gate_at_once_and_keeps_the_remaining_budget():
    dut = DecelControl()
    rng = random.Random(3)

    async def bench(ctx):
        await write_reg(ctx, dut.bus, BUDGET, 10)
        assert len(await feed(ctx, dut, 3, rng)) == 3
        ctx.set(dut.inp, 1)                       # pulses keep coming during the write
        await write_reg(ctx, dut.bus, CTRL, CTRL.encode(hold=1))
        assert ctx.get(dut.remaining) == 6         # the pulse of the write cycle passed ...
        assert not ctx.get(dut.out)               # ... the gate is shut once the commit is seen
        assert await feed(ctx, dut, 20, rng) == []
        remaining = await read_reg(ctx, dut.bus, REMAINING)
        assert remaining == 6
        status = await read_reg(ctx, dut.bus, STATUS)
        assert status_bits(status) == (0, 0)
        assert await read_reg(ctx, dut.bus, CTRL) == CTRL.encode(hold=1)
        await write_reg(ctx, dut.bus, CTRL, CTRL.encode(hold=0))
        assert len(await feed(ctx, dut, 30, rng)) == remaining
        assert ctx.get(dut.spent)

    simulate(dut, bench)


def test_gate_is_closed_after_reset_until_a_budget_is_loaded():
    dut = DecelControl()

    async def bench(ctx):
        assert await feed(ctx, dut, 10, random.Random(1)) == []
        status = await read_reg(ctx, dut.bus, STATUS)
        assert status_bits(status) == (1, 0)

    simulate(dut, bench)


@settings(derandomize=True, max_examples=6, deadline=None)
@given(st.integers(0, FULL), st.integers(0, 2**32))
@example(FULL, 1)
@example(0, 1)
def test_model_passes_exactly_the_budget_over_the_whole_range(budget, seed):
    rng = np.random.default_rng(seed)
    model = DecelControlModel()
    model.step(False, load=budget)
    passed = offered = 0
    chunk = 1 << 20
    while offered < budget + 1000:            # feed in chunks, with random gaps
        inp = rng.random(chunk) < 0.8
        out = model.run(inp)
        assert not (out & ~inp).any()
        passed += int(out.sum())
        offered += int(inp.sum())
    assert passed == budget
    assert model.spent


@settings(derandomize=True, max_examples=20, deadline=None)
@given(st.integers(0, 500), st.booleans(), st.integers(0, 2**32))
def test_model_run_equals_step(budget, hold, seed):
    rng = random.Random(seed)
    inp = [rng.random() < 0.5 for _ in range(1200)]
    stepped, ran = DecelControlModel(), DecelControlModel()
    for model in (stepped, ran):
        model.step(False, load=budget)
        model.hold = hold
    assert ran.run(np.array(inp)).tolist() == [stepped.step(i) for i in inp]
    assert ran.remaining == stepped.remaining


def test_budget_out_of_range_is_refused_by_name():
    with pytest.raises(ValueError, match=r"register BUDGET: 16777216 is outside"):
        BUDGET.to_bytes(1 << 24)
    with pytest.raises(ValueError, match=r"budget must be in 0..2\*\*24-1, not -1"):
        DecelControlModel().step(True, load=-1)
