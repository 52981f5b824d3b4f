"""The two-mass feed drive (motor, ball screw spring, table): gateware equals its fixed-point
model cycle by cycle; the model rings at the natural frequencies of the profile-error paper's
eqs. (1)-(3) and deflects by the load over the stiffness."""

import math
import random
from dataclasses import replace

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from k37.sim.machine.plant_model import FRAC_BITS, PlantParams
from k37.sim.machine.two_mass import TwoMassDrive
from k37.sim.machine.two_mass_model import TwoMassDriveModel, TwoMassParams
from k37.sim.reproduce.resonance import ring_hz, table1_drive
from tests.sim.machine.test_plant import compare_with_model, drive_stimulus

#: A stiff, light drive whose spring rings within a short simulation (about 200 cycles).
FAST = {"kt": 0.5, "ja": 1e-5, "vg": 2.0, "mass": 1.0, "ks": 1e9, "lead": 0.01}


def drive_model(plant: PlantParams, drive: TwoMassParams, **faults: int) -> TwoMassDriveModel:
    return TwoMassDriveModel(plant.gain, vmax=plant.vmax, dac_bits=12, kf=plant.kf_word,
                             **drive.ports(), **faults)


def ports(drive: TwoMassParams, **faults: int) -> dict[str, int]:
    return {**drive.ports(), **faults}


def run_both(plant: PlantParams, drive: TwoMassParams, stimulus: list[tuple], **faults: int):
    compare_with_model(plant, 12, stimulus, TwoMassDrive(), drive_model(plant, drive, **faults),
                       **ports(drive, **faults))


@settings(max_examples=8, deadline=None, derandomize=True)
@given(kf=st.floats(0, 1.5), d=st.floats(0, 1e-4), ti=st.sampled_from([0.0, 0.002]),
       fc=st.floats(0, 2e-3), load=st.floats(-2e-3, 2e-3), cs=st.floats(0, 500.0),
       scale=st.booleans(), seed=st.integers(0, 2**32))
def test_two_mass_gateware_equals_model_cycle_by_cycle(kf, d, ti, fc, load, cs, scale, seed):
    rng = random.Random(seed)
    plant = PlantParams(kp=80.0, tm=0.0, kf=kf)
    drive = TwoMassParams(**FAST, d=d, ti=ti, fc=fc, load=load, cs=cs, scale=scale)
    faults = {"load_step": drive.disturbance_word(1e-3), "load_after": 150}
    stimulus = drive_stimulus(rng)
    run_both(plant, drive, stimulus, **faults)


@pytest.mark.parametrize("scale", [False, True])
def test_two_mass_gateware_equals_model_through_an_undamped_ring_and_a_stall(scale):
    """A D/A step sets the spring ringing with no damping; a stall then stops both masses
    with the spring still deflected, and the release lets it ring again."""
    plant = PlantParams(kp=80.0, tm=0.0)
    drive = TwoMassParams(**FAST, scale=scale)
    stimulus = [(2048 + 400, False)] * 300 + [(2048, True)] * 20 + [(2048, False)] * 300
    run_both(plant, drive, stimulus)


def test_free_two_mass_rings_at_sqrt_ks_over_reduced_mass_within_2_percent():
    drive = table1_drive("x")                        # a 1/s velocity loop: the motor side free
    expected = math.sqrt(drive.ks / drive.reduced_mass) / (2 * math.pi)
    assert expected == pytest.approx(drive.free_hz)
    assert abs(ring_hz(drive) / expected - 1) < 0.02


def test_two_mass_with_the_motor_held_rings_at_sqrt_ks_over_m_within_2_percent():
    drive = table1_drive("x", held=True)             # a 5 us velocity loop: the motor held
    assert abs(ring_hz(drive) / math.sqrt(drive.ks / drive.mass) * 2 * math.pi - 1) < 0.02


def table1_model(**overrides) -> TwoMassDriveModel:
    return drive_model(PlantParams(kp=30.0, tm=0.0), replace(table1_drive("x"), **overrides))


def test_undamped_spring_keeps_its_amplitude_and_damping_decays_it():
    peaks = {}
    for name, model in (("free", table1_model()), ("damped", table1_model(cs=2e4))):
        model.alpha = 0
        model.deflection = 1000 << FRAC_BITS
        trace = []
        for _ in range(60_000):
            model.cycle(2048)
            trace.append(abs(model.deflection))
        peaks[name] = max(trace[-10_000:]) / (1000 << FRAC_BITS)
    assert peaks["free"] == pytest.approx(1.0, abs=0.01)
    assert peaks["damped"] < 0.5


def test_load_on_the_table_deflects_the_screw_by_force_over_stiffness():
    drive = replace(table1_drive("x", held=True), cs=2e4, load=2.0)
    model = drive_model(PlantParams(kp=30.0, tm=0.0), drive)
    for _ in range(200_000):
        model.cycle(2048)
    force = drive.load / drive.radius                    # N along the feed
    counts = force / drive.ks * drive.counts_per_rev / drive.lead
    assert model.deflection / (1 << FRAC_BITS) == pytest.approx(counts, rel=0.01)


def test_scale_reads_the_table_and_the_motor_encoder_the_motor():
    for scale in (0, 1):
        model = table1_model(scale=bool(scale))
        model.deflection = 500 << FRAC_BITS
        assert model.count == (-500 if scale else 0)


@pytest.mark.parametrize(("key", "value", "message"), [
    ("mass", 0.0, "mass must be"), ("ks", 1e15, "natural frequency"),
    ("lead", -1.0, "lead must be")])
def test_two_mass_parameters_out_of_range_are_refused_by_name(key, value, message):
    with pytest.raises(ValueError, match=message):
        TwoMassParams(**{**FAST, key: value})
