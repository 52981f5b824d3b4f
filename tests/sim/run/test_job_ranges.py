"""Every machine and servo key's range, through ``k37 run``: a value just outside is one error
line naming the key, the value and the range; the boundary values are accepted and fit the
blocks; the loader and the blocks refuse a value in the same words."""

from __future__ import annotations

import dataclasses
import gc
import math
import sys
import warnings
from pathlib import Path

import pytest
from amaranth.hdl import UnusedElaboratable

from k37.firmware_model.gcode.parser import parse
from k37.firmware_model.job import (
    AXES,
    MachineConfig,
)
from k37.hdl.chipset.chip import Chipset
from k37.hdl.common.params import Limit
from k37.hdl.feed.map.feed_rate import DIVIDER_WIDTH
from k37.hdl.feed.rates import increment_for
from k37.sim.cli import main
from k37.sim.machine.plant_model import ALPHA_BITS, GAIN_BITS, VMAX_BITS, PlantParams
from k37.sim.machine.servo import plant_params, servo_limits
from k37.sim.run.jobfile import load_job
from tests.sim.run.test_job import write

# --- every machine and servo key's range, through `k37 run` ---------------------------------

#: The range of every numeric machine and servo key on the default machine, as the blocks
#: define them (servo: the plant's fixed point, in the job's units).
DEFAULT = MachineConfig()
LIMITS: dict[str, Limit] = {
    **{f"machine.{f.name}": DEFAULT.valid(f.name) for f in dataclasses.fields(MachineConfig)
       if isinstance(DEFAULT.valid(f.name), Limit)},
    **{f"servo.{name}": limit for name, limit in servo_limits(DEFAULT).items()}}
#: A program any machine runs: it moves nothing.
DWELL = '[program]\ngcode = "G04 P0.01"\n'


def test_the_ranges_are_the_blocks():
    assert {key: limit.describe() for key, limit in LIMITS.items()} == {
        "machine.clock_hz": "in 1..1000000000 Hz",
        "machine.lsb_mm": "> 0 mm",
        "machine.accel_bits": "in 4..24",
        "machine.accel_fa_hz": ">= 0.05960464478 and < 1000000 Hz (24-bit divider at clock_hz)",
        "machine.dac_bits": "in 8..16",
        "machine.in_position": "in 0..16777215",
        "machine.alarm_limit": "in 0..16777215",
        "machine.encoder_filter": "in 1..255",
        "machine.rapid_mm_min": "> 0 mm/min",
        "machine.axes": "in 2..3",
        "servo.kp": "> 0 and < 1000000 1/s (32-bit gain at clock_hz)",
        "servo.tm": ">= 0 and <= 16.777216 s (24-bit alpha at clock_hz)",
        "servo.max_speed": "> 0 and < 3932160000 mm/min (48-bit speed limit at clock_hz and "
                           "lsb_mm)",
        "servo.kf": ">= 0 and <= 2 (fraction of the command rate)",
        "servo.update_cycles": "in 1..4096 cycles",
        "servo.kt": "> 0 N m/A", "servo.ja": "> 0 kg m^2", "servo.vg": "> 0 A s/rad",
        "servo.ti": ">= 0 s", "servo.d": ">= 0 N m s/rad", "servo.fc": ">= 0 N m",
        "servo.load": "a number N m", "servo.counts_per_rev": "> 0 counts",
        "servo.mass": "> 0 kg", "servo.ks": "> 0 N/m", "servo.cs": ">= 0 N s/m",
        "servo.lead": "> 0 m",
    }


def _step(bound: float, limit: Limit, toward: float) -> float:
    """The next value after ``bound`` toward ``toward`` that the key's type holds (near 0: the
    smallest normal float, as a subnormal speed underflows in the plant's units)."""
    if limit.integer:
        return bound + (1 if toward > bound else -1)
    if bound == 0 and toward > 0:
        return sys.float_info.min
    return math.nextafter(bound, toward)


def _bounds(limit: Limit) -> list[tuple[float, bool, float]]:
    """Each bound (as the key's type), whether it is open, and the direction of the inside."""
    kind = int if limit.integer else float
    return [(kind(bound), is_open, toward)
            for bound, is_open, toward in ((limit.low, limit.low_open, math.inf),
                                           (limit.high, limit.high_open, -math.inf))
            if bound is not None]


def outside(limit: Limit) -> list[float]:
    """The values just outside each bound."""
    return [bound if is_open else _step(bound, limit, -toward)
            for bound, is_open, toward in _bounds(limit)]


def inside(limit: Limit) -> list[float]:
    """The boundary values a key takes: each bound, or just inside it if open."""
    return [_step(bound, limit, toward) if is_open else bound
            for bound, is_open, toward in _bounds(limit)]


