"""The event-level engine equals the compiled RTL backend, and the lockstep checker finds the
first cycle where two backends differ.

Whole jobs run on ``--backend engine`` and ``--backend cxxrtl``: the reports (the fields of how
a run was computed aside) and every sample must be equal. The jobs are the demo and
hypothesis-drawn short programs of lines, arcs, helices and dwells on random small machines
(two and three axes; accel/decel circuits of every shape before the K3701, after it or none;
random widths and servos; faults), every example and three-axis CAM programs. The drives and
the curves have modules of their own (``test_engine_drives.py``, ``test_engine_curves.py``).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from k37.firmware_model.job import MachineConfig, demo_job
from k37.hdl.k3701.block import LATENCY_LINEAR
from k37.hdl.k3702.map import K3702_MAP
from k37.sim.backends.engine import build as engine_build
from k37.sim.backends.engine.constants import header
from k37.sim.backends.engine.lockstep import DivergenceError, LockstepBackend
from k37.sim.backends.factory import choose_backend
from k37.sim.run.jobfile import load_job
from k37.sim.run.report import HOW_FIELDS
from k37.sim.run.runner import (
    RunOptions,
    build_backend,
    run_job,
    system_params,
)
from tests.paths import ROOT


def comparable(report: dict) -> dict:
    return {k: v for k, v in report.items() if k not in HOW_FIELDS}


def same_on_engine_and_rtl(job, faults=None, **options) -> dict:
    """Run ``job`` on both backends; assert equal reports and samples; the engine's report."""
    runs = {kind: run_job(job, RunOptions(backend=kind, faults=faults or {}, **options))
            for kind in ("engine", "cxxrtl")}
    engine, rtl = runs["engine"], runs["cxxrtl"]
    assert engine.report["backend"] == "engine" and rtl.report["backend"] == "cxxrtl"
    assert comparable(engine.report) == comparable(rtl.report)
    assert engine.samples.shape == rtl.samples.shape
    assert np.array_equal(engine.samples, rtl.samples)
    return engine.report


def test_engine_equals_the_rtl_on_the_demo_report_and_samples():
    report = same_on_engine_and_rtl(demo_job())
    assert report["status"] == "ok" and report["cycles"] > 6_000_000
    assert report["backend_reason"] == "--backend engine"


