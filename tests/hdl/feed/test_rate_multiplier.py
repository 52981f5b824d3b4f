# amaranth: UnusedElaboratable=no
"""Rate multiplier: the SN7497's pulse pattern per stage, and exact counts when cascaded.

The reference model's decoding is the rule; the gateware and the compiled backend's closed
forms (its idle skipping) are tested against it.
"""

import ctypes
import random

import numpy as np
import pytest
from amaranth.hdl import Elaboratable, Module, Signal
from hypothesis import given, settings
from hypothesis import strategies as st

from k37.hdl.feed.model.rate_multiplier import RateMultiplierModel, gate, selected_bit, stage_gate
from k37.hdl.feed.rate_multiplier import RateMultiplier
from k37.hdl.feed.rates import STAGE_BITS
from k37.sim.backends.cxxrtl.backend import CxxrtlBackend
from tests.testbench import simulate

#: The 7497's decoding gates as the datasheet's logic diagram wires them: rate bit b passes
#: the counter states s with s mod period == residue (F: QA low; E: QA high, QB low; ...).
SN7497_GATES = {5: (2, 0), 4: (4, 1), 3: (8, 3), 2: (16, 7), 1: (32, 15), 0: (64, 31)}


def sn7497_states(rate: int) -> set[int]:
    """The counter states in which a 7497 with rate inputs ``rate`` passes the clock."""
    return {s for s in range(64) for bit, (period, residue) in SN7497_GATES.items()
            if rate >> bit & 1 and s % period == residue}


def test_the_model_decodes_as_the_datasheet():
    for rate in range(64):
        states = sn7497_states(rate)
        assert {s for s in range(64) if stage_gate(s, rate)} == states, rate
        assert {s for s in range(64) if rate >> selected_bit(s, 1) & 1} == states, rate


def run_gateware(dut: RateMultiplier, stimulus: list[tuple[int, bool]]) -> list[tuple]:
    """``(out, enable_out, count)`` of each cycle, driving ``(word, clk_en)`` per cycle."""
    seen: list[tuple] = []

    async def bench(ctx):
        for word, clk_en in stimulus:
            ctx.set(dut.word, word)
            ctx.set(dut.clk_en, clk_en)
            seen.append((ctx.get(dut.out), ctx.get(dut.enable_out), ctx.get(dut.count)))
            await ctx.tick()

    simulate(dut, bench)
    return seen


def test_every_rate_gives_m_pulses_per_64_clocks_at_the_7497_states():
    rng = random.Random(7497)
    dut = RateMultiplier(stages=1)
    stimulus = []
    for rate in range(64):
        # 64 input clocks per rate, spread over cycles with random gaps.
        clocks = 0
        while clocks < 64:
            clk_en = rng.random() < 0.6
            stimulus.append((rate, clk_en))
            clocks += clk_en
    seen = run_gateware(dut, stimulus)

    clock = 0
    pulses_by_rate = dict.fromkeys(range(64), 0)
    for (rate, clk_en), (out, enable_out, _) in zip(stimulus, seen, strict=True):
        assert out <= clk_en and enable_out <= clk_en
        if clk_en:
            clock += 1                                 # the state this input clock reaches
            state = clock % 64
            assert out == (state in sn7497_states(rate)), (rate, state)
            assert enable_out == (state == 63)
            pulses_by_rate[rate] += out
    assert pulses_by_rate == {rate: rate for rate in range(64)}


def test_single_rate_inputs_pulse_where_the_datasheet_says():
    # A alone: once per 64 clocks, at the 31st clock after reset; F alone: every even clock.
    seen = run_gateware(RateMultiplier(stages=1), [(0b000001, 1)] * 128)
    assert [t + 1 for t, (out, _, _) in enumerate(seen) if out] == [31, 95]
    seen = run_gateware(RateMultiplier(stages=1), [(0b100000, 1)] * 16)
    assert [t + 1 for t, (out, _, _) in enumerate(seen) if out] == [2, 4, 6, 8, 10, 12, 14, 16]


@settings(derandomize=True, max_examples=6, deadline=None)
@given(st.sampled_from([2, 3]), st.integers(0, 2**32))
def test_gateware_equals_model_with_changing_words_and_clock_gaps(stages, seed):
    rng = random.Random(seed)
    bits = 6 * stages
    stimulus = []
    word = rng.randrange(1 << bits)
    for _ in range(1500):
        if rng.random() < 0.01:
            word = rng.randrange(1 << bits)
        stimulus.append((word, rng.random() < 0.8))
    model = RateMultiplierModel(stages)
    seen = run_gateware(RateMultiplier(stages), stimulus)
    for (word, clk_en), (out, enable_out, count) in zip(stimulus, seen, strict=True):
        assert count == model.count
        assert (out, enable_out) == model.step(word, clk_en)


@settings(derandomize=True, max_examples=4, deadline=None)
@given(st.integers(0, (1 << 12) - 1))
def test_12_bit_word_gives_exactly_w_pulses_per_4096_clocks(word):
    seen = run_gateware(RateMultiplier(stages=2), [(word, 1)] * 4096)
    assert sum(out for out, _, _ in seen) == word
    assert sum(enable_out for _, enable_out, _ in seen) == 1


