"""The servo plant: gateware equals its fixed-point model; the model obeys the physics."""

import math
import random

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from k37.sim.machine.plant import ServoPlant
from k37.sim.machine.plant_model import (
    ALPHA_BITS,
    FRAC_BITS,
    PlantParams,
    ServoPlantModel,
    dac_zero,
)
from tests.testbench import simulate


def compare_with_model(params: PlantParams, dac_bits: int, stimulus: list[tuple],
                       dut: ServoPlant | None = None,
                       model: ServoPlantModel | None = None, **inputs: int) -> ServoPlantModel:
    """Drive gateware and model with (dac, stall) or (dac, stall, com) per cycle (com: the net
    command pulse), asserting equal outputs each cycle; ``inputs``: more constant ports (the
    model has them as fields)."""
    dut = dut or ServoPlant()
    model = model or ServoPlantModel(params.gain, params.alpha, params.vmax, dac_bits,
                                     params.kf_word, params.update_cycles)

    async def bench(ctx):
        ctx.set(dut.period, params.update_cycles)
        ctx.set(dut.gain, params.gain)
        ctx.set(dut.alpha, params.alpha)
        ctx.set(dut.vmax, params.vmax)
        ctx.set(dut.kf, params.kf_word)
        ctx.set(dut.dac_zero, dac_zero(dac_bits))
        for name, value in inputs.items():
            ctx.set(getattr(dut, name), value)
        for t, (dac, stall, *com) in enumerate(stimulus):
            ctx.set(dut.dac, dac)
            ctx.set(dut.stall, stall)
            pulse = com[0] if com else 0
            ctx.set(dut.com_pos, pulse > 0)
            ctx.set(dut.com_neg, pulse < 0)
            await ctx.tick()
            model.cycle(dac, stall, pulse)
            assert ctx.get(dut.velocity) == model.velocity, t
            assert ctx.get(dut.count) == model.count, t
            a, b = model.quadrature()
            assert (ctx.get(dut.a), ctx.get(dut.b)) == (a, b)
            assert (ctx.get(dut.a_n), ctx.get(dut.b_n)) == (1 - a, 1 - b)

    simulate(dut, bench)
    return model


def drive_stimulus(rng: random.Random, cycles: int = 400) -> list[tuple[int, bool, int]]:
    """A drive's random (dac, stall, com) per cycle for :func:`compare_with_model`: the D/A
    word stepping around mid-scale every 41 cycles, rare stalls, command pulses either way."""
    dac = 2048
    stimulus = []
    for t in range(cycles):
        if t % 41 == 0:
            dac = 2048 + rng.randrange(-300, 300)
        stimulus.append((dac, rng.random() < 0.03, rng.choice((-1, 0, 1))))
    return stimulus


@settings(max_examples=8, deadline=None, derandomize=True)
@given(kp=st.floats(5, 200), tm=st.floats(0, 0.002), vmax=st.sampled_from([None, 2e4, 3e5]),
       dac_bits=st.integers(8, 16), seed=st.integers(0, 2**32))
def test_plant_gateware_equals_model_cycle_by_cycle(kp, tm, vmax, dac_bits, seed):
    rng = random.Random(seed)
    stimulus = []
    dac = 1 << (dac_bits - 1)
    for t in range(400):
        if t % 37 == 0:
            dac = rng.randrange(1 << dac_bits)
        stimulus.append((dac, rng.random() < 0.05))
    compare_with_model(PlantParams(kp=kp, tm=tm, max_speed=vmax), dac_bits, stimulus)


@settings(max_examples=6, deadline=None, derandomize=True)
@given(kf=st.floats(0, 2), tm=st.sampled_from([0.0, 0.0005]), seed=st.integers(0, 2**32))
def test_feedforward_gateware_equals_model_with_command_pulses(kf, tm, seed):
    rng = random.Random(seed)
    stimulus = [(2048 + rng.randrange(-50, 50), False, rng.choice((-1, 0, 0, 1)))
                for _ in range(300)]
    compare_with_model(PlantParams(kp=50.0, tm=tm, kf=kf), 12, stimulus)


@settings(max_examples=8, deadline=None, derandomize=True)
@given(period=st.integers(2, 70), kf=st.sampled_from([0.0, 0.6, 2.0]),
       tm=st.sampled_from([0.0, 0.00003, 0.001]), seed=st.integers(0, 2**32))
def test_plant_with_an_update_period_equals_its_model_cycle_by_cycle(period, kf, tm, seed):
    compare_with_model(PlantParams(kp=60.0, tm=tm, kf=kf, update_cycles=period), 12,
                       drive_stimulus(random.Random(seed), 500))


