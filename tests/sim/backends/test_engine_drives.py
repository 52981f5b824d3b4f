"""The engine's torque and two-mass drives equal the compiled RTL's, and what the engine probes.

Whole jobs run on ``--backend engine`` and ``--backend cxxrtl`` (the reports, every block's
cycles among them, and every sample must be equal): hypothesis-drawn short programs on
machines with the torque or the two-mass drive on every axis and random drive values (the
velocity loop's integral, viscous and Coulomb friction, a load, a spring's damping, a linear
scale, a load step), and the lockstep checker over a two-mass run with a load step. The
internal signals the engine probes read as the RTL's, cycle for cycle.
"""

from __future__ import annotations

from dataclasses import replace

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from k37.firmware_model.host import Host8085
from k37.firmware_model.job import MachineConfig
from k37.hdl.k3701.block import Block
from k37.sim.backends.engine.backend import PROBES
from k37.sim.backends.factory import choose_backend
from k37.sim.link.simulated import SimulatedLink
from k37.sim.machine.servo import load_step_fault
from k37.sim.reproduce.workers import start_at_full_feed
from k37.sim.run.runner import RunOptions, build_backend, configure_plants, run_job, system_params
from tests.sim.backends.test_engine import same_on_engine_and_rtl

#: The torque drive with every term (a 1 ms velocity loop, so that any Kp is stable).
TORQUE = {"drive": "torque", "vg": 2.0, "kf": 0.6, "ti": 0.01, "d": 0.02, "fc": 0.002,
          "load": 0.001}

drive_values = st.fixed_dictionaries({
    "drive": st.sampled_from(["torque", "two_mass"]),
    "vg": st.floats(1.0, 3.0), "kf": st.floats(0.0, 1.0),
    "ti": st.sampled_from([0.0, 0.005, 0.02]), "d": st.floats(0.0, 0.05),
    "fc": st.floats(0.0, 0.003), "load": st.floats(-0.002, 0.002),
    "cs": st.floats(0.0, 3000.0), "scale": st.booleans()})


def drive_job(seed: int, accel: str, servo: dict, random_moves, *, axes: int = 2):
    """A random short job with ``servo`` on every axis, on a machine of ``accel`` with 8-bit
    circuits (so that few RTL models serve every draw)."""
    job, faults, _ = random_moves(seed, accel, dwell=True, axes=axes, servo=servo)
    return replace(job, machine=replace(job.machine, accel_bits=8)), faults


@settings(max_examples=10, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(seed=st.integers(0, 10**6), accel=st.sampled_from(["pre", "post"]), servo=drive_values,
       step=st.one_of(st.none(), st.tuples(st.floats(0.0005, 0.004), st.sampled_from([1, -1]),
                                           st.floats(0.0, 0.2))))
def test_engine_equals_the_rtl_on_generated_jobs_with_torque_and_two_mass_drives(
        seed, accel, servo, step, random_moves):
    if servo["drive"] == "torque":
        servo = {k: v for k, v in servo.items() if k not in ("cs", "scale")}
    job, faults = drive_job(seed, accel, servo, random_moves)
    if step is not None:
        torque, sign, at_s = step
        faults.setdefault("x", {}).update(load_step_fault(job, "x", sign * torque, at_s))
    assert choose_backend("auto", system_params(job))[0] == "engine"
    report = same_on_engine_and_rtl(job, faults, sample_every=97)
    assert report["blocks"] or report["status"] != "ok"


@pytest.mark.parametrize("drive", ["torque", "two_mass"])
def test_engine_equals_the_rtl_on_a_three_axis_job_with_each_drive(drive, random_moves):
    job, faults = drive_job(5, "pre", {**TORQUE, "drive": drive}, random_moves, axes=3)
    same_on_engine_and_rtl(job, faults, sample_every=97)


def test_engine_without_skipping_equals_the_rtl_without_skipping(random_moves):
    """``--no-skip-idle``: every cycle evaluated on both, none skipped."""
    job, faults = drive_job(3, "post", {**TORQUE, "drive": "two_mass", "cs": 2000.0},
                            random_moves)
    report = same_on_engine_and_rtl(job, faults, sample_every=97, skip_idle=False,
                                    max_cycles=300_000)
    assert report["skipped_cycles"] == 0


def test_lockstep_runs_a_two_mass_job_with_a_load_step_without_a_difference(random_moves):
    job, faults = drive_job(11, "post", {**TORQUE, "drive": "two_mass", "cs": 2000.0},
                            random_moves)
    faults.setdefault("y", {}).update(load_step_fault(job, "y", 0.003, 0.02))
    report = run_job(job, RunOptions(backend="lockstep", faults=faults)).report
    assert report["backend"] == "lockstep" and report["status"] == "ok"


@pytest.mark.parametrize(("accel", "block"), [("pre", Block.line(300, 120)),
                                               ("post", Block.arc(0, 0, -40, 0))])
def test_engine_probes_read_as_the_rtls_signals_through_a_block(accel, block, make_job):
    """The K3701's busy and overrun, and the accel/decel circuit's idle before the K3701 (the
    signals the reproduction reads), through a block run at the top feed rate (FP offered
    every cycle: overruns) and its drain, compared every 7 cycles."""
    job = make_job("M30", MachineConfig(accel=accel, accel_bits=8))
    engine, rtl = build_backend(job, "engine"), build_backend(job, "cxxrtl")
    names = engine.probe_names()
    assert names == [p for p in PROBES if accel == "pre" or p != "chipset.accel.idle"]
    for backend in (engine, rtl):
        configure_plants(backend, job)
        start_at_full_feed(Host8085(SimulatedLink(backend)), block)
    seen = set()
    for _ in range(4000):
        values = [engine.probe(name) for name in names]
        assert values == [rtl.probe(name) for name in names]
        seen.add(tuple(values))
        engine.step(7)
        rtl.step(7)
    assert len(seen) > 2