@settings(derandomize=True, max_examples=3, deadline=None)
@given(st.integers(0, (1 << 12) - 1))
def test_gateware_pulses_in_the_states_the_model_gates_over_a_whole_period(word):
    seen = run_gateware(RateMultiplier(stages=2), [(word, 1)] * 4096)
    states = np.arange(1, 4097) % 4096  # the state each input clock reaches
    assert [out for out, _, _ in seen] == gate(states, word, 2).tolist()
    assert [count for _, _, count in seen] == list(range(4096))


class _PulseCounter(Elaboratable):
    """A rate multiplier on every cycle with counters of its pulses, for long free runs."""

    def __init__(self, stages: int):
        self.dut = RateMultiplier(stages)
        self.pulses = Signal(6 * stages + 1)
        self.enables = Signal(6 * stages + 1)

    def elaborate(self, platform):
        m = Module()
        m.submodules.dut = dut = self.dut
        m.d.comb += dut.clk_en.eq(1)
        m.d.sync += [self.pulses.eq(self.pulses + dut.out),
                     self.enables.eq(self.enables + dut.enable_out)]
        return m


@pytest.mark.slow
def test_18_bit_word_gives_exactly_w_pulses_per_2_pow_18_clocks_in_gateware():
    word = 0b101010_111100_110101       # every stage has several rate bits set
    top = _PulseCounter(stages=3)

    async def bench(ctx):
        ctx.set(top.dut.word, word)
        await ctx.tick().repeat(1 << 18)
        assert ctx.get(top.pulses) == word
        assert ctx.get(top.enables) == 1

    simulate(top, bench)


@settings(derandomize=True, max_examples=25, deadline=None)
@given(st.integers(0, (1 << 18) - 1), st.integers(0, (1 << 18) - 1))
def test_18_bit_word_gives_w_pulses_in_any_2_pow_18_consecutive_clocks_in_model(word, start):
    # The model's gate, vectorised over one full counter period starting anywhere.
    states = (start + np.arange(1 << 18)) % (1 << 18)
    hits = gate(states, word, 3)
    assert int(np.count_nonzero(hits)) == word
    # ... and the per-cycle model agrees with the vectorised gate on a stretch of it.
    model = RateMultiplierModel(3)
    model.count = (start - 1) % (1 << 18)
    assert [model.step(word, True)[0] for _ in range(2000)] == hits[:2000].tolist()


def test_cascaded_stages_never_pulse_together():
    # Each stage alone and all together: the together count is the sum, so no overlap.
    states = np.arange(1 << 12)
    for word in (0o7777, 0o4001, 0o0077, 0o7700):
        together = np.count_nonzero(gate(states, word, 2))
        alone = sum(np.count_nonzero(gate(states, word & mask, 2)) for mask in (0o7700, 0o0077))
        assert together == alone == word


def test_bad_parameters_are_refused_by_name():
    with pytest.raises(ValueError, match="stages must be at least 1, not 0"):
        RateMultiplier(stages=0)
    with pytest.raises(TypeError, match=r"stages must be an integer, not 1\.5"):
        RateMultiplier(stages=1.5)
    with pytest.raises(ValueError, match=r"word must be in 0..2\*\*6-1, not 64"):
        RateMultiplierModel(1).step(64, True)


@pytest.fixture(scope="module")
def harness() -> ctypes.CDLL:
    """The compiled backend's harness (linked into every model), for its closed forms."""
    backend = CxxrtlBackend(RateMultiplier(stages=1))
    lib = ctypes.CDLL(str(backend.model.path))
    backend.close()
    u64, uint = ctypes.c_uint64, ctypes.c_uint
    lib.k37_rm_selected_bit.restype, lib.k37_rm_selected_bit.argtypes = uint, [u64, uint]
    lib.k37_rm_clocks_before_pulse.restype = u64
    lib.k37_rm_clocks_before_pulse.argtypes = [u64, u64, uint]
    return lib


@settings(derandomize=True, max_examples=150, deadline=None)
@given(stages=st.sampled_from([1, 2, 3]), data=st.data())
def test_the_compiled_backends_closed_forms_follow_the_model(harness, stages, data):
    bits = STAGE_BITS * stages
    count = data.draw(st.one_of(st.integers(0, (1 << bits) - 1),
                                st.integers(0, bits).map(lambda t: (1 << t) - 1)))
    word = data.draw(st.one_of(st.integers(0, (1 << bits) - 1),
                               st.integers(0, bits - 1).map(lambda b: 1 << b)))
    assert harness.k37_rm_selected_bit(count, bits) == selected_bit(count, stages)
    # Input clocks before the first pulse, from the model over a whole period.
    hits = np.flatnonzero(gate((count + 1 + np.arange(1 << bits)) % (1 << bits), word, stages))
    expected = int(hits[0]) if hits.size else (1 << 64) - 1
    assert harness.k37_rm_clocks_before_pulse(count, word, bits) == expected
