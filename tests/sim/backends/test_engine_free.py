"""The engine's closed forms for its idle skipping (``free.h``, ``lag.h``) equal the reference
models of the blocks they advance: the phase divider's strobes, the rate multiplier's next
pulse, and the lazy plant's bound on the cycles that keep its count and its run over them."""

from __future__ import annotations

import ctypes

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from k37.hdl.feed.model.divider import PhaseDividerModel
from k37.hdl.feed.model.rate_multiplier import RateMultiplierModel, gate
from k37.sim.backends.engine.backend import load
from k37.sim.backends.engine.build import build
from k37.sim.machine.plant_model import ALPHA_BITS, FRAC_BITS, VC_MAX, ServoPlantModel, dac_zero


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


#: Cycles of the plant's model stepped at most per case.
STEPPED = 3000


@settings(max_examples=80, deadline=None)
@given(err=st.integers(-32767, 32767), gain=st.integers(0, 1 << 22),
       alpha=st.integers(1, (1 << ALPHA_BITS) - 1),
       velocity=st.one_of(st.integers(-(1 << 24), 1 << 24), st.integers(-VC_MAX, VC_MAX)),
       offset=st.integers(0, (1 << FRAC_BITS) - 1), count=st.integers(-1000, 1000),
       stall=st.booleans())
def test_the_lazy_plants_bound_keeps_the_count_and_its_run_follows_the_model(
        lib, err, gain, alpha, velocity, offset, count, stall):
    plant = ServoPlantModel(gain, alpha, dac_bits=16, velocity=velocity,
                            position=(count << FRAC_BITS) + offset)
    dac = dac_zero(16) + err
    vc = plant.command(dac, 0)
    position = plant.position % (1 << 64)
    clear = lib.k37e_lag_clear(velocity, vc, alpha, position, stall)
    cycles = min(clear, STEPPED)
    for _ in range(cycles):  # the bound: no count change within it
        plant.cycle(dac, stall)
        assert plant.count == count
    v, at = ctypes.c_int64(velocity), ctypes.c_uint64(position)
    lib.k37e_lag_run(ctypes.byref(v), vc, alpha, ctypes.byref(at), stall, cycles)
    assert (v.value, at.value) == (plant.velocity, plant.position % (1 << 64))
