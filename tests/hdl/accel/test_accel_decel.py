# amaranth: UnusedElaboratable=no
"""Exponential accel/decel: cycle equality with the model, conservation, tau = 300 ms."""

import math
import random

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from k37.hdl.accel.exponential import AccelDecel
from k37.hdl.accel.model.exponential import AccelDecelModel
from k37.hdl.feed.model.divider import PhaseDividerModel
from k37.hdl.feed.rates import FA_INCREMENT, frequency_of, increment_for
from k37.sim.backends.contract import CLOCK_PERIOD
from tests.testbench import simulate

#: One cycle of stimulus: (positive input pulse, negative input pulse, addition pulse).
Cycle = tuple[int, int, bool]


def run_gateware(dut: AccelDecel, stimulus: list[Cycle]) -> list[tuple]:
    """Per cycle ``(out, x, y, pending, idle)``; ``out`` is net (``out_pos - out_neg``)."""
    seen: list[tuple] = []

    async def bench(ctx):
        for pos, neg, add in stimulus:
            if dut.bidirectional:
                ctx.set(dut.inp_pos, pos)
                ctx.set(dut.inp_neg, neg)
                out = ctx.get(dut.out_pos) - ctx.get(dut.out_neg)
            else:
                ctx.set(dut.inp, pos)
                out = ctx.get(dut.out)
            ctx.set(dut.add, add)
            seen.append((out, ctx.get(dut.x), ctx.get(dut.y), ctx.get(dut.pending),
                         ctx.get(dut.idle)))
            await ctx.tick()

    simulate(dut, bench)
    return seen


def check_against_model(dut: AccelDecel, stimulus: list[Cycle]) -> AccelDecelModel:
    """Run ``stimulus`` on gateware and model; they must agree on every port every cycle.

    Also checks conservation in every cycle: inputs so far = outputs so far + x + pending.
    """
    model = AccelDecelModel(dut.n, dut.counter_width, dut.bidirectional)
    inputs = outputs = 0
    for (pos, neg, add), (out, x, y, pending, idle) in zip(stimulus,
                                                           run_gateware(dut, stimulus),
                                                           strict=True):
        assert (x, y, pending, idle) == (model.x, model.y, model.pending, model.idle)
        assert inputs == outputs + x + pending
        assert out == model.step(pos - neg, add)
        inputs += pos - neg
        outputs += out
    return model


def random_stimulus(rng: random.Random, cycles: int, p_inp: float, p_add: float,
                    bidirectional: bool) -> list[Cycle]:
    """Random bursts: the input rate and direction change now and then."""
    stimulus = []
    rate, negative = p_inp, False
    for _ in range(cycles):
        if rng.random() < 0.01:
            rate = rng.choice((0.0, p_inp / 4, p_inp, 1.0))
            negative = bidirectional and rng.random() < 0.5
        pulse = int(rng.random() < rate)
        pos, neg = (0, pulse) if negative else (pulse, 0)
        if bidirectional and rng.random() < 0.05:
            pos, neg = rng.choice(((1, 1), (0, 1), (1, 0)))     # both at once: net 0
        stimulus.append((pos, neg, rng.random() < p_add))
    return stimulus


def drain(stimulus: list[Cycle], cycles: int, p_add: float, rng: random.Random) -> list[Cycle]:
    return stimulus + [(0, 0, rng.random() < p_add) for _ in range(cycles)]


@settings(derandomize=True, max_examples=10, deadline=None)
@given(st.booleans(), st.sampled_from([(3, 8), (5, 12), (15, 24)]), st.integers(0, 2**32))
def test_gateware_equals_model_cycle_by_cycle_on_random_streams(bidirectional, widths, seed):
    n, counter_width = widths
    rng = random.Random(seed)
    stimulus = random_stimulus(rng, 1500, rng.choice((0.1, 0.5)), rng.choice((0.1, 0.5, 1.0)),
                               bidirectional)
    check_against_model(AccelDecel(n, counter_width, bidirectional), stimulus)


