# amaranth: UnusedElaboratable=no
"""Linear and bell accel/decel: cycle equality with the models, conservation, coincidence,
and the shapes' step responses (a ramp over T; an S curve)."""

import random

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from k37.hdl.accel.bell import AccelBell
from k37.hdl.accel.linear import AccelLinear
from k37.hdl.accel.model.bell import AccelBellModel
from k37.hdl.accel.model.linear import AccelLinearModel
from tests.hdl.accel.test_accel_decel import drain, random_stimulus, run_gateware

SHAPES = {"linear": (AccelLinear, AccelLinearModel), "bell": (AccelBell, AccelBellModel)}


def check_against_model(shape: str, stimulus, **params) -> list[tuple]:
    """Gateware and model agree on the output and idle every cycle (and on x, y, pending,
    which both shapes expose); conservation holds at the end of a drain."""
    gateware, model_class = SHAPES[shape]
    dut = gateware(**params)
    model = model_class(**params)
    probe = model.exponential if shape == "bell" else model
    seen = run_gateware(dut, stimulus)
    for (pos, neg, add), (out, x, y, pending, idle) in zip(stimulus, seen, strict=True):
        assert (x, y, pending, idle) == (probe.x, probe.y, probe.pending, model.idle)
        assert out == model.step(pos - neg, add)
    return seen


@settings(derandomize=True, max_examples=8, deadline=None)
@given(st.sampled_from(sorted(SHAPES)), st.booleans(),
       st.sampled_from([(3, 0), (4, 2), (5, 3), (6, 4)]), st.integers(0, 2**32))
def test_gateware_equals_model_cycle_by_cycle_on_random_streams(shape, bidirectional, bits,
                                                                 seed):
    n, bins_bits = bits
    rng = random.Random(seed)
    stimulus = random_stimulus(rng, 1200, rng.choice((0.1, 0.5)), rng.choice((0.2, 0.5, 1.0)),
                               bidirectional)
    check_against_model(shape, stimulus, n=n, counter_width=12, bidirectional=bidirectional,
                        bins_bits=bins_bits)


@settings(derandomize=True, max_examples=8, deadline=None)
@given(st.sampled_from(sorted(SHAPES)), st.booleans(), st.integers(0, 2**32))
def test_total_output_equals_total_input_after_draining(shape, bidirectional, seed):
    rng = random.Random(seed)
    stimulus = drain(random_stimulus(rng, 600, 0.5, 0.5, bidirectional), 1500, 0.5, rng)
    seen = check_against_model(shape, stimulus, n=4, counter_width=10,
                               bidirectional=bidirectional, bins_bits=2)
    assert seen[-1][4], "the circuit did not drain"
    assert sum(out for out, *_ in seen) == sum(pos - neg for pos, neg, _ in stimulus)
    assert any(pos for pos, _, _ in stimulus)


@settings(derandomize=True, max_examples=6, deadline=None)
@given(st.sampled_from(sorted(SHAPES)), st.booleans(), st.integers(0, 2**32))
def test_no_pulse_lost_or_doubled_when_input_output_and_bin_close_coincide(shape, bidirectional,
                                                                            seed):
    # An input pulse on every addition (so on every bin close) while output pulses flow.
    rng = random.Random(seed)
    stimulus = [(1, 0, rng.random() < 0.3) for _ in range(40)]
    for _ in range(500):
        add = rng.random() < 0.5
        pos, neg = (1, 0) if add else (int(rng.random() < 0.3), 0)
        if bidirectional and add and rng.random() < 0.3:
            pos, neg = rng.choice(((0, 1), (1, 1)))
        stimulus.append((pos, neg, add))
    stimulus = drain(stimulus, 600, 1.0, rng)
    seen = check_against_model(shape, stimulus, n=3, counter_width=10,
                               bidirectional=bidirectional, bins_bits=1)
    outs = [out for out, *_ in seen]
    assert sum(outs) == sum(pos - neg for pos, neg, _ in stimulus)
    assert sum(1 for (pos, neg, add), out in zip(stimulus, outs, strict=True)
               if add and (pos or neg) and out) > 50


def test_linear_step_response_is_a_ramp_over_t_then_the_input_rate():
    # n = 8 (T = 256 additions, add every cycle), 16 bins of 16: input every 2nd cycle.
    model = AccelLinearModel(n=8, counter_width=16, bins_bits=4)
    out = np.array([model.step(int(t % 2 == 0), True) for t in range(2000)])
    rate = np.convolve(out, np.ones(64) / 64, mode="valid")  # rate over 64-cycle windows
    # Before a full window has passed the rate rises linearly (a ramp from 0 to 1/2 over
    # T = 256 cycles, one bin = 16 cycles late); after it, exactly the input's 1/2.
    assert abs(rate[128 - 32 + 16] - 0.25) < 0.03
    assert np.all(np.abs(rate[256 + 32:] - 0.5) < 1 / 64 + 1e-9)
    assert model.x == 128


def test_bell_step_response_is_s_shaped_and_slower_than_linear():
    bell, linear = AccelBellModel(n=7, counter_width=16, bins_bits=3), AccelLinearModel(
        n=7, counter_width=16, bins_bits=3)
    b = np.cumsum([bell.step(1, True) for _ in range(1500)])
    lin = np.cumsum([linear.step(1, True) for _ in range(1500)])
    # The bell lags the linear circuit by the exponential's tau (128 cycles) once both are
    # at full rate, and starts more gently (its acceleration rises from 0).
    assert abs((lin[-1] - b[-1]) - 128) <= 3
    assert b[100] < lin[100]


def test_bad_bins_are_refused_by_name():
    with pytest.raises(ValueError, match="bins_bits must be at most n = 3, not 4"):
        AccelLinear(n=3, bins_bits=4)
    with pytest.raises(ValueError, match="bins_bits must be at least 0, not -1"):
        AccelBell(n=3, bins_bits=-1)