@settings(max_examples=12, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(seed=st.integers(0, 10**6), accel=st.sampled_from(["pre", "post", "none"]),
       dwell=st.booleans())
def test_engine_equals_the_rtl_on_generated_jobs(seed, accel, dwell, random_moves):
    job, faults, _ = random_moves(seed, accel, dwell=dwell)
    same_on_engine_and_rtl(job, faults, sample_every=97)


@pytest.mark.parametrize(("accel", "shape", "axis_shapes", "axis_fa", "seed"), [
    ("pre", "bell", None, (), 1), ("pre", "linear", None, (), 5),
    ("post", "linear", {"y": "bell"}, (), 3),
    ("post", "exponential", {"y": "linear"}, ("x", "y"), 7)])
def test_engine_equals_the_rtl_with_every_circuit_and_addition_clock(accel, shape, axis_shapes,
                                                                     axis_fa, seed, random_moves):
    job, faults, _ = random_moves(seed, accel, dwell=False, shape=shape, axis_shapes=axis_shapes,
                                  axis_fa=axis_fa)
    assert job.fa_axes() == axis_fa
    same_on_engine_and_rtl(job, faults, sample_every=97)


EXAMPLES = ROOT / "examples"


#: Every example job, and the faults it is run with.
EXAMPLE_FAULTS = [("circle.toml", {}), ("circle_post.toml", {}), ("dwell.toml", {}),
                  ("square.toml", {}), ("stall.toml", {"x": {"stall": 1}}), ("square.ngc", {})]


@pytest.mark.parametrize(("example", "faults"), EXAMPLE_FAULTS)
def test_engine_equals_the_rtl_on_every_example(example, faults):
    job = load_job(EXAMPLES / example)
    same_on_engine_and_rtl(job, faults)


@settings(max_examples=6, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(seed=st.integers(0, 10**6), dwell=st.booleans())
def test_engine_equals_the_rtl_on_generated_three_axis_jobs(seed, dwell, random_moves):
    """Lines through space, arcs in random planes, helices (on the default three-axis machine:
    one compiled RTL model serves them all)."""
    job, faults, _ = random_moves(seed, "pre", dwell=dwell, axes=3)
    job = replace(job, machine=replace(job.machine, accel_bits=15))
    same_on_engine_and_rtl(job, faults, sample_every=97)


@pytest.mark.parametrize("program", ["linuxcnc_style_helix.ngc", "fusion_style_contour.nc"])
def test_engine_equals_the_rtl_on_three_axis_cam_programs(program):
    job = load_job(ROOT / "tests" / "gcode_corpus" / program)
    assert job.machine.axes == 3
    assert same_on_engine_and_rtl(job)["status"] == "ok"


@settings(max_examples=6, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(seed=st.integers(0, 10**6), accel=st.sampled_from(["pre", "post", "none"]),
       length=st.integers(5, 255))
def test_engine_equals_the_rtl_with_long_encoder_filters(seed, accel, length, random_moves):
    """Every count waits out a filter streak of up to 255 samples, which the engine's skips
    jump; at the longer lengths the encoders miss counts and the servo runs away."""
    job, faults, _ = random_moves(seed, accel, dwell=True)
    job = replace(job, machine=replace(job.machine, encoder_filter=length))
    same_on_engine_and_rtl(job, faults, sample_every=97)


def test_lockstep_runs_a_long_encoder_filter_without_a_difference():
    machine = replace(demo_job().machine, encoder_filter=40)
    job = replace(demo_job(), machine=machine)
    report = run_job(job, RunOptions(backend="lockstep", max_cycles=300_000)).report
    assert report["backend"] == "lockstep" and report["cycles"] == 300_000


def test_lockstep_runs_the_demo_without_a_difference():
    report = run_job(demo_job(), RunOptions(backend="lockstep", max_cycles=400_000)).report
    assert report["backend"] == "lockstep" and report["cycles"] == 400_000


def test_lockstep_names_the_first_differing_cycle_and_port(make_job):
    """An engine of a machine with a shorter accel/decel time constant beside the RTL of the
    paper's: the checker stops at the first cycle their outputs differ, and names the port;
    stepped alone, the two agree on every output up to the cycle before."""
    slow = make_job("G21 G91 F1200\nG01 X1 Y0.5\nM30")
    fast = make_job("G21 G91 F1200\nG01 X1 Y0.5\nM30", MachineConfig(accel_bits=8))
    pair = LockstepBackend(build_backend(fast, "engine"), build_backend(slow, "cxxrtl"))
    with pytest.raises(DivergenceError) as caught:
        run_job(slow, RunOptions(max_cycles=2_000_000), pair)
    found = caught.value
    assert found.names == ("engine", "cxxrtl") and found.values[0] != found.values[1]
    engine, rtl = build_backend(fast, "engine"), build_backend(slow, "cxxrtl")
    pair = LockstepBackend(engine, rtl)
    for name, args, kwargs in caught.value.replayed:
        getattr(pair, name)(*args, **kwargs)
    outputs = tuple(name for name, port in rtl.ports.items() if not port.is_input)
    assert engine.cycle == rtl.cycle == found.cycle - 1
    assert engine.get_many(outputs) == rtl.get_many(outputs)
    engine.step()
    rtl.step()
    assert (engine.get(found.port), rtl.get(found.port)) == found.values


def test_a_closed_engine_refuses_every_call():
    engine = build_backend(demo_job(), "engine")
    engine.close()
    with pytest.raises(RuntimeError, match="this EngineBackend is closed"):
        engine.step(1)
    engine.close()  # again: nothing


def test_every_cxx_file_of_the_engine_is_a_source_of_its_key():
    """A C++ file that the key does not cover would let a library built before an edit of it
    stand; the plant's update shared with the RTL harness is one of them."""
    package = Path(engine_build.__file__).parent
    files = {path.name for path in package.iterdir() if path.suffix in (".cc", ".h")}
    assert files | {"lag.h"} == {Path(name).name for name in engine_build.SOURCES}


def test_engine_constants_come_from_the_register_maps():
    text = header()
    assert f"constexpr int64_t LATENCY_LINEAR = {LATENCY_LINEAR}LL;" in text
    alarm = K3702_MAP["ALARM_ZONE"]
    assert (f'{{"ALARM_ZONE", {alarm.addr}, {alarm.nbytes}, 1, 1, 0, 0, 0LL, '
            f'{(1 << alarm.width) - 1}LL, {alarm.init}ULL}},') in text


def test_auto_picks_the_engine_where_it_runs_the_job_and_no_internal_signal_is_read(
        make_job):
    params = system_params(demo_job())
    assert choose_backend("auto", params) == (
        "engine", "auto: the engine runs this machine and program")
    assert choose_backend("auto", params, internals=True) == (
        "cxxrtl", "auto: internal signals (a waveform, probes) need the RTL")
    assert choose_backend("engine", params) == ("engine", "--backend engine")
    assert choose_backend("auto", None) == (
        "cxxrtl", "auto: the engine runs only the simulated machine (System)")
    report = run_job(make_job("G21 G91 F600\nG01 X0.05\nM30")).report
    assert (report["backend"], report["backend_reason"]) == (
        "engine", "auto: the engine runs this machine and program")
