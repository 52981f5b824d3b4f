"""The lockstep checker finds no difference between the engine and the compiled RTL on the
jobs of the machine's options, the examples, the reproduction and the conformance corpus.

Every job runs on :class:`k37.sim.backends.engine.lockstep.LockstepBackend`: after each call
of the run (each step, wait, bus access) every output port and the cycle count of the engine
are compared with the compiled RTL's, and the first differing cycle raises
:class:`~k37.sim.backends.engine.lockstep.DivergenceError` naming the port. The jobs are
hypothesis-drawn: short programs (lines, arcs, helices, dwells, parabolas and exponentials,
faults and load steps) over the placements of the accel/decel circuit, the drives, the
contour controllers and two and three axes, and blocks of every kind started into a running
feed; then every shape of the circuit and per-axis addition clocks, every example, the
reproduction's runs of distinct machines (each placement and shape, the drives, the
controllers, the FP-budget hazard) and its step-rate blocks, and every program of the
conformance corpus. Each machine's pair of backends is built once per module (the machines
are the ones the other backend tests build, so their models come from the cache) and reset
between jobs. Long runs are cut off at a cycle limit each test names.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import replace
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from k37.firmware_model.host import Host8085
from k37.firmware_model.job import CONTOUR_CONTROLLERS, ContourConfig, Job, MachineConfig
from k37.hdl.feed.map.decel_control import DECEL_MAP
from k37.hdl.feed.map.feed_rate import FEED_MAP
from k37.hdl.k3701.block import Block
from k37.hdl.k3701.map import block_registers
from k37.sim.backends.contract import Backend
from k37.sim.backends.engine.lockstep import LockstepBackend
from k37.sim.link.simulated import SimulatedLink
from k37.sim.machine.servo import load_step_fault
from k37.sim.reproduce.experiments import all_specs
from k37.sim.reproduce.runs import QUICK, RateSpec, RunSpec
from k37.sim.reproduce.workers import max_rates
from k37.sim.run.jobfile import load_job
from k37.sim.run.runner import RunOptions, build_backend, configure_plants, design_key, run_job
from tests.hdl.k3701.test_k3701_exponential import exponentials
from tests.hdl.k3701.test_k3701_parabolic import parabolas
from tests.paths import ROOT
from tests.sim.backends.test_engine import EXAMPLE_FAULTS
from tests.sim.backends.test_engine_drives import TORQUE

Pairs = Callable[[Job], Backend]


@pytest.fixture(scope="module")
def lockstep() -> Iterator[Pairs]:
    """``lockstep(job)``: the engine and the compiled RTL of ``job``'s machine in lockstep,
    built once per machine in this module and reset for each later job."""
    built: dict[str, LockstepBackend] = {}

    def pair(job: Job) -> Backend:
        key = design_key(job)
        if key in built:
            built[key].reset()
        else:
            built[key] = LockstepBackend(build_backend(job, "engine"),
                                         build_backend(job, "cxxrtl"))
        return built[key]

    yield pair
    for backend in built.values():
        backend.close()


def run_in_lockstep(job: Job, lockstep: Pairs, faults: dict | None = None,
                    **options) -> dict:
    """``job`` run to its end or ``max_cycles`` in lockstep; its report."""
    backend = lockstep(job)
    report = run_job(job, RunOptions(faults=faults or {}, **options), backend).report
    assert report["cycles"] > 0
    return report


#: The machines the hypothesis draws run on, by placement of the accel/decel circuit: the
#: drives each has (8-bit circuits; without a circuit, the first-order plant only).
DRIVES = {"pre": ("first_order", "torque", "two_mass"),
          "post": ("first_order", "torque", "two_mass"), "none": ("first_order",)}


#: The servo keys of the torque and two-mass drives (with every term).
SERVOS = {"torque": TORQUE, "two_mass": {**TORQUE, "drive": "two_mass", "cs": 2000.0}}


@st.composite
def machine_options(draw) -> dict:
    accel = draw(st.sampled_from(sorted(DRIVES)))
    return {"accel": accel, "drive": draw(st.sampled_from(DRIVES[accel])),
            "controller": draw(st.sampled_from(CONTOUR_CONTROLLERS)),
            "update_cycles": draw(st.sampled_from(UPDATE_CYCLES))}


#: The first-order plant's update periods the hypothesis draws from.
UPDATE_CYCLES = (1, 16, 64)


def servo_keys(drive: str, update_cycles: int) -> dict:
    """The servo keys of ``drive``: the torque and two-mass drives', or the first-order
    plant's update period."""
    return SERVOS.get(drive) or {"update_cycles": update_cycles}


