"""Job files: what ``k37 run [JOB]`` runs, loaded and checked against the whole machine.

A job is a TOML file (``.toml``) or a plain G-code file (any other extension), run on the
default machine; no job at all is :func:`firmware_model.job.demo_job`, the paper's circle. A
TOML job::

    name = "circle"                 # optional; default: the file's stem

    [machine]                       # every key optional (defaults: MachineConfig)
    clock_hz = 1_000_000
    accel = "post"                  # "pre" | "post" | "none"
    accel_shape = "linear"          # "exponential" | "linear" | "bell"
    [machine.y]                     # per-axis accel/decel circuit (accel = "post" only)
    accel_bits = 14

    [servo]                         # both axes (defaults: ServoConfig)
    kp = 30.0
    [servo.y]                       # per-axis overrides
    kp = 25.0

    [program]                       # exactly one of gcode (inline) and file
    file = "square.ngc"             # relative to the TOML file
    arc_tolerance = 2.0             # LSB, optional

    [run]                           # optional
    max_time_s = 10.0

Every value is checked when the job is loaded, against the limit of the block that has it: a
machine key against the chipset's or the host's (:class:`firmware_model.job.MachineConfig`),
a servo key (and each ``[servo.x]``/``[servo.y]`` override) against the simulated plant's
fixed point on the job's clock and LSB (:func:`servo_limits`). An unknown key anywhere is an
error naming its full path. All errors are :class:`JobError` (bad file or value, naming the
key, its value and its range) or :class:`~firmware_model.gcode.GcodeError` (bad program),
each one line of text.
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import fields
from os import PathLike
from pathlib import Path
from typing import Any, NoReturn

from firmware_model.gcode import ARC_TOLERANCE, ARC_TOLERANCE_LIMIT, Program, parse
from firmware_model.job import (
    AXES,
    AxisAccelConfig,
    Job,
    MachineConfig,
    OrAbsent,
    RunConfig,
    ServoConfig,
    Valid,
    demo_job,
    gcode_job,
)
from hdl.limits import Limit
from sim.machine.plant import PlantParams
from sim.machine.torque_drive import TorqueParams

__all__ = ["JobError", "job_keys_markdown", "load_job", "load_step_fault", "plant_params",
           "servo_limits", "torque_params"]

#: The torque drive's keys (used only with ``drive = "torque"``).
TORQUE_KEYS = tuple(TorqueParams.limits())


class JobError(ValueError):
    """A job file the loader refuses; ``str()`` is one line naming the file."""


def servo_limits(machine: MachineConfig) -> dict[str, Limit]:
    """The range of each servo key on ``machine``: the plant's
    (:meth:`sim.machine.plant.PlantParams.limits`), in the job's units."""
    limits = PlantParams.limits(machine.clock_hz)
    speed = limits["max_speed"]
    return {**limits, "max_speed": speed.scaled(machine.mm_per_min(1.0), "mm/min",
                                                f"{speed.note} and lsb_mm"),
            **TorqueParams.limits()}


def plant_params(machine: MachineConfig, servo: ServoConfig) -> PlantParams:
    """The plant of one axis's ``servo`` on ``machine``.

    Raises
    ------
    ValueError
        A servo key is out of the plant's range (checked in the plant's units), naming the
        key, its value and its range in the job's units (:func:`servo_limits`).
    """
    values = {"kp": servo.kp, "tm": servo.tm, "kf": servo.kf,
              "max_speed": None if servo.max_speed is None else machine.lsb_per_s(servo.max_speed)}
    limits = PlantParams.limits(machine.clock_hz)
    for name, value in values.items():
        if value is not None and value not in limits[name]:
            raise ValueError(f"{name} must be {servo_limits(machine)[name].describe()}, "
                             f"not {getattr(servo, name)!r}")
    return PlantParams(clock_hz=machine.clock_hz, **values)


def torque_params(machine: MachineConfig, servo: ServoConfig) -> TorqueParams:
    """The torque drive of one axis's ``servo`` on ``machine`` (ValueError naming a bad key)."""
    return TorqueParams(clock_hz=machine.clock_hz,
                        **{name: getattr(servo, name) for name in TORQUE_KEYS})


