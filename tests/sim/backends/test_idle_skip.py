"""Exact idle skipping on the compiled backend: a skipped run equals the stepped run.

While the machine stands still (a dwell, the host busy, the axes at rest) only the feed-rate
generator's dividers and rate multiplier, and the accel/decel accumulators between their
carries, run on (``k37.sim.machine.system.free_running``); the compiled backend then skips ahead and
advances them in closed form. Every signal of the design must end up as if each cycle had
been evaluated.
"""

from __future__ import annotations

import numpy as np
import pytest
from amaranth.hdl import Module, Mux
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out
from hypothesis import given, settings
from hypothesis import strategies as st

from k37.firmware_model.job import Job, MachineConfig, ServoConfig
from k37.hdl.k3701.block import Block
from k37.hdl.k3701.chip import K3701
from k37.hdl.k3701.map import K3701_MAP, block_registers
from k37.sim.backends.cxxrtl.backend import CxxrtlBackend
from k37.sim.machine.plant import ServoPlant
from k37.sim.machine.plant_model import ALPHA_BITS, COUNT_BITS, GAIN_BITS
from k37.sim.run.report import HOW_FIELDS
from k37.sim.run.runner import RunOptions, build_backend, run_job


def run(job: Job, faults: dict, kind: str, skip: bool, sample_every: int,
        max_cycles: int = 10**9):
    """The run's report without the how-fields, its samples, and every signal at the end."""
    backend = build_backend(job, kind)
    result = run_job(job, RunOptions(sample_every=sample_every, faults=faults, skip_idle=skip,
                                     max_cycles=max_cycles), backend)
    signals = {name: backend.probe(name) for name in backend.probe_names()}
    skipped = backend.skipped_cycles
    backend.close()
    report = {k: v for k, v in result.report.items() if k not in HOW_FIELDS}
    return report, result.samples, signals, skipped


def skipped_equals_stepped(job: Job, faults: dict, sample_every: int,
                           max_cycles: int = 10**9) -> tuple[tuple, tuple]:
    """Run ``job`` on the compiled backend stepped and skipping, assert the same report,
    samples and every signal at the end (free-running ones too), and return both runs."""
    stepped = run(job, faults, "cxxrtl", False, sample_every, max_cycles)
    skipped = run(job, faults, "cxxrtl", True, sample_every, max_cycles)
    assert stepped[3] == 0
    assert skipped[0] == stepped[0]
    assert np.array_equal(skipped[1], stepped[1])
    assert skipped[2] == stepped[2]
    return stepped, skipped


@pytest.mark.parametrize("accel", ["pre", "post", "none"])
@pytest.mark.parametrize(("seed", "sample_every"),
                         [pytest.param(1, 97, marks=pytest.mark.slow), (2, 10_007)])
def test_skipping_idle_cycles_changes_no_signal_of_the_machine(accel, seed, sample_every,
                                                              random_moves):
    job, faults, dwell = random_moves(seed * 10 + len(accel), accel, dwell=True)
    _, skipped = skipped_equals_stepped(job, faults, sample_every)
    # Most of the dwells (the axes settle first) and the waits for the host are skipped.
    assert skipped[3] > 0.5 * dwell * job.machine.clock_hz


@pytest.mark.parametrize(("accel", "shape", "axis_shapes", "servo"), [
    ("post", "exponential", {"x": "linear", "y": "bell"}, {"kf": 0.7}),
    pytest.param("pre", "exponential", None, {"drive": "torque", "vg": 2.0, "kf": 0.6,
                                              "d": 0.02, "fc": 0.002},
                 marks=pytest.mark.slow),
    pytest.param("pre", "linear", None, None, marks=pytest.mark.slow),
    pytest.param("pre", "bell", None, None, marks=pytest.mark.slow)])
def test_skipping_with_new_circuits_feedforward_and_torque_drive_changes_no_signal(
        accel, shape, axis_shapes, servo, random_moves):
    # A linear or bell circuit is quiet only when drained (its bin timer runs while it holds
    # pulses), and the torque drive is stepped while it moves (Coulomb friction brings it to
    # rest exactly): the skips come in the dwells.
    job, faults, dwell = random_moves(3, accel, dwell=True, shape=shape,
                                      axis_shapes=axis_shapes, servo=servo)
    _, skipped = skipped_equals_stepped(job, faults, 1009)
    assert skipped[3] > 0.5 * dwell * job.machine.clock_hz


@pytest.mark.parametrize("scale", [False, True])
def test_skipping_with_the_two_mass_drive_changes_no_signal(scale, random_moves):
    # The two-mass drive is stepped while the spring rings or either mass moves; skips come
    # only once the whole drive is static.
    servo = {"drive": "two_mass", "vg": 2.0, "kf": 0.6, "d": 0.02, "fc": 0.002, "cs": 2000.0,
             "scale": scale}
    job, faults, _ = random_moves(3, "pre", dwell=True, servo=servo)
    assert job.servo["y"].drive == "two_mass"
    skipped_equals_stepped(job, faults, 1009)