def test_an_update_period_holds_the_velocity_and_moves_the_position_every_cycle():
    params = PlantParams(kp=30.0, tm=0.002, update_cycles=16)
    model = ServoPlantModel(params.gain, params.alpha, dac_bits=12, period=16)
    velocities, positions = [], []
    for _ in range(64):
        model.cycle(2048 + 400)
        velocities.append(model.velocity)
        positions.append(model.position)
    assert len(set(velocities)) == 4  # updated in cycles 0, 16, 32 and 48 only
    assert all(velocities[t] == velocities[t - 1] for t in range(1, 64) if t % 16)
    assert all(positions[t] - positions[t - 1] == velocities[t] for t in range(1, 64))


@pytest.mark.parametrize("period", [1, 16])
def test_feedforward_adds_kf_times_the_command_pulse_rate_to_the_velocity(period):
    params = PlantParams(kp=30.0, tm=0.002, kf=0.75, update_cycles=period)
    model = ServoPlantModel(params.gain, params.alpha, dac_bits=12, kf=params.kf_word,
                            period=period)
    start = None
    for t in range(60_000):  # a pulse every 4th cycle (250k counts/s) with the D/A at 0 V
        model.cycle(2048, com=int(t % 4 == 0))
        if t == 20_000:
            start = model.position
    speed = (model.position - start) / 40_000 / (1 << FRAC_BITS) * 1e6
    assert speed == pytest.approx(0.75 * 250_000, rel=1e-4)


def test_velocity_lands_exactly_on_the_command_in_gateware_and_model():
    # Tm = 20 cycles: the lag's residue falls below one update's resolution within
    # 30 Tm, and the velocity then equals the command exactly (here 0: the axis stops).
    zero = dac_zero(12)
    stimulus = [(zero + 300, False)] * 600 + [(zero, False)] * 900
    model = compare_with_model(PlantParams(kp=30.0, tm=20e-6), 12, stimulus)
    assert model.velocity == 0


def test_an_axis_at_rest_does_not_creep():
    params = PlantParams(kp=30.0, tm=0.01)
    model = ServoPlantModel(params.gain, params.alpha, dac_bits=12)
    for _ in range(20_000):
        model.cycle(2048 + 500)
    for _ in range(200_000):  # 20 Tm with the D/A at 0 V
        model.cycle(2048)
    assert model.velocity == 0
    rest = model.position
    for _ in range(1_000):
        model.cycle(2048)
    assert model.position == rest


@pytest.mark.parametrize(("period", "tolerance"), [(1, 2e-3), (64, 4e-3)])
def test_velocity_follows_kp_times_error_with_first_order_lag_tm(period, tolerance):
    """Within the update's Euler step: (1 - P dt/Tm)^(Tm/(P dt)) is 1/e within P dt/Tm."""
    params = PlantParams(kp=30.0, tm=0.01, update_cycles=period)
    model = ServoPlantModel(params.gain, params.alpha, dac_bits=12, period=period)
    error = 500
    final = params.kp * error  # counts/s
    speeds = []
    for _ in range(50_000):  # 5 Tm
        model.cycle(2048 + error)
        speeds.append(model.velocity / (1 << FRAC_BITS) * 1e6)
    at_tm = speeds[10_000 - 1]
    assert at_tm / final == pytest.approx(1 - math.exp(-1), abs=tolerance)
    assert speeds[-1] / final == pytest.approx(1 - math.exp(-5), abs=tolerance)


def test_speed_limit_clamps_the_velocity_command():
    params = PlantParams(kp=30.0, tm=0.0, max_speed=10_000.0)
    model = ServoPlantModel(params.gain, params.alpha, params.vmax, dac_bits=16)
    for _ in range(100):
        model.cycle((1 << 15) + 20_000)
    assert model.velocity / (1 << FRAC_BITS) * 1e6 == pytest.approx(10_000, rel=1e-6)


def test_positive_motion_has_a_leading_b():
    model = ServoPlantModel(PlantParams(kp=100.0, tm=0.0).gain, 1 << ALPHA_BITS, dac_bits=12)
    states = []
    for _ in range(20_000):
        model.cycle(2048 + 1000)  # 1e5 counts/s: a count every 10 cycles
        if not states or states[-1] != model.quadrature():
            states.append(model.quadrature())
    assert states[:5] == [(0, 0), (1, 0), (1, 1), (0, 1), (0, 0)]


def test_kv_follows_from_kp_and_the_dac_width():
    assert PlantParams(kp=30.0, tm=0.01).kv(12) == pytest.approx(30 * 2048 / 10)
    with pytest.raises(ValueError, match="kp must be > 0"):
        PlantParams(kp=0, tm=0.01)