def load_step_fault(job: Job, axis: str, torque: float, at_s: float) -> dict[str, int]:
    """The plant inputs of a load step of ``torque`` (N m) on ``axis`` at ``at_s`` seconds
    (the axis must have the torque drive); ValueError naming what is wrong."""
    if axis not in AXES:
        raise ValueError(f"no axis {axis!r}; axes are {', '.join(AXES)}")
    servo = job.servo[axis]
    if servo.drive != "torque":
        raise ValueError(f"a load step needs servo.{axis}.drive = \"torque\", not "
                         f"{servo.drive!r}")
    Limit(unit="N m").check("load step torque", torque)
    Limit(0, unit="s").check("load step time", at_s)
    params = torque_params(job.machine, servo)
    word = params.torque_word(torque)
    if word == 0 or abs(word) + abs(params.torque_word(params.load)) >= 1 << 39:
        raise ValueError(f"load step {torque!r} N m is 0 or beyond the drive's torque range")
    return {"load_step": word, "load_after": round(at_s * job.machine.clock_hz)}


def load_job(path: str | PathLike[str] | None) -> Job:
    """Load a TOML job, or a G-code file run on the default machine; None: the demo.

    Raises
    ------
    JobError
        The file cannot be read, is not valid TOML, or holds an unknown key or a bad value.
    GcodeError
        The program is bad (naming its file, line and column).
    """
    if path is None:
        return demo_job()
    path = Path(path)
    text = _read(path, str(path))
    if path.suffix.lower() != ".toml":
        return gcode_job(path.stem, text, str(path))
    return _TomlJob(path, text).job()


def _read(path: Path, name: str) -> str:
    try:
        return path.read_text(encoding="utf-8")
    except UnicodeDecodeError as e:
        raise JobError(f"{name}: not UTF-8 text (byte {e.start})") from None
    except OSError as e:
        raise JobError(f"{name}: cannot read: {e.strerror or e}") from None
    except ValueError as e:  # a path no system can open (a NUL in it)
        raise JobError(f"{name}: cannot read: {e}") from None


_TOML_POSITION = re.compile(r"^(.*) \(at line (\d+), column (\d+)\)$")


