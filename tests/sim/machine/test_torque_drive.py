"""The torque drive (the profile-error paper's velocity loop, inertia and friction): gateware equals
its fixed-point model; the model obeys the physics (the P loop's lag, D's droop, stiction, the
integral removing the droop, a load step)."""

import math
import random

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from k37.sim.machine.plant_model import FRAC_BITS, PlantParams
from k37.sim.machine.torque_drive import TorqueDrive
from k37.sim.machine.torque_drive_model import TorqueDriveModel, TorqueParams
from tests.sim.machine.test_plant import compare_with_model, drive_stimulus

CLOCK = 1e6


def drive_model(plant: PlantParams, torque: TorqueParams, **faults: int) -> TorqueDriveModel:
    return TorqueDriveModel(plant.gain, torque.alpha, plant.vmax, 12, plant.kf_word,
                            beta=torque.beta, ki=torque.ki, fc=torque.fc_word,
                            load=torque.torque_word(torque.load), **faults)


def ports(torque: TorqueParams, **faults: int) -> dict[str, int]:
    return {"alpha": torque.alpha, "beta": torque.beta, "ki": torque.ki, "fc": torque.fc_word,
            "load": torque.torque_word(torque.load), **faults}


@settings(max_examples=8, deadline=None, derandomize=True)
@given(kf=st.floats(0, 1.5), d=st.floats(0, 0.05), ti=st.sampled_from([0.0, 0.002, 0.02]),
       fc=st.floats(0, 0.05), load=st.floats(-0.05, 0.05), seed=st.integers(0, 2**32))
def test_torque_drive_gateware_equals_model_cycle_by_cycle(kf, d, ti, fc, load, seed):
    rng = random.Random(seed)
    plant = PlantParams(kp=80.0, tm=0.0, kf=kf)
    torque = TorqueParams(vg=2.0, d=d, ti=ti, fc=fc, load=load)
    faults = {"load_step": torque.torque_word(0.02), "load_after": 150}
    stimulus = drive_stimulus(rng)
    compare_with_model(plant, 12, stimulus, TorqueDrive(), drive_model(plant, torque, **faults),
                       **ports(torque, **faults))


def speed_after(model: TorqueDriveModel, cycles: int, dac: int) -> float:
    """counts/s after ``cycles`` at D/A code ``dac``."""
    for _ in range(cycles):
        model.cycle(dac)
    return model.velocity / (1 << FRAC_BITS) * CLOCK


def test_p_loop_lags_by_ja_over_kt_vg_and_viscous_friction_droops_by_d_over_vg_kt():
    plant = PlantParams(kp=30.0, tm=0.0)
    torque = TorqueParams(kt=0.5, ja=1e-3, vg=0.2, d=0.025)   # 1/Tm = 100/s, D/(Vg Kt) = 0.25
    model = drive_model(plant, torque)
    command = 30.0 * 500                                        # 500 codes of error
    rate = torque.rate + torque.d / torque.ja                   # the lag with D: 125/s
    at_tau = speed_after(model, round(CLOCK / rate), 2048 + 500)
    final = command / (1 + 0.25)
    assert at_tau / final == pytest.approx(1 - math.exp(-1), abs=2e-3)
    # (alpha and beta carry 24 fraction bits: D/(Vg Kt) is 0.2497 in the fixed point)
    assert speed_after(model, 200_000, 2048 + 500) == pytest.approx(final, rel=5e-4)


def test_integral_term_removes_the_droop():
    plant = PlantParams(kp=30.0, tm=0.0)
    model = drive_model(plant, TorqueParams(d=0.025, ti=0.02))
    assert speed_after(model, 600_000, 2048 + 500) == pytest.approx(15_000, rel=1e-3)


def test_coulomb_friction_holds_a_weak_drive_at_rest_and_slows_a_strong_one():
    plant = PlantParams(kp=30.0, tm=0.0)
    torque = TorqueParams(fc=0.05)          # P loop: Kt Vg = 0.1 N m per rad/s
    model = drive_model(plant, torque)
    weak = 0.04 / 0.1 / (2 * math.pi) * 10_000 / 30   # codes whose torque at rest is 0.04 N m
    assert speed_after(model, 50_000, 2048 + round(weak)) == 0
    strong = drive_model(plant, torque)
    # Steady: Kt Vg (vc - w) = Fc, so the speed falls short by Fc / (Kt Vg) rad/s.
    short = 0.05 / 0.1 * 10_000 / (2 * math.pi)
    assert speed_after(strong, 200_000, 2048 + 500) == pytest.approx(15_000 - short, rel=1e-3)


def test_a_load_step_slows_the_axis_from_its_cycle_on():
    plant = PlantParams(kp=30.0, tm=0.0)
    torque = TorqueParams()
    model = drive_model(plant, torque, load_step=torque.torque_word(0.05), load_after=100_000)
    before = speed_after(model, 100_000, 2048 + 500)
    after = speed_after(model, 100_000, 2048 + 500)
    assert before == pytest.approx(15_000, rel=1e-4)
    # Within the update's rounding: a velocity step of 1/alpha of its resolution (2.3 counts/s).
    assert before - after == pytest.approx(0.05 / 0.1 * 10_000 / (2 * math.pi), abs=2.5)