@settings(max_examples=30, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(seed=st.integers(0, 10**6), options=machine_options(), dwell=st.booleans(),
       curves=st.booleans(), load_step=st.booleans())
def test_lockstep_finds_no_difference_on_generated_jobs_over_the_machine_options(
        seed, options, dwell, curves, load_step, random_moves, lockstep):
    """Two-axis jobs, each cut off after 1,500,000 cycles."""
    drive = options["drive"]
    job, faults, _ = random_moves(seed, options["accel"], dwell=dwell, curves=curves,
                                  servo=servo_keys(drive, options["update_cycles"]))
    job = replace(job, machine=replace(job.machine, accel_bits=8),
                  contour=ContourConfig(controller=options["controller"]))
    if load_step and drive != "first_order":
        faults.setdefault("y", {}).update(load_step_fault(job, "y", 0.002, 0.01))
    run_in_lockstep(job, lockstep, faults, max_cycles=1_500_000)


@settings(max_examples=10, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(seed=st.integers(0, 10**6), drive=st.sampled_from(DRIVES["pre"]), dwell=st.booleans(),
       curves=st.booleans(), update_cycles=st.sampled_from(UPDATE_CYCLES))
def test_lockstep_finds_no_difference_on_generated_three_axis_jobs(
        seed, drive, dwell, curves, update_cycles, random_moves, lockstep):
    """Lines through space, arcs in every plane, helices; each cut off after 1,500,000
    cycles."""
    job, faults, _ = random_moves(seed, "pre", dwell=dwell, curves=curves, axes=3,
                                  servo=servo_keys(drive, update_cycles))
    bits = 15 if drive == "first_order" else 8
    job = replace(job, machine=replace(job.machine, accel_bits=bits))
    run_in_lockstep(job, lockstep, faults, max_cycles=1_500_000)


def test_lockstep_finds_no_difference_without_skipping_idle_cycles(lockstep):
    """``--no-skip-idle``: every cycle evaluated on both; the first 500,000 cycles."""
    report = run_in_lockstep(load_job(ROOT / "examples" / "square.toml"), lockstep,
                             skip_idle=False, max_cycles=500_000)
    assert report["skipped_cycles"] == 0


@pytest.mark.parametrize(("accel", "shape", "axis_shapes", "axis_fa", "seed"), [
    ("pre", "bell", None, (), 1), ("pre", "linear", None, (), 5),
    ("post", "linear", {"y": "bell"}, (), 3),
    ("post", "exponential", {"y": "linear"}, ("x", "y"), 7)])
def test_lockstep_finds_no_difference_with_every_circuit_and_addition_clock(
        accel, shape, axis_shapes, axis_fa, seed, random_moves, lockstep):
    job, faults, _ = random_moves(seed, accel, dwell=True, shape=shape, axis_shapes=axis_shapes,
                                  axis_fa=axis_fa)
    run_in_lockstep(job, lockstep, faults)


@pytest.mark.parametrize(("update_cycles", "kf", "seed"), [(1, 0.8, 14), (2, 0.0, 11),
                                                           (37, 0.8, 12), (256, 0.0, 13)])
def test_lockstep_finds_no_difference_with_a_plant_update_period(update_cycles, kf, seed,
                                                                 random_moves, lockstep):
    """The velocity held between updates, the feedforward summed over them."""
    job, faults, _ = random_moves(seed, "post", dwell=True,
                                  servo={"update_cycles": update_cycles, "kf": kf})
    run_in_lockstep(job, lockstep, faults)


lines = st.builds(Block.line, st.integers(-300, 300), st.integers(-300, 300),
                  sqrt2=st.booleans())
arcs = st.builds(lambda r, cw, sqrt2: Block.arc(0, 0, -r, 0, cw=cw, sqrt2=sqrt2),
                 st.integers(5, 200), st.booleans(), st.booleans())


@settings(max_examples=16, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(block=st.one_of(lines, arcs, parabolas(span=30), exponentials(span=30)),
       accel=st.sampled_from(sorted(DRIVES)), feed=st.integers(1 << 14, (1 << 18) - 1))
def test_lockstep_finds_no_difference_on_blocks_started_into_a_running_feed(
        block, accel, feed, make_job, lockstep):
    """The feed path opened before the block starts, so that FP arrives from the block's
    first cycle: each step as early as the K3701's setup and latency allow (a run's blocks
    start before their feed, which hides the setup). 20,000 cycles compared every 7."""
    job = make_job("M30", MachineConfig(accel=accel, accel_bits=8))
    pair = lockstep(job)
    configure_plants(pair, job)
    host = Host8085(SimulatedLink(pair))
    host.command("K3701", ack=1, clear=1)
    for register in ("RM_INC", "FA_INC"):
        host.write("FEED", register, FEED_MAP[register].bounds[1])
    host.write("FEED", "FEED", feed)
    host.write("DECEL", "BUDGET", DECEL_MAP["BUDGET"].bounds[1])
    for register, value in block_registers(block).items():
        host.write("K3701", register, value)
    host.command("K3701", start=1)
    for _ in range(20_000 // 7):
        pair.step(7)


@pytest.mark.parametrize(("example", "faults"), EXAMPLE_FAULTS)
def test_lockstep_finds_no_difference_on_every_example(example, faults, lockstep):
    run_in_lockstep(load_job(ROOT / "examples" / example), lockstep, faults)


#: The reproduction's runs of distinct machines and controllers, and the cycles each is cut
#: off after: the circuit before the K3701 (a line, a parabola, the FP budget one too high),
#: after it (exponential, linear), none (a parabola under each contour controller, a Bezier
#: curve cut into chords), the two-mass drive, the torque drive with an axis on its own
#: addition clock. The controllers' runs are cut shorter (150 of their samples): their hosts'
#: controllers cost about 30 ms of Python per simulated millisecond on any backend.
REPRODUCED = {"line": 3_000_000, "parabola": 3_000_000, "hazard_plus": 3_000_000,
              "post_high": 3_000_000, "s000_corner_linear_15ms": 3_000_000,
              "s000_resonant_exponential_15ms": 3_000_000, "s002_parabola": 3_000_000,
              "s002_parabola_vgccc": 150_000, "s002_parabola_cec": 150_000,
              "s002_bezier_cec": 150_000, "s003_ts_unequal": 3_000_000}


@pytest.mark.parametrize(("key", "cycles"), REPRODUCED.items())
def test_lockstep_finds_no_difference_on_the_quick_reproductions_runs(key, cycles, lockstep):
    """Each run of ``k37 reproduce --quick`` cut off after the cycles :data:`REPRODUCED`
    gives it."""
    spec = all_specs(QUICK)[key]
    assert isinstance(spec, RunSpec)
    run_in_lockstep(spec.job(), lockstep, sample_every=spec.sample_every,
                    max_cycles=min(spec.max_cycles, cycles),
                    budget_offset=spec.budget_offset)


def test_lockstep_finds_no_difference_on_the_quick_reproductions_step_rates(lockstep):
    """A line and a circle with FP offered every cycle: a step every K3701 latency."""
    spec = all_specs(QUICK)["rates"]
    assert isinstance(spec, RateSpec)
    data = max_rates(spec, lockstep)
    assert data.report["backend"] == "lockstep"
    assert data.probes["linear_steps"] == data.probes["circular_steps"] == QUICK.rate_steps


CORPUS = sorted(path for path in (ROOT / "tests" / "gcode_corpus").iterdir() if path.is_file())


@pytest.mark.parametrize("program", CORPUS, ids=lambda path: path.name)
def test_lockstep_finds_no_difference_on_the_conformance_corpus(program: Path, lockstep):
    """The first 20,000,000 cycles (20 s of machine time: three to ten blocks) of each
    program."""
    run_in_lockstep(load_job(program), lockstep, max_cycles=20_000_000)