def job_text(key: str, value: float) -> str:
    """A job with ``key = value`` (under ``[servo]``, ``[servo.x]`` or ``[servo.y]`` as the
    key says); a clock comes with an fa and a kp it allows."""
    table, name = key.rsplit(".", 1)
    text = f"[{table}]\n{name} = {value!r}\n"
    if key == "machine.clock_hz":
        text += f"accel_fa_hz = {value / 2!r}\n[servo]\nkp = {value / 2!r}\n"
    return text + DWELL


def run_error(tmp_path: Path, capsys, text: str) -> str:
    """``k37 run`` of a job file of ``text``: exit 2 and the one line it printed."""
    path = write(tmp_path, text)
    assert main(["run", str(path), "-q"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    prefix = f"k37: error: {path}: "
    assert err.startswith(prefix)
    return err[len(prefix):].rstrip("\n")


OUT_OF_RANGE = [(key, value) for key, limit in LIMITS.items() for value in outside(limit)]
OVERRIDES = [(key.replace("servo.", f"servo.{axis}."), value) for axis in AXES
             for key, value in OUT_OF_RANGE if key.startswith("servo.")]


@pytest.mark.parametrize(("key", "value"), OUT_OF_RANGE + OVERRIDES)
def test_a_value_out_of_range_exits_2_naming_key_value_and_range(tmp_path, capsys, key, value):
    limit = LIMITS[key.replace(".x.", ".").replace(".y.", ".")]
    assert run_error(tmp_path, capsys, job_text(key, value)) == (
        f"{key} must be {limit.describe()}, not {value!r}")


@pytest.mark.parametrize(("key", "value"),
                         [(key, value) for key, limit in LIMITS.items() for value in inside(limit)])
def test_the_boundary_values_are_accepted_and_fit_the_blocks(tmp_path, key, value):
    job = load_job(write(tmp_path, job_text(key, value)))
    table, name = key.split(".")
    configs = [job.machine] if table == "machine" else [job.servo[axis] for axis in AXES]
    assert [getattr(config, name) for config in configs] == [value] * len(configs)
    for axis in AXES:
        plant = plant_params(job.machine, job.servo[axis])
        assert (0 <= plant.gain < 1 << GAIN_BITS and 0 < plant.alpha < 1 << ALPHA_BITS
                and 0 <= plant.vmax < 1 << VMAX_BITS)
    assert 0 < increment_for(job.machine.accel_fa_hz, width=DIVIDER_WIDTH,
                             f_clk=job.machine.clock_hz) < 1 << DIVIDER_WIDTH


@pytest.mark.parametrize(("key", "value", "block"), [
    ("machine.accel_bits", 2, lambda: Chipset(accel_bits=2)),
    ("machine.accel_fa_hz", 0.05, lambda: increment_for(0.05, width=DIVIDER_WIDTH, f_clk=1e6)),
    ("machine.lsb_mm", -1.0, lambda: parse("", lsb_mm=-1.0)),
    ("servo.kp", 2e6, lambda: PlantParams(kp=2e6, tm=0.01)),
    ("servo.tm", 40.0, lambda: PlantParams(kp=30.0, tm=40.0)),
])
def test_the_block_and_the_loader_refuse_a_value_in_the_same_words(tmp_path, capsys, key, value,
                                                                    block):
    with pytest.raises(ValueError, match=" must ") as info:
        block()
    refusal = str(info.value).split(" must ", 1)[1]
    # A refused design is made (Amaranth's ``__new__`` ran) but never meant to be elaborated:
    # drop it here, where its unused-design warning is expected, not at a later collection.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnusedElaboratable)
        del info
        gc.collect()
    assert run_error(tmp_path, capsys, job_text(key, value)) == f"{key} must {refusal}"


def test_a_drive_that_updates_every_cycle_refuses_an_update_period(tmp_path, capsys):
    text = '[servo]\ndrive = "torque"\nupdate_cycles = 8\n' + DWELL
    assert run_error(tmp_path, capsys, text) == (
        "servo.update_cycles must be 1 on a torque drive (it updates every cycle), not 8")


def test_the_servo_ranges_follow_the_clock_and_the_lsb(tmp_path, capsys):
    fast = "[machine]\nclock_hz = 2_000_000\nlsb_mm = 0.01\n[servo]\n"
    job = load_job(write(tmp_path, fast + "kp = 1.5e6\nmax_speed = 7e10\n" + DWELL))
    assert job.servo["x"].kp == 1.5e6
    assert run_error(tmp_path, capsys, fast + "max_speed = 8e10\n" + DWELL) == (
        "servo.max_speed must be > 0 and < 78643200000 mm/min (48-bit speed limit at clock_hz "
        "and lsb_mm), not 80000000000.0")


def test_an_extreme_valid_job_runs_without_a_traceback(tmp_path):
    path = write(tmp_path, "[machine]\naccel_bits = 4\naccel_fa_hz = 0.0596046448\n"
                           "[servo]\nkp = 999999.0\ntm = 16.777216\nmax_speed = 3.9e9\n"
                           '[program]\ngcode = "G01 X0.01 F100"\n')
    assert main(["run", str(path), "--backend", "pysim", "--max-cycles", "3000", "-q"]) in (0, 1)
