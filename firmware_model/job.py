"""Job files: the machine, its servos and the program that ``k37 run [JOB]`` runs.

A job is a TOML file (``.toml``) or a plain G-code file (any other extension), run on the
default machine; no job at all is :func:`demo_job`, the paper's circle. A TOML job::

    name = "circle"                 # optional; default: the file's stem

    [machine]                       # every key optional (defaults: MachineConfig)
    clock_hz = 1_000_000
    accel = "pre"                   # "pre" | "post" | "none"

    [servo]                         # both axes (defaults: ServoConfig)
    kp = 30.0
    [servo.y]                       # per-axis overrides
    kp = 25.0

    [program]                       # exactly one of gcode (inline) and file
    file = "square.ngc"             # relative to the TOML file
    arc_tolerance = 2.0             # LSB, optional

    [run]                           # optional
    max_time_s = 10.0

Every value is checked (type and range) and an unknown key anywhere is an error naming its
full path. All errors are :class:`JobError` (bad file or value) or
:class:`~firmware_model.gcode.GcodeError` (bad program), each one line of text.
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, fields
from os import PathLike
from pathlib import Path
from typing import Any

from firmware_model.gcode import ARC_TOLERANCE, Program, parse
from hdl.encoder import ENCODER_MAP
from hdl.hostbus import Register
from hdl.k3702 import K3702_MAP

__all__ = ["AXES", "DEMO_GCODE", "Job", "JobError", "MachineConfig", "RunConfig",
           "ServoConfig", "demo_job", "gcode_job", "job_keys_markdown", "load_job"]

#: The axes of the machine, in order.
AXES = ("x", "y")

#: The demo: the paper's circle (its photo 6, circular interpolation under FP control), as a
#: full CCW circle of radius 10 mm starting at its rightmost point, at 1200 mm/min (20 k
#: steps/s at 1 um, well inside the K3701's 47.6 k/s and the default servo's reach).
DEMO_GCODE = """\
(K37 demo: the paper's circle, a full circle of radius 10 mm)
G17 G21 G90
F1200
G03 I-10 J0
M30
"""


class JobError(ValueError):
    """A job file the loader refuses; ``str()`` is one line naming the file."""


Check = Callable[[str, Any], Any]


def _number(name: str, value: Any) -> float:
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        raise TypeError(f"{name} must be a number, not {value!r}")
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, not {value!r}")
    return float(value)


def _positive(name: str, value: Any) -> float:
    value = _number(name, value)
    if value <= 0:
        raise ValueError(f"{name} must be positive, not {value!r}")
    return value


def _non_negative(name: str, value: Any) -> float:
    value = _number(name, value)
    if value < 0:
        raise ValueError(f"{name} must not be negative, not {value!r}")
    return value


def _optional(check: Check) -> Check:
    def optional(name: str, value: Any) -> Any:
        return None if value is None else check(name, value)
    return optional


def _integer(low: int, high: int) -> Check:
    def integer(name: str, value: Any) -> int:
        if isinstance(value, float) and value.is_integer():
            value = int(value)
        if not isinstance(value, int) or isinstance(value, bool):
            raise TypeError(f"{name} must be an integer, not {value!r}")
        if not low <= value <= high:
            raise ValueError(f"{name} must be in {low}..{high}, not {value!r}")
        return value
    return integer


def _register(reg: Register) -> Check:
    """The values a chip register accepts (from its register table)."""
    return _integer(*reg.bounds)


def _choice(*options: str) -> Check:
    def choice(name: str, value: Any) -> str:
        if value not in options:
            raise ValueError(f"{name} must be one of {', '.join(map(repr, options))}, "
                             f"not {value!r}")
        return value
    return choice


def _boolean(name: str, value: Any) -> bool:
    if not isinstance(value, bool):
        raise TypeError(f"{name} must be true or false, not {value!r}")
    return value


def _key(default: Any, check: Check, doc: str) -> Any:
    return field(default=default, metadata={"check": check, "doc": doc})


class _Checked:
    """Validates (and normalises) every field with its ``check`` in ``__post_init__``."""

    def __post_init__(self) -> None:
        for f in fields(self):
            object.__setattr__(self, f.name, f.metadata["check"](f.name, getattr(self, f.name)))

    def to_dict(self) -> dict[str, Any]:
        """The JSON-able form: every key with its value."""
        return asdict(self)


@dataclass(frozen=True)
class MachineConfig(_Checked):
    """The chipset and its host-set values. Defaults are the paper's where it gives them."""

    clock_hz: int = _key(1_000_000, _integer(1, 10**9), "system clock CP (Hz); paper: 1 MHz")
    lsb_mm: float = _key(0.001, _positive, "axis travel of one LSB = one pulse (mm)")
    accel: str = _key("pre", _choice("pre", "post", "none"),
                      "accel/decel placement: before the K3701 (FP control), per axis after "
                      "it, or none")
    accel_bits: int = _key(15, _integer(1, 24), "accumulator width n of the accel/decel "
                                                "circuit; paper: 15")
    accel_fa_hz: float = _key(2**15 / 0.3, _positive,
                              "addition clock fa (Hz); paper: 109.227 kHz, tau = 2^n/fa = 300 ms")
    sqrt2: bool = _key(True, _boolean, "K3701 sqrt(2) control (constant path speed)")
    dac_bits: int = _key(K3702_MAP["DAC_BITS"].init, _register(K3702_MAP["DAC_BITS"]),
                         "K3702 D/A word width N")
    in_position: int = _key(10, _register(K3702_MAP["POSITION_ZONE"]),
                            "K3702 position zone W (LSB): in position while abs(error) <= W")
    alarm_limit: int = _key(20_000, _register(K3702_MAP["ALARM_ZONE"]),
                            "K3702 alarm zone A (LSB): alarm while abs(error) > A")
    encoder_filter: int = _key(ENCODER_MAP["FILTER"].init, _register(ENCODER_MAP["FILTER"]),
                               "encoder glitch filter K (samples)")
    rapid_mm_min: float = _key(3000.0, _positive,
                               "feed of G00 moves (mm/min); the default servo follows it with "
                               "a lag of 1667 LSB, inside a 12-bit D/A word's 2048")

    def __post_init__(self) -> None:
        super().__post_init__()
        if not self.accel_fa_hz < self.clock_hz:
            raise ValueError(f"accel_fa_hz must be below clock_hz = {self.clock_hz}, "
                             f"not {self.accel_fa_hz!r}")

    @property
    def tau_s(self) -> float:
        """The accel/decel time constant 2^n / fa (s)."""
        return 2**self.accel_bits / self.accel_fa_hz


@dataclass(frozen=True)
class ServoConfig(_Checked):
    """One axis's servo drive and motor (the simulation plant)."""

    kp: float = _key(30.0, _positive, "position loop gain Kp (1/s)")
    tm: float = _key(0.01, _positive, "velocity loop time constant Tm (s)")
    max_speed: float | None = _key(None, _optional(_positive),
                                   "motor speed limit (mm/min); absent: no limit")


@dataclass(frozen=True)
class RunConfig(_Checked):
    """Options of the run itself."""

    max_time_s: float | None = _key(None, _optional(_positive),
                                    "stop the run after this much simulated time (s); absent: "
                                    "the command line's limit")


@dataclass(frozen=True)
class Job:
    """A machine, its two servos and a parsed program."""

    name: str
    machine: MachineConfig
    servo: dict[str, ServoConfig]
    program: Program
    run: RunConfig = field(default_factory=RunConfig)

    def to_dict(self) -> dict[str, Any]:
        """The JSON-able form of the job's configuration (the program as a summary)."""
        return {"name": self.name, "machine": self.machine.to_dict(),
                "servo": {axis: self.servo[axis].to_dict() for axis in AXES},
                "program": self.program.to_dict(), "run": self.run.to_dict()}


def demo_job() -> Job:
    """The built-in demo (:data:`DEMO_GCODE`) on the default machine."""
    return gcode_job("demo", DEMO_GCODE, "<demo>")


def gcode_job(name: str, text: str, source: str) -> Job:
    """G-code ``text`` (``source`` names it in errors) on the default machine and servos."""
    machine = MachineConfig()
    program = parse(text, source=source, lsb_mm=machine.lsb_mm, sqrt2=machine.sqrt2)
    return Job(name, machine, dict.fromkeys(AXES, ServoConfig()), program)


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

    def fail(self, message: str):
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
        machine = self.build(MachineConfig, self.table(self.data, "machine",
                                                       _names(MachineConfig)), "machine.")
        servo = self.servo()
        run = self.build(RunConfig, self.table(self.data, "run", _names(RunConfig)), "run.")
        return Job(name, machine, servo, self.program(machine), run)

    def servo(self) -> dict[str, ServoConfig]:
        table = self.table(self.data, "servo", (*_names(ServoConfig), *AXES))
        common = {k: v for k, v in table.items() if k not in AXES}
        self.build(ServoConfig, common, "servo.")
        axes = {axis: self.table(table, axis, _names(ServoConfig), "servo.") for axis in AXES}
        return {axis: self.build(ServoConfig, {**common, **axes[axis]}, f"servo.{axis}.")
                for axis in AXES}

    def program(self, machine: MachineConfig) -> Program:
        if "program" not in self.data:
            self.fail("missing [program] table (give gcode or file)")
        table = self.table(self.data, "program", ("gcode", "file", "arc_tolerance"))
        if ("gcode" in table) == ("file" in table):
            self.fail("program must give exactly one of gcode (inline) and file")
        tolerance = table.get("arc_tolerance", ARC_TOLERANCE)
        try:
            tolerance = _non_negative("arc_tolerance", tolerance)
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
    """A Markdown table of every TOML key with its default and meaning (from the classes)."""
    rows = ["| key | default | meaning |", "|---|---|---|",
            "| name | the file's stem | the job's name |"]
    for table, cls in (("machine", MachineConfig), ("servo", ServoConfig), ("run", RunConfig)):
        for f in fields(cls):
            default = "absent" if f.default is None else _toml_value(f.default)
            rows.append(f"| {table}.{f.name} | {default} | {f.metadata['doc']} |")
    rows += ["| servo.x.*, servo.y.* | the [servo] values | per-axis servo overrides |",
             "| program.gcode | | the program, inline (give gcode or file) |",
             "| program.file | | the program's file, relative to the job file |",
             f"| program.arc_tolerance | {ARC_TOLERANCE!r} | largest difference (LSB) between an "
             f"arc's start and end radii |"]
    return "\n".join(rows) + "\n"
