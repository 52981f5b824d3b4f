"""The engine's parabolas and exponentials equal the compiled RTL's.

Blocks loaded over the host bus run on the engine and the RTL in lockstep (every output port
compared after each call, the first differing cycle named): hypothesis-drawn parabolas and
exponentials the host accepts, and raw data the chip refuses or runs past its end (a zero
abscissa, |k| < 2, a negative offset, a third coordinate on three axes), at random feed
rates, on two and three axes in every plane. Whole jobs with curves (generated programs
ending in a G06 parabola and a G06.1/G06.2 exponential) give equal reports and samples.
"""

from __future__ import annotations

from dataclasses import replace

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from k37.firmware_model.host import Host8085
from k37.firmware_model.job import MachineConfig
from k37.hdl.feed.map.decel_control import DECEL_MAP
from k37.hdl.feed.map.feed_rate import FEED_MAP
from k37.hdl.k3701.block import Block, Kind
from k37.hdl.k3701.map import block_registers
from k37.sim.backends.engine.lockstep import LockstepBackend
from k37.sim.backends.factory import choose_backend
from k37.sim.link.simulated import SimulatedLink
from k37.sim.run.runner import build_backend, configure_plants, system_params
from tests.hdl.k3701.test_k3701_exponential import exponentials
from tests.hdl.k3701.test_k3701_parabolic import parabolas
from tests.sim.backends.test_engine import same_on_engine_and_rtl

coords = st.integers(-40, 40)
raw_curves = st.builds(
    Block, kind=st.sampled_from([Kind.PARABOLIC, Kind.EXPONENTIAL]), xe=coords, ye=coords,
    i=st.integers(-3, 40), j=st.integers(-3, 40), cw=st.booleans(), sqrt2=st.booleans(),
    swap=st.booleans(), frac=st.integers(-40, 40))


def run_in_lockstep(block: Block, axes: int, feed: int, make_job) -> Host8085:
    """``block`` loaded and started on both backends in lockstep, then run for 200,000
    cycles at the feed word ``feed`` (the rate multiplier's clock and the accel/decel
    circuit's additions every cycle); the host on them."""
    machine = (MachineConfig(accel="post", accel_bits=8) if axes == 2
               else MachineConfig(axes=3, accel_bits=15))
    job = make_job("M30", machine)
    pair = LockstepBackend(build_backend(job, "engine"), build_backend(job, "cxxrtl"))
    configure_plants(pair, job)
    host = Host8085(SimulatedLink(pair))
    host.command("K3701", ack=1, clear=1)
    for register, value in block_registers(block, axes).items():
        host.write("K3701", register, value)
    host.command("K3701", start=1)
    for register in ("RM_INC", "FA_INC"):
        host.write("FEED", register, FEED_MAP[register].bounds[1])
    host.write("FEED", "FEED", feed)
    host.write("DECEL", "BUDGET", DECEL_MAP["BUDGET"].bounds[1])
    for _ in range(200):
        pair.step(1000)
    return host


@settings(max_examples=10, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(block=st.one_of(parabolas(span=30), exponentials(span=30)), axes=st.sampled_from([2, 3]),
       plane=st.integers(0, 2), feed=st.integers(1 << 14, (1 << 18) - 1))
def test_engine_runs_the_curves_the_host_loads_as_the_rtl_does(block, axes, plane, feed,
                                                               make_job):
    host = run_in_lockstep(replace(block, plane=plane if axes == 3 else 0), axes, feed,
                           make_job)
    status = host.read("K3701", "STATUS")
    assert status & 0b0111 == 0b0010  # ended (irq), not busy, no error
    assert host.read("K3701", "X") == host.read("K3701", "Y") == 0


@settings(max_examples=10, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(block=raw_curves, axes=st.sampled_from([2, 3]), ze=st.sampled_from([0, 0, 5]),
       feed=st.integers(1 << 14, (1 << 18) - 1))
def test_engine_refuses_and_ends_raw_curve_data_as_the_rtl_does(block, axes, ze, feed,
                                                                 make_job):
    run_in_lockstep(replace(block, ze=ze if axes == 3 else 0), axes, feed, make_job)


@pytest.mark.slow
@settings(max_examples=6, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(seed=st.integers(0, 10**6), axes=st.sampled_from([2, 3]))
def test_engine_equals_the_rtl_on_generated_jobs_with_curves(seed, axes, random_moves):
    job, faults, _ = random_moves(seed, "pre", dwell=False, curves=True, axes=axes)
    job = replace(job, machine=replace(job.machine, accel_bits=8 if axes == 2 else 15))
    kinds = {move.block.kind for move in job.program.moves}
    assert {Kind.PARABOLIC, Kind.EXPONENTIAL} <= kinds
    assert choose_backend("auto", system_params(job))[0] == "engine"
    same_on_engine_and_rtl(job, faults, sample_every=97)