def test_skipping_with_each_axis_on_its_own_addition_clock_changes_no_signal(random_moves):
    # Each exponential circuit's accumulator counts the strobes of its own divider, at a rate
    # of its own: a skip stops before the first carry of any of them.
    job, faults, dwell = random_moves(9, "post", dwell=True, axis_fa=("x", "y"))
    assert len({job.fa_hz(axis) for axis in ("x", "y")} | {job.machine.accel_fa_hz}) == 3
    _, skipped = skipped_equals_stepped(job, faults, 1009)
    assert skipped[3] > 0.5 * dwell * job.machine.clock_hz


@pytest.mark.slow
def test_a_skipping_compiled_run_equals_amaranths_simulator(random_moves):
    job, faults, _ = random_moves(1, "pre", dwell=True)
    compiled = run(job, faults, "cxxrtl", True, 50, max_cycles=30_000)
    reference = run(job, faults, "pysim", True, 50, max_cycles=30_000)
    assert compiled[3] > 5_000, "the run must include skipped cycles"
    assert compiled[0] == reference[0]
    assert np.array_equal(compiled[1], reference[1])


@pytest.mark.parametrize("accel", ["pre", "post"])
def test_skipping_between_accel_decel_carries_changes_no_signal(accel, make_job):
    # The paper's tau = 300 ms: after the move the circuit drains for seconds, its last
    # carries 100 to 300 ms apart; a stiff servo (Kp 200/s, Tm 0.5 ms) rests in between.
    job = make_job("G21 G91 F1200\nG01 X0.3 Y0.1\nM30", MachineConfig(accel=accel),
                   ServoConfig(kp=200.0, tm=0.0005), name="tail")
    stepped, skipped = skipped_equals_stepped(job, {}, 1000)
    assert skipped[3] > 0.3 * stepped[0]["cycles"]


@pytest.mark.parametrize("accel", ["pre", "post", "none"])
def test_skipping_between_the_feed_pulses_of_a_low_feed_arc_changes_no_signal(accel, make_job):
    # The paper's low feed (word 0x00FF: 88 FP/s): between feed pulses, carries and encoder
    # edges, thousands of cycles apart, only the free-running state and the plants move.
    job = make_job("G21 G91 F5.3\nG03 X0 Y0 I0.04 J0\nM30", MachineConfig(accel=accel),
                   name="low-feed")
    stepped, skipped = skipped_equals_stepped(job, {}, 1000)
    assert skipped[3] > 0.5 * stepped[0]["cycles"]


@pytest.mark.slow
@settings(derandomize=True, max_examples=12, deadline=None)
@given(accel=st.sampled_from(["pre", "post", "none"]), feed=st.integers(1, 3000),
       tm=st.sampled_from([1e-6, 0.0005, 0.01]), kp=st.floats(20, 300),
       x=st.integers(-40, 40), y=st.integers(-40, 40), arc=st.booleans())
def test_skipping_through_random_moves_changes_no_signal(make_job, accel, feed, tm, kp, x, y,
                                                         arc):
    # Feeds from 1 to 3000 mm/min give every shape of rate multiplier word (the skip stops
    # before the next feed pulse through the open gate); Tm = 1 us lands the velocity at once, so
    # the plants also move at a steady velocity (stepped in closed form up to the next count).
    machine = MachineConfig(accel=accel, accel_fa_hz=400_000.0)
    move = f"G03 X0 Y0 I{abs(x) / 1000 + 0.005:.3f} J0" if arc else \
        f"G01 X{x / 1000:.3f} Y{y / 1000:.3f}"
    job = make_job(f"G21 G91 F{feed}\n{move}\nM30", machine, ServoConfig(kp=kp, tm=tm),
                   name="random")
    _, skipped = skipped_equals_stepped(job, {}, 997, max_cycles=2_000_000)
    assert skipped[3] > 0


class LonePlant(wiring.Component):
    """One servo plant with its inputs as ports, declared free-running: the skip then steps
    it natively up to each change of its count (sim/backends/cxxrtl/plant.cc, advance_plants),
    which ``seen`` registers a cycle later (as an encoder interface would) and feeds back: on odd
    counts the D/A code is one step further from 0 V, so a skip that ran past a count change moves
    the plant differently."""

    free_running = ServoPlant.declare().under("plant").merge(quiet="quiet")

    def __init__(self):
        super().__init__({"dac": In(16), "dac_zero": In(16), "gain": In(GAIN_BITS),
                          "alpha": In(ALPHA_BITS), "stall": In(1), "count": Out(COUNT_BITS),
                          "seen": Out(COUNT_BITS), "quiet": Out(1)})

    def elaborate(self, platform):
        m = Module()
        m.submodules.plant = plant = ServoPlant()
        faster = Mux(self.dac < self.dac_zero, self.dac - 1, self.dac + 1)
        m.d.comb += [plant.dac.eq(Mux(self.seen[0], faster, self.dac)),
                     plant.dac_zero.eq(self.dac_zero),
                     plant.gain.eq(self.gain), plant.alpha.eq(self.alpha),
                     plant.stall.eq(self.stall), self.count.eq(plant.count), self.quiet.eq(1)]
        m.d.sync += self.seen.eq(plant.count)
        return m


