"""The engine's closed forms for its idle skipping (``free.h``) equal the reference models of
the blocks they advance: the phase divider's strobes and the rate multiplier's next pulse."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from k37.hdl.feed.model.divider import PhaseDividerModel
from k37.hdl.feed.model.rate_multiplier import RateMultiplierModel, gate
from k37.sim.backends.engine.backend import load
from k37.sim.backends.engine.build import build


@pytest.fixture(scope="module")
def lib():
    return load(str(build().path))


@settings(max_examples=60, deadline=None)
@given(phase=st.integers(0, (1 << 12) - 1), increment=st.integers(0, (1 << 12) - 1),
       stb=st.booleans(), safe=st.integers(0, 5))
def test_strobes_and_cycles_within_follow_the_phase_divider(lib, phase, increment, stb, safe):
    width = 12
    divider = PhaseDividerModel(width)
    divider.phase, divider.stb = phase, stb
    seen = [int(divider.step(increment)) for _ in range(200)]
    for k in (1, 2, 57, 200):
        assert lib.k37e_strobes_seen(phase, increment, stb, width, k) == sum(seen[:k])
    within = lib.k37e_cycles_within(phase, increment, stb, width, safe)
    fits = [k for k in range(201) if sum(seen[:k]) <= safe]
    assert min(within, 200) == max(fits)


@settings(max_examples=60, deadline=None)
@given(count=st.integers(0, (1 << 12) - 1), word=st.integers(0, (1 << 12) - 1))
def test_clocks_before_pulse_follow_the_rate_multiplier(lib, count, word):
    stages = 2
    rate = RateMultiplierModel(stages)
    rate.count = count
    clocks = lib.k37e_clocks_before_pulse(count, word, 6 * stages)
    if word == 0:
        assert clocks == (1 << 64) - 1
        return
    pulses = [rate.step(word, True)[0] for _ in range(1 << 12)]
    assert pulses.index(True) == clocks
    assert gate((count + 1 + clocks) % (1 << 12), word, stages)