@settings(derandomize=True, max_examples=6, deadline=None)
@given(st.booleans(), st.integers(0, 2**32))
def test_total_output_equals_total_input_after_draining(bidirectional, seed):
    rng = random.Random(seed)
    stimulus = drain(random_stimulus(rng, 800, 0.5, 0.5, bidirectional), 1200, 0.5, rng)
    dut = AccelDecel(n=4, counter_width=10, bidirectional=bidirectional)
    seen = run_gateware(dut, stimulus)
    assert seen[-1][4], "the circuit did not drain"
    assert sum(out for out, *_ in seen) == sum(pos - neg for pos, neg, _ in stimulus)
    assert any(pos for pos, _, _ in stimulus)


@settings(derandomize=True, max_examples=8, deadline=None)
@given(st.booleans(), st.integers(0, 2**32))
def test_no_pulse_lost_or_doubled_when_input_and_carry_coincide(bidirectional, seed):
    rng = random.Random(seed)
    # Build up x, then put an input pulse on every addition while carries are flowing.
    stimulus = [(1, 0, rng.random() < 0.2) for _ in range(60)]
    for _ in range(600):
        add = rng.random() < 0.4
        pos, neg = (1, 0) if add else (int(rng.random() < 0.3), 0)
        if bidirectional and add and rng.random() < 0.3:
            pos, neg = rng.choice(((0, 1), (1, 1)))  # -1 against a carry, or +1 and -1 at once
        stimulus.append((pos, neg, add))
    dut = AccelDecel(n=3, counter_width=8, bidirectional=bidirectional)
    model = check_against_model(dut, stimulus)
    # The stream really forced coincidences: replay the model and count them.
    replay = AccelDecelModel(3, 8, bidirectional)
    coincidences = 0
    for pos, neg, add in stimulus:
        before = replay.pending
        out = replay.step(pos - neg, add)
        coincidences += bool(add and (pos or neg) and replay.pending != before - out)
    assert coincidences > 100
    assert (replay.x, replay.pending) == (model.x, model.pending)


def test_add_to_first_output_pulse_is_one_cycle_and_a_carry_leaves_one_pulse_per_cycle():
    # n = 2: three input pulses give x = 3; the first addition (y = 3) carries nothing, the
    # second (3 + 3 = 6) carries 1; then x = 2 + 10 inputs = 12 and 2 + 12 = 14 carries 3.
    pulse, addition, idle = (1, 0, 0), (0, 0, 1), (0, 0, 0)
    stimulus = [pulse] * 3 + [addition] * 2 + [idle] * 3 + [pulse] * 10 + [addition] + [idle] * 5
    seen = run_gateware(AccelDecel(n=2, counter_width=8), stimulus)
    outs = [t for t, (out, *_) in enumerate(seen) if out]
    assert outs == [5, 19, 20, 21]
    assert seen[-1][1:4] == (12 - 3, 14 % 4, 0)


@settings(derandomize=True, max_examples=20, deadline=None)
@given(st.booleans(), st.integers(1, 15), st.integers(0, 2**32))
def test_model_run_equals_step_on_random_streams(bidirectional, n, seed):
    rng = random.Random(seed)
    stimulus = drain(random_stimulus(rng, 3000, rng.random(), rng.random(), bidirectional),
                     2000, rng.random(), rng)
    inp = np.array([pos - neg for pos, neg, _ in stimulus], dtype=np.int8)
    add = np.array([a for _, _, a in stimulus], dtype=bool)
    stepped = AccelDecelModel(n, 12, bidirectional)
    ran = AccelDecelModel(n, 12, bidirectional)
    expected = [stepped.step(int(i), bool(a)) for i, a in zip(inp, add, strict=True)]
    half = len(inp) // 2                   # two calls: run() must continue where it stopped
    got = np.concatenate((ran.run(inp[:half], add[:half]), ran.run(inp[half:], add[half:])))
    assert got.tolist() == expected
    assert (ran.x, ran.y, ran.pending) == (stepped.x, stepped.y, stepped.pending)


