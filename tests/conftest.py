"""Fixtures the tests share: jobs built or written for a test, random move programs, the
``k37`` command.

Amaranth-simulator helpers for the gateware's unit tests (a bench on a 1 MHz clock, host-bus
accesses) are in ``testbench.py`` beside this file.
"""

from __future__ import annotations

import os
import random
import subprocess
import sys
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import pytest
from hypothesis import settings

from k37.firmware_model.gcode.parser import parse
from k37.firmware_model.job import AxisAccelConfig, Job, MachineConfig, ServoConfig

# Hypothesis draws the same examples on every run (they follow from each test's name), so that
# a run's result is the code's; K37_HYPOTHESIS=explore draws new ones on every run, to look for
# cases the repeatable draws do not reach.
settings.register_profile("repeatable", derandomize=True)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("K37_HYPOTHESIS", "repeatable"))


def _make_job(gcode: str, machine: MachineConfig | None = None,
              servo: ServoConfig | None = None, *, name: str = "test",
              source: str | None = None) -> Job:
    """``gcode`` (named ``source`` in errors, default ``<name>``) on ``machine`` (default: the
    paper's) with ``servo`` on every axis."""
    machine = machine or MachineConfig()
    program = parse(gcode, source=source or f"<{name}>", lsb_mm=machine.lsb_mm,
                    sqrt2=machine.sqrt2, axes=machine.axes)
    return Job(name, machine, dict.fromkeys(machine.axis_names, servo or ServoConfig()),
               program)


def _random_moves(seed: int, accel: str, *, dwell: bool, axes: int = 2,
                  shape: str = "exponential", axis_shapes: dict[str, str] | None = None,
                  servo: dict | None = None, axis_fa: tuple[str, ...] = (),
                  curves: bool = False) -> tuple[Job, dict, float]:
    """Three short random lines or full circles (each followed by a 50 to 150 ms dwell if
    ``dwell``) on a random small machine, and random faults: the job, its faults and the
    seconds of dwell. On three axes (``axes=3``) the lines move Z too and the circles are in
    a random plane, helical (their normal axis moving) half the time. ``shape``: the
    accel/decel circuit; ``axis_shapes``: per-axis circuits (post placement) with their own
    random widths; ``servo``: servo keys beside Kp and Tm; ``axis_fa``: axes (post placement)
    whose circuits add at random addition clocks of their own; ``curves``: a random parabola
    and exponential (in XY) follow the moves."""
    rng = random.Random(seed)
    lines = [f"G21 G91 F{rng.choice((300, 1200, 2400))}"]
    seconds = 0.0
    for _ in range(3):
        if rng.random() < 0.5:
            x, y = rng.randint(-40, 40) / 1000, rng.randint(-40, 40) / 1000
            z = f" Z{rng.randint(-40, 40) / 1000:.3f}" if axes == 3 else ""
            lines.append(f"G01 X{x:.3f} Y{y:.3f}{z}")
        else:
            arc = f"G0{rng.choice((2, 3))} I{rng.randint(5, 30) / 1000:.3f} J0"
            if axes == 3:
                plane, first, normal = rng.choice((("G17", "I", "Z"), ("G18", "K", "Y"),
                                                   ("G19", "J", "X")))
                r = rng.randint(5, 30)  # a full circle: 5.6 r steps, more than the helix's r
                helix = f" {normal}{rng.randint(-r, r) / 1000:.3f}" if rng.random() < 0.5 else ""
                arc = f"{plane} G0{rng.choice((2, 3))} {first}{r / 1000:.3f}{helix}"
            lines.append(arc)
        if dwell:
            wait = rng.randint(50, 150) / 1000  # the axes settle in the first 10 to 40 ms
            lines.append(f"G04 P{wait}")
            seconds += wait
    if curves:  # drawn after the moves, so that a seed's moves are the same either way
        pe, vp = rng.randint(24, 40) * rng.choice((1, -1)), rng.randint(-4, 4)
        xe, ye = rng.randint(20, 40) * rng.choice((1, -1)), rng.randint(5, 15)
        k = rng.randint(25, 40) * rng.choice((1, -1))
        lines += [f"G17 G06 X{pe / 1000:.3f} Y{rng.randint(-3, 3) / 1000:.3f} "
                  f"I{pe / 2000:.4f} J{vp / 1000:.3f}",
                  f"G06.{rng.choice((1, 2))} X{xe / 1000:.3f} Y{ye / 1000:.3f} K{k / 1000:.3f}"]
    lines.append("M30")
    machine = MachineConfig(accel=accel, accel_bits=rng.choice((4, 6, 8)), accel_shape=shape,
                            sqrt2=rng.random() < 0.5,
                            accel_fa_hz=float(rng.randint(50_000, 400_000)),
                            alarm_limit=rng.choice((30, 20_000)),
                            encoder_filter=rng.randint(1, 4), axes=axes)
    plant = ServoConfig(kp=rng.uniform(100, 400), tm=rng.uniform(0.0002, 0.002), **(servo or {}))
    faults = {}
    if rng.random() < 0.4:
        faults[rng.choice(machine.axis_names)] = {rng.choice(("stall", "break_a")): 1}
    job = _make_job("\n".join(lines), machine, plant, name=f"random-{seed}")
    if axis_shapes:
        job = replace(job, axis_accel={
            axis: AxisAccelConfig(accel_shape=s, accel_bits=rng.choice((4, 5, 7)))
            for axis, s in axis_shapes.items()})
    if axis_fa:
        job = replace(job, axis_accel={**job.axis_accel, **{
            axis: replace(job.axis_accel.get(axis, AxisAccelConfig()),
                          accel_fa_hz=float(rng.randint(50_000, 400_000))) for axis in axis_fa}})
    return job, faults, seconds


@pytest.fixture(scope="session")
def make_job() -> Callable[..., Job]:
    """``make_job(gcode, machine=None, servo=None, *, name, source)``: see
    :func:`_make_job`."""
    return _make_job


@pytest.fixture(scope="session")
def random_moves() -> Callable[..., tuple[Job, dict, float]]:
    """``random_moves(seed, accel, *, dwell, axes=2)``: a random short job, its faults and its
    dwell seconds (see :func:`_random_moves`)."""
    return _random_moves


@pytest.fixture
def job_file(tmp_path: Path) -> Callable[..., Path]:
    """Writes a TOML job (its ``[machine]`` and ``[servo]`` tables as TOML text) to
    ``tmp_path/job.toml`` and returns its path."""

    def write(gcode: str, machine: str = "", servo: str = "") -> Path:
        path = tmp_path / "job.toml"
        path.write_text(f'[machine]\n{machine}\n[servo]\n{servo}\n[program]\ngcode = """\n'
                        f'{gcode}\n"""\n')
        return path

    return write


@pytest.fixture
def k37(tmp_path: Path) -> Callable[..., subprocess.CompletedProcess]:
    """Runs ``k37 ARGS`` in a fresh Python (``python -m k37.sim.cli``) in ``tmp_path``."""

    def run(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "k37.sim.cli", *args], cwd=tmp_path,
                              capture_output=True, text=True, check=False)

    return run