class _TomlJob:
    """One TOML job file being loaded; every error names the file."""

    def __init__(self, path: Path, text: str):
        self.path = path
        self.source = str(path)
        try:
            self.data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as e:
            m = _TOML_POSITION.match(str(e))
            where = f"{m.group(2)}:{m.group(3)}: {m.group(1)}" if m else f" {e}"
            raise JobError(f"{self.source}:{where}") from None

    def fail(self, message: str) -> NoReturn:
        raise JobError(f"{self.source}: {message}") from None

    def table(self, data: dict, key: str, allowed: tuple[str, ...], parent: str = "") -> dict:
        """``data[key]`` (a table, empty when absent), refusing keys not in ``allowed``."""
        value = data.get(key, {})
        if not isinstance(value, dict):
            self.fail(f"{parent}{key} must be a table, not {value!r}")
        self.known(value, allowed, f"{parent}{key}.")
        return value

    def known(self, table: dict, allowed: tuple[str, ...], prefix: str) -> None:
        for k in table:
            if k not in allowed:
                self.fail(f"unknown key {prefix}{k}")

    def build(self, cls: type, values: dict, prefix: str) -> Any:
        try:
            return cls(**values)
        except (TypeError, ValueError) as e:
            self.fail(f"{prefix}{e}")

    def job(self) -> Job:
        self.known(self.data, ("name", "machine", "servo", "program", "run"), "")
        name = self.data.get("name", self.path.stem)
        if not isinstance(name, str) or not name:
            self.fail(f"name must be a non-empty string, not {name!r}")
        table = self.table(self.data, "machine", (*_names(MachineConfig), *AXES))
        machine = self.build(MachineConfig, {k: v for k, v in table.items() if k not in AXES},
                             "machine.")
        axis_accel = {axis: self.build(AxisAccelConfig,
                                       self.table(table, axis, _names(AxisAccelConfig),
                                                  "machine."), f"machine.{axis}.")
                      for axis in AXES if axis in table}
        servo = self.servo(machine)
        run = self.build(RunConfig, self.table(self.data, "run", _names(RunConfig)), "run.")
        program = self.program(machine)
        try:
            return Job(name, machine, servo, program, run, axis_accel)
        except ValueError as e:
            self.fail(str(e))

    def servo(self, machine: MachineConfig) -> dict[str, ServoConfig]:
        """Both axes' servos: ``[servo]``, each key overridden by ``[servo.x]``/``[servo.y]``;
        each table is checked against the plant on ``machine``, naming its own keys."""
        table = self.table(self.data, "servo", (*_names(ServoConfig), *AXES))
        common = {k: v for k, v in table.items() if k not in AXES}
        self.plant(machine, common, "servo.")
        axes = {axis: self.table(table, axis, _names(ServoConfig), "servo.") for axis in AXES}
        return {axis: self.plant(machine, {**common, **axes[axis]}, f"servo.{axis}.")
                for axis in AXES}

    def plant(self, machine: MachineConfig, values: dict, prefix: str) -> ServoConfig:
        servo = self.build(ServoConfig, values, prefix)
        try:
            plant_params(machine, servo)
            for name, limit in TorqueParams.limits().items():
                limit.check(name, getattr(servo, name))
            if servo.drive == "torque":  # its fixed point (the keys are unused otherwise)
                torque_params(machine, servo)
        except (TypeError, ValueError) as e:
            self.fail(f"{prefix}{e}")
        return servo

    def program(self, machine: MachineConfig) -> Program:
        if "program" not in self.data:
            self.fail("missing [program] table (give gcode or file)")
        table = self.table(self.data, "program", ("gcode", "file", "arc_tolerance"))
        if ("gcode" in table) == ("file" in table):
            self.fail("program must give exactly one of gcode (inline) and file")
        tolerance = table.get("arc_tolerance", ARC_TOLERANCE)
        try:
            tolerance = ARC_TOLERANCE_LIMIT.check("arc_tolerance", tolerance)
        except (TypeError, ValueError) as e:
            self.fail(f"program.{e}")
        key = "gcode" if "gcode" in table else "file"
        if not isinstance(table[key], str):
            self.fail(f"program.{key} must be a string, not {table[key]!r}")
        if key == "gcode":
            text, source = table["gcode"], f"{self.source}:program.gcode"
        else:
            file = self.path.parent / table["file"]
            source = str(file)
            text = _read(file, f"{self.source}: program.file {source}")
        return parse(text, source=source, lsb_mm=machine.lsb_mm, sqrt2=machine.sqrt2,
                     arc_tolerance=tolerance)


def _names(cls: type) -> tuple[str, ...]:
    return tuple(f.name for f in fields(cls))


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return str(value).lower()
    return f'"{value}"' if isinstance(value, str) else repr(value)


def job_keys_markdown() -> str:
    """A Markdown table of every TOML key with its default, its values (on the default
    machine, for those that follow from it) and its meaning (from the classes)."""
    machine = MachineConfig()
    plant = servo_limits(machine)
    rows = ["Values that follow from other keys are those of the default machine.", "",
            "| key | default | values | meaning |", "|---|---|---|---|",
            "| name | the file's stem | a non-empty string | the job's name |"]
    for table, config in (("machine", machine), ("servo", ServoConfig()), ("run", RunConfig())):
        for f in fields(config):
            valid: Valid = config.valid(f.name)
            if table == "servo" and f.name in plant:  # type checked there, range the plant's
                valid = OrAbsent(plant[f.name]) if f.default is None else plant[f.name]
            default = "absent" if f.default is None else _toml_value(f.default)
            rows.append(f"| {table}.{f.name} | {default} | {valid.describe()} | "
                        f"{f.metadata['doc']} |")
    for f in fields(AxisAccelConfig):
        rows.append(f"| machine.{'/'.join(AXES)}.{f.name} | the [machine] value | "
                    f"{AxisAccelConfig().valid(f.name).describe()} | {f.metadata['doc']} |")
    rows += [f"| servo.{'.*, servo.'.join(AXES)}.* | the [servo] values | as in [servo] | "
             "per-axis servo overrides |",
             "| program.gcode | | a string | the program, inline (give gcode or file) |",
             "| program.file | | a string | the program's file, relative to the job file |",
             f"| program.arc_tolerance | {ARC_TOLERANCE!r} | {ARC_TOLERANCE_LIMIT.describe()} | "
             f"largest difference (LSB) between an arc's start and end radii |"]
    return "\n".join(rows) + "\n"