def stepped_and_skipping(component: type):
    """Two compiled backends of ``component()``: one steps, one skips (closed afterwards)."""
    backends = CxxrtlBackend(component()), CxxrtlBackend(component())
    yield backends
    for backend in backends:
        backend.close()


def step_both(backends, cycles: int) -> None:
    """Step the first of :func:`stepped_and_skipping`'s backends, let the second skip, and
    compare every signal."""
    stepped, skipping = backends
    stepped.step(cycles)
    skipping.step(cycles, skip_idle=True)
    names = stepped.probe_names()
    assert {n: skipping.probe(n) for n in names} == {n: stepped.probe(n) for n in names}


@pytest.fixture(scope="module")
def lone_plants():
    yield from stepped_and_skipping(LonePlant)


@settings(derandomize=True, max_examples=30, deadline=None)
@given(phases=st.lists(st.tuples(
    st.integers(-3, 3), st.one_of(st.sampled_from([1 << 20, 3 << 18]), st.integers(0, 1 << 22)),
    st.one_of(st.just((1 << ALPHA_BITS) - 1), st.integers(1, 1 << 16)), st.booleans(),
    st.integers(1, 30_000)), min_size=1, max_size=4))
def test_native_plant_steps_equal_the_plants_gateware(lone_plants, phases):
    # Velocity 2^20 (or 3 * 2^18) counts/cycle << 32 lands the position exactly on count
    # boundaries; alpha = 2^24 - 1 lands the velocity at once (then steady, in closed form),
    # a small alpha keeps it in its lag (stepped one cycle at a time).
    stepped, skipping = lone_plants
    for backend in lone_plants:
        backend.reset()
        backend.set("dac_zero", 2048)
    for offset, gain, alpha, stall, cycles in phases:
        for backend in lone_plants:
            for port, value in (("dac", 2048 + offset), ("gain", gain), ("alpha", alpha),
                                ("stall", int(stall and offset == 0))):
                backend.set(port, value)
        step_both(lone_plants, cycles)
    assert stepped.skipped_cycles == 0
    assert skipping.skipped_cycles > 0 or max(phase[-1] for phase in phases) < 1000


@pytest.fixture(scope="module")
def lone_k3701s():
    yield from stepped_and_skipping(K3701)


@settings(derandomize=True, max_examples=20, deadline=None)
@given(kind=st.sampled_from(["line", "circle", "parabola", "exponential"]),
       r=st.integers(3, 30),
       xe=st.integers(-30, 30), ye=st.integers(-30, 30), cw=st.booleans(), sqrt2=st.booleans(),
       fp=st.lists(st.tuples(st.booleans(), st.integers(1, 40)), min_size=5, max_size=60))
def test_skipping_the_k3701_step_latency_changes_no_signal(lone_k3701s, kind, r, xe, ye,
                                                          cw, sqrt2, fp):
    # A whole circle (end = start), a line, a parabola (through the tangent point
    # (xe / 2, r), or (r, ye / 2) with its axis along X) or an exponential (constant r,
    # offset r + 1/2; a logarithm with its abscissa along Y); the FP stream as runs of high
    # and low cycles.
    block = {"circle": lambda: Block.arc(0, 0, r, 0, cw=cw, sqrt2=sqrt2),
             "line": lambda: Block.line(xe, ye, sqrt2=sqrt2),
             "parabola": lambda: Block.parabola(xe or 1, ye, xe // 2, r, swap=cw and ye != 0,
                                                sqrt2=sqrt2),
             "exponential": lambda: Block.exponential(xe or 1, ye, r if cw else -r, r, r // 2,
                                                      swap=sqrt2 and ye != 0,
                                                      sqrt2=sqrt2)}[kind]()
    ctrl = block_registers(block)["CTRL"]
    cmd = K3701_MAP["CMD"]
    for backend in lone_k3701s:
        backend.reset()
        for name, value in (("X", block.xe), ("Y", block.ye), ("I", block.i), ("J", block.j),
                            ("E", block.frac), ("CTRL", ctrl)):
            reg = K3701_MAP[name]
            for k, byte in enumerate(reg.to_bytes(value)):
                backend.bus_write(reg.addr + k, byte)
        backend.bus_write(cmd.addr, cmd.encode(start=1, ack=1, clear=1))
    for level, cycles in fp:
        for backend in lone_k3701s:
            backend.set("fp", int(level))
        step_both(lone_k3701s, cycles)
    assert lone_k3701s[1].skipped_cycles > 0 or sum(c for level, c in fp if not level) < 100