TAU = 2**15 / frequency_of(FA_INCREMENT)


def step_response(fi: float, accel_s: float, total_s: float) -> tuple[np.ndarray, np.ndarray]:
    """The paper's circuit (n = 15, fa from the 24-bit divider) fed fi for accel_s seconds.

    Runs the reference model, proven cycle-equal to the gateware above (3e6 cycles is beyond
    the Amaranth simulator's reach in test time). Returns the input and output pulse trains.
    """
    cycles = round(total_s / CLOCK_PERIOD)
    inp = PhaseDividerModel().run(increment_for(fi), cycles).astype(np.int8)
    inp[round(accel_s / CLOCK_PERIOD):] = 0
    add = PhaseDividerModel().run(FA_INCREMENT, cycles)
    return inp, AccelDecelModel().run(inp, add)


def ideal_pulses(t: float, accel_s: float) -> float:
    """Output pulses by time t per unit fi: the integral of the paper's (16) and (21)."""
    if t <= accel_s:
        return t - TAU * (1 - math.exp(-t / TAU))
    rate_at_stop = 1 - math.exp(-accel_s / TAU)
    return (ideal_pulses(accel_s, accel_s)
            + rate_at_stop * TAU * (1 - math.exp(-(t - accel_s) / TAU)))


def rates(out: np.ndarray, t: float, window_s: float, fi: float, accel_s: float):
    """Measured and ideal output rate, as fractions of fi, averaged over a window centred on t.

    Comparing window averages, not the ideal curve's value at the centre, keeps the window
    from counting as an error where the curve bends sharply (when the input stops).
    """
    half = round(window_s / 2 / CLOCK_PERIOD)
    centre = round(t / CLOCK_PERIOD)
    span = 2 * half * CLOCK_PERIOD
    measured = int(out[centre - half:centre + half].sum()) / span / fi
    lo, hi = (centre - half) * CLOCK_PERIOD, (centre + half) * CLOCK_PERIOD
    return measured, (ideal_pulses(hi, accel_s) - ideal_pulses(lo, accel_s)) / span


@pytest.mark.slow
@pytest.mark.parametrize(("fi", "window_s"), [(500e3, 2e-3), (20e3, 20e-3)])
def test_output_rate_follows_1_minus_exp_with_tau_300_ms(fi, window_s):
    accel_s, total_s = 5 * 0.3, 10 * 0.3
    inp, out = step_response(fi, accel_s, total_s)
    assert abs(TAU - 0.3) < 1e-6
    at_tau, _ = rates(out, 0.3, window_s, fi, accel_s)
    assert abs(at_tau - (1 - math.exp(-1))) < 0.01
    # The whole curve, acceleration and deceleration, window by window.
    centres = np.arange(window_s, total_s - window_s / 2, window_s)
    deviation = max(abs(measured - ideal)
                    for measured, ideal in (rates(out, t, window_s, fi, accel_s)
                                            for t in centres))
    assert deviation < 0.01, f"largest deviation {deviation:.4f} of full scale"
    # 5 tau after the input stops, under 1% of the steady-state count is still in flight.
    assert 0 <= int(inp.sum()) - int(out.sum()) < 0.01 * fi * TAU


def test_bad_parameters_are_refused_by_name():
    with pytest.raises(ValueError, match="n must be at least 1, not 0"):
        AccelDecel(n=0)
    with pytest.raises(ValueError, match="counter_width must be at least 2, not 1"):
        AccelDecel(counter_width=1)
    with pytest.raises(TypeError, match="bidirectional must be a bool, not 1"):
        AccelDecel(bidirectional=1)
    with pytest.raises(ValueError, match=r"inp must be one of \(0, 1\), not -1"):
        AccelDecelModel().step(-1, True)
