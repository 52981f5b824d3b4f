# amaranth: UnusedElaboratable=no
"""The FEED chip against its reference model, cycle by cycle, in its plain and per-axis fa
builds: the feed pulses, the shared fa and each axis's own fa, the registers' readback."""

from __future__ import annotations

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from k37.hdl.feed.feed_rate import FeedRate
from k37.hdl.feed.map.feed_rate import FA_AXES, FEED_MAP, FEED_MAP_AXIS_FA, feed_map
from k37.hdl.feed.model.feed_rate import FeedRateModel
from k37.hdl.feed.rates import FA_INCREMENT
from tests.testbench import drive_bus, read_reg, simulate, write_ops

#: A host's writes: (register, value, idle cycles after the write).
Writes = list[tuple[str, int, int]]


def run_both(axis_fa: tuple[str, ...], writes: Writes, tail: int = 60) -> tuple[list, list, dict]:
    """The gateware's and the model's outputs in every cycle of ``writes`` (then ``tail``
    idle cycles), and the registers read back over the bus at the end."""
    dut, model = FeedRate(axis_fa), FeedRateModel(axis_fa)
    names = ("out", "fa", *(f"fa_{axis}" for axis in dut.axis_fa))
    ops = []
    for name, value, gap in writes:
        reg = dut.regmap[name]
        ops += [(op, name if k == reg.nbytes - 1 else None, value)
                for k, op in enumerate(write_ops(reg, value))] + [(None, None, 0)] * gap
    ops += [(None, None, 0)] * tail
    seen, expected, read = [], [], {}

    async def bench(ctx):
        for op, commit, value in ops:
            drive_bus(ctx, dut.bus, op)
            if commit is not None:
                model.write(commit, value)
            seen.append({name: ctx.get(getattr(dut, name)) for name in names})
            expected.append(model.step())
            await ctx.tick()
        drive_bus(ctx, dut.bus, None)
        for reg in dut.regmap:
            read[reg.name] = await read_reg(ctx, dut.bus, reg)

    simulate(dut, bench)
    return seen, expected, read | {"model": model.registers}


def _increment() -> st.SearchStrategy[int]:
    # Fast clocks (a strobe every few cycles) as well as slow ones and 0 (stopped).
    return st.one_of(st.integers(1 << 21, (1 << 24) - 1), st.integers(0, (1 << 24) - 1),
                     st.just(0))


@st.composite
def host_writes(draw) -> tuple[tuple[str, ...], Writes]:
    axis_fa = tuple(draw(st.sets(st.sampled_from(tuple(FA_AXES)))))
    regmap = feed_map(axis_fa)
    writes = []
    for _ in range(draw(st.integers(1, 6))):
        name = draw(st.sampled_from([r.name for r in regmap]))
        value = (draw(st.integers(0, (1 << 18) - 1)) if name == "FEED" else draw(_increment()))
        writes.append((name, value, draw(st.integers(0, 40))))
    return axis_fa, writes


@settings(derandomize=True, max_examples=8, deadline=None)
@given(host_writes())
@example((("x", "y"), [("FA_INC_X", 1 << 22, 30), ("FA_INC_Y", 3 << 21, 30),
                       ("FA_INC", 1 << 23, 30)]))
@example((("z",), [("RM_INC", (1 << 24) - 1, 0), ("FEED", 0x00FF, 0), ("FA_INC_Z", 0, 50)]))
def test_the_gateware_equals_the_model_cycle_by_cycle(case):
    axis_fa, writes = case
    seen, expected, read = run_both(axis_fa, writes)
    assert seen == expected
    assert {name: read[name] for name in read["model"]} == read["model"]


def test_each_axis_clock_runs_at_its_own_rate_beside_the_shared_one():
    writes = [("FA_INC", 1 << 21, 0), ("FA_INC_X", 1 << 22, 0), ("FA_INC_Y", 3 << 21, 0)]
    seen, expected, _ = run_both(("x", "y"), writes, tail=800)
    assert seen == expected
    late = seen[-640:]  # whole periods of all three, well after the writes
    assert [sum(s[name] for s in late) for name in ("fa", "fa_x", "fa_y")] == [80, 160, 240]


def test_every_axis_clock_resets_to_the_shared_ones_rate_and_phase():
    seen, expected, read = run_both(("x", "y", "z"), [], tail=200)
    assert seen == expected
    assert all(s["fa"] == s["fa_x"] == s["fa_y"] == s["fa_z"] for s in seen)
    assert read["FA_INC_Z"] == read["FA_INC"] == FA_INCREMENT


def test_the_plain_chip_has_one_fa_and_the_plain_map():
    chip = FeedRate()
    assert chip.regmap is FEED_MAP and chip.axis_fa == ()
    assert {"fa_x", "fa_y", "fa_z"}.isdisjoint(chip.signature.members)
    assert [a.path for a in FeedRate.declare().accumulators] == ["rm_clock", "fa_clock"]


def test_the_per_axis_registers_sit_at_free_addresses_above_the_plain_maps():
    for reg in FEED_MAP:
        assert FEED_MAP_AXIS_FA[reg.name] == reg
    assert [(r.name, r.addr) for r in FEED_MAP_AXIS_FA if r.name not in
            {r.name for r in FEED_MAP}] == [("FA_INC_X", 0x09), ("FA_INC_Y", 0x0C),
                                              ("FA_INC_Z", 0x0F)]
    assert [r.name for r in feed_map(("z", "x"))][3:] == ["FA_INC_X", "FA_INC_Z"]
    with pytest.raises(ValueError, match="no axis 'w'"):
        feed_map(("w",))


def test_each_axis_clock_is_declared_free_running():
    declared = FeedRate.declare(("y", "x"))
    assert [a.path for a in declared.accumulators] == ["rm_clock", "fa_clock", "fa_clock_x",
                                                        "fa_clock_y"]
