# amaranth: UnusedElaboratable=no
"""The K3701's step latency count: gateware equals its model cycle by cycle; the strobes'
timing; bad parameters refused by name."""

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from k37.hdl.k3701.block import LATENCY_CIRCULAR, LATENCY_LINEAR
from k37.hdl.k3701.datapaths.circular import CircularDatapath
from k37.hdl.k3701.datapaths.parabolic import ParabolicDatapath
from k37.hdl.k3701.latency import StepLatency
from k37.hdl.k3701.model.latency import StepLatencyModel
from tests.testbench import simulate

#: The chip's datapaths at the paper's latencies: linear (no stages), circular, parabolic.
LATENCIES = (LATENCY_LINEAR, LATENCY_CIRCULAR, LATENCY_CIRCULAR)
STAGES = (0, CircularDatapath.STAGES, ParabolicDatapath.STAGES)

Inputs = tuple[bool, bool, int, bool, tuple[bool, ...]]  # clear, load, value, run, running


def gateware(cycles: list[Inputs]) -> list[tuple]:
    dut = StepLatency(LATENCIES, STAGES)
    seen: list[tuple] = []

    async def bench(ctx):
        for clear, load, value, run, running in cycles:
            for port, v in ((dut.clear, clear), (dut.load, load), (dut.value, value),
                            (dut.run, run)):
                ctx.set(port, v)
            for i, r in enumerate(running):
                ctx.set(dut.running[i], r)
            seen.append((ctx.get(dut.count), bool(ctx.get(dut.zero)), bool(ctx.get(dut.last)),
                         tuple(bool(ctx.get(a)) for a in dut.advance),
                         tuple(ctx.get(s) for s in dut.stage)))
            await ctx.tick()

    simulate(dut, bench)
    return seen


def model(cycles: list[Inputs]) -> list[tuple]:
    count = StepLatencyModel(LATENCIES, STAGES)
    seen = []
    for clear, load, value, run, running in cycles:
        out = count.outputs(running)
        seen.append((count.count, out.zero, out.last, out.advance, out.stage))
        count.step(clear=clear, load=load, value=value, run=run)
    return seen


# clear and load are rare, run is mostly high (as in the chip), so that counts run down; a
# load is mostly of a latency's L - 1, as the chip's.
_cycle = st.tuples(st.sampled_from([False] * 9 + [True]),
                   st.sampled_from([False] * 6 + [True]),
                   st.sampled_from([latency - 1 for latency in LATENCIES])
                   | st.integers(0, max(LATENCIES) - 1),
                   st.sampled_from([True] * 4 + [False]),
                   st.tuples(*[st.booleans()] * 3))


@settings(derandomize=True, max_examples=40, deadline=None)
@given(st.lists(_cycle, min_size=1, max_size=120))
def test_gateware_equals_model_cycle_by_cycle(cycles):
    assert gateware(cycles) == model(cycles)


def test_a_load_times_the_stages_then_the_step_then_counts_to_zero():
    """Loaded with L - 1 in cycle 0 while the circular datapath runs: stage s in cycle
    1 + s, advance (the count at 1) in cycle L - 1, zero from cycle L on."""
    latency = LATENCY_CIRCULAR
    cycles = [(False, True, latency - 1, True, (False, True, False))] + \
        [(False, False, 0, True, (False, True, False))] * (latency + 1)
    seen = model(cycles)
    assert gateware(cycles) == seen
    stages = [k for k, (*_, stage) in enumerate(seen) if stage[1]]
    assert [seen[k][4][1] for k in stages] == [1, 2, 4, 8] and stages == [1, 2, 3, 4]
    assert [k for k, row in enumerate(seen) if row[3][1]] == [latency - 1]
    assert [k for k, row in enumerate(seen) if row[1]] == [0, latency, latency + 1]
    assert all(row[4][2] == 0 and not row[3][2] for row in seen)  # parabolic not running


@pytest.mark.parametrize(("latencies", "stages", "message"), [
    ((10, 20), (0,), "one stage count per latency"),
    ((1,), (0,), "a latency must be at least 2, not 1"),
    ((5,), (4,), "a latency of 5 cycles has no room for 4 stages"),
    ((10,), ("4",), "a stage count must be an integer, not '4'"),
])
def test_bad_parameters_are_refused_by_name(latencies, stages, message):
    with pytest.raises((ValueError, TypeError), match=message):
        StepLatency(latencies, stages)
