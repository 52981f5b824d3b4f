# amaranth: UnusedElaboratable=no
"""Phase-accumulator divider: exact strobe counts, model equality, the paper's fa."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from k37.hdl.feed.divider import PhaseDivider
from k37.hdl.feed.model.divider import PhaseDividerModel
from k37.hdl.feed.rates import FA_INCREMENT, frequency_of, increment_for
from tests.testbench import simulate


def run_gateware(width: int, increments: list[int]) -> list[bool]:
    """The divider's ``stb`` in each cycle, with ``increments[t]`` on the port in cycle t."""
    dut = PhaseDivider(width)
    seen: list[bool] = []

    async def bench(ctx):
        for inc in increments:
            ctx.set(dut.increment, inc)
            seen.append(bool(ctx.get(dut.stb)))
            await ctx.tick()

    simulate(dut, bench)
    return seen


@settings(derandomize=True, max_examples=12, deadline=None)
@given(st.sampled_from([3, 8, 24]).flatmap(
    lambda w: st.tuples(st.just(w), st.integers(0, (1 << w) - 1))))
def test_strobes_in_first_t_cycles_are_floor_t_increment_over_2_pow_width(case):
    width, inc = case
    cycles = 400
    stb = run_gateware(width, [inc] * cycles)
    counts = np.cumsum(stb)
    # The strobe of cycle t reports the carry of the addition at the end of cycle t - 1.
    for t in range(1, cycles):
        assert counts[t] == (t * inc) >> width
    assert stb == PhaseDividerModel(width).run(inc, cycles).tolist()


@settings(derandomize=True, max_examples=8, deadline=None)
@given(st.lists(st.integers(0, 255), min_size=1, max_size=300))
def test_gateware_equals_model_when_the_host_changes_the_increment(increments):
    model = PhaseDividerModel(8)
    assert run_gateware(8, increments) == [model.step(inc) for inc in increments]


@settings(derandomize=True, max_examples=30, deadline=None)
@given(st.integers(0, (1 << 24) - 1), st.integers(0, 5000), st.integers(0, 5000))
def test_model_run_equals_step(inc, warmup, cycles):
    stepped, ran = PhaseDividerModel(), PhaseDividerModel()
    for _ in range(warmup):
        stepped.step(inc)
        ran.step(inc)
    expected = [stepped.step(inc) for _ in range(cycles)]
    assert ran.run(inc, cycles).tolist() == expected
    assert (ran.phase, ran.stb) == (stepped.phase, stepped.stb)


def test_paper_fa_from_1_mhz_gives_tau_300_ms():
    fa = frequency_of(FA_INCREMENT)
    assert abs(fa - 2**15 / 0.3) < 0.06           # one increment step is 0.0596 Hz
    assert abs(2**15 / fa - 0.3) < 1e-6


def test_increment_for_inverts_frequency_of():
    for inc in (0, 1, 1000, FA_INCREMENT, (1 << 24) - 1):
        assert increment_for(frequency_of(inc)) == inc


def test_bad_parameters_are_refused_by_name():
    with pytest.raises(TypeError, match="width must be an integer, not '8'"):
        PhaseDivider("8")
    with pytest.raises(ValueError, match="width must be at least 1, not 0"):
        PhaseDivider(0)
    with pytest.raises(ValueError, match=r"^frequency must be >= 0\.05960464478 and < 1000000 Hz "
                                         r"\(24-bit divider at clock_hz\), not 2000000\.0$"):
        increment_for(2e6)
    with pytest.raises(ValueError, match=r"^frequency must be >= 0\.0596.* not 0\.05$"):
        increment_for(0.05)  # an increment that rounds to 0 would stop the strobe
    with pytest.raises(ValueError, match=r"increment must be in 0..2\*\*8-1, not 256"):
        PhaseDividerModel(8).step(256)
