"""Job files: what ``k37 run [JOB]`` runs, loaded and checked against the whole machine.

A job is a TOML file (``.toml``) or a plain G-code file (any other extension), run on the
default machine; no job at all is :func:`k37.firmware_model.job.demo_job`, the paper's circle. A
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
    arc_tolerance = 2.0             # LSB, optional (default: LinuxCNC's 0.028 mm)
    tools = { 1 = 25.0, 2 = { length = 30.0, diameter = 6.0 } }   # optional: mm, lengths
                                    # for G43, diameters for G41/G42

    [run]                           # optional
    max_time_s = 10.0

    [contour]                       # optional: the host's contour controller
    controller = "cec"              # "none" | "ccc" | "vgccc" | "cec"

Every value is checked when the job is loaded, against the limit of the block that has it: a
machine key against the chipset's or the host's (:class:`k37.firmware_model.job.MachineConfig`),
a servo key (and each ``[servo.x]``/``[servo.y]`` override) against the simulated plant's
fixed point on the job's clock and LSB (:func:`k37.sim.machine.servo.servo_limits`). An
unknown key anywhere is an error naming its full path. All errors are :class:`JobError` (bad
file or value, naming the key, its value and its range) or
:class:`~k37.firmware_model.gcode.parser.GcodeError` (bad program), each one line of text.
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import fields
from os import PathLike
from pathlib import Path
from typing import Any, NoReturn

from k37.firmware_model.gcode.tool_table import Tool
from k37.firmware_model.gcode.units import ARC_TOLERANCE_LIMIT, ARC_TOLERANCE_MM
from k37.firmware_model.job import (
    AxisAccelConfig,
    ContourConfig,
    Job,
    MachineConfig,
    OrAbsent,
    RunConfig,
    ServoConfig,
    Valid,
    demo_job,
    gcode_job,
    parse_for_machine,
)
from k37.firmware_model.motion.program import Dwell, Line, Move, Program
from k37.hdl.chipset.map import ALL_AXES
from k37.hdl.common.params import Limit
from k37.sim.files import STDIO, InputError, read_input_text
from k37.sim.machine.servo import check_servo, servo_limits

__all__ = ["JobError", "job_from_data", "job_keys_markdown", "load_job", "read_toml"]

#: A tool's diameter (mm) in ``program.tools``.
TOOL_DIAMETER = Limit(low=0.0, unit="mm")


class JobError(ValueError):
    """A job file the loader refuses; ``str()`` is one line naming the file."""


def load_job(path: str | PathLike[str] | None, *, frontend: str = "builtin",
             arc_tolerance: float | None = None) -> Job:
    """Load a TOML job, or a G-code file (``-``: stdin) run on the default machine; None: the
    demo. A file must be a regular file of at most :data:`k37.sim.files.MAX_INPUT_BYTES`.
    ``frontend`` reads the program (:data:`k37.firmware_model.gcode.canon.FRONTENDS`);
    ``arc_tolerance`` (LSB), if given, replaces the job's.

    Raises
    ------
    JobError
        The file cannot be read, is not valid TOML, or holds an unknown key or a bad value;
        or its program neither moves nor dwells.
    GcodeError
        The program is bad (naming its file, line and column).
    """
    if path is None:
        return demo_job()
    path = Path(path)
    text = _read(path, str(path))
    if path.suffix.lower() != ".toml":  # G-code, from a file or from stdin ("-")
        name = "stdin" if str(path) == STDIO else path.stem
        job = gcode_job(name, text, str(path), frontend=frontend, arc_tolerance=arc_tolerance)
    else:
        job = _TomlJob(path, read_toml(text, str(path)), text, frontend, arc_tolerance).job()
    if not any(isinstance(item, Dwell) or (isinstance(item, Move) and not (
            isinstance(item, Line) and item.end == item.start)) for item in job.program.items):
        # a dwell holds the machine still for a while: a run of its servos (a load step)
        raise JobError(f"{job.program.source}: no motion in the program (no move, arc, "
                       f"canned cycle or dwell: nothing for the machine to run)")
    return job


def _read(path: Path, name: str) -> str:
    """The text of a job or program file (a regular file, or stdin for ``-``, of at most
    :data:`k37.sim.files.MAX_INPUT_BYTES`); a :class:`JobError` naming ``name`` otherwise."""
    try:
        # a UTF-8 byte-order mark is skipped
        return read_input_text(path, encoding="utf-8-sig")
    except InputError as e:
        raise JobError(f"{name}: {e}") from None
    except UnicodeDecodeError as e:
        raise JobError(f"{name}: not UTF-8 text (byte {e.start})") from None
    except OSError as e:
        raise JobError(f"{name}: cannot read: {e.strerror or e}") from None
    except ValueError as e:  # a path no system can open (a NUL in it)
        raise JobError(f"{name}: cannot read: {e}") from None


_TOML_POSITION = re.compile(r"^(.*) \(at line (\d+), column (\d+)\)$")


def read_toml(text: str, source: str) -> dict[str, Any]:
    """TOML ``text`` as a dict; a syntax error is a :class:`JobError` at ``source:line:col``."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        m = _TOML_POSITION.match(str(e))
        where = f"{m.group(2)}:{m.group(3)}: {m.group(1)}" if m else f" {e}"
        raise JobError(f"{source}:{where}") from None


def job_from_data(path: Path, data: dict[str, Any]) -> Job:
    """The job of TOML ``data`` as if read from ``path`` (its errors name ``path``; a
    ``program.file`` is relative to its folder)."""
    return _TomlJob(path, data).job()


class _TomlJob:
    """One TOML job file being loaded; every error names the file."""

    def __init__(self, path: Path, data: dict[str, Any], text: str | None = None,
                 frontend: str = "builtin", arc_tolerance: float | None = None):
        self.path = path
        self.frontend = frontend
        self.arc_tolerance = arc_tolerance
        self.source = str(path)
        self.data = data
        self.text = text  # the file's text, when there is one (for an inline program's lines)

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
        self.known(self.data, ("name", "machine", "servo", "program", "run", "contour"), "")
        name = self.data.get("name", self.path.stem)
        if not isinstance(name, str) or not name:
            self.fail(f"name must be a non-empty string, not {name!r}")
        table = self.table(self.data, "machine", (*_names(MachineConfig), *ALL_AXES))
        machine = self.build(MachineConfig,
                             {k: v for k, v in table.items() if k not in ALL_AXES}, "machine.")
        machine, program = self.program(machine, axes_given="axes" in table)
        for axis in ALL_AXES:
            if axis in table and axis not in machine.axis_names:
                self.fail(f"machine.{axis}: the machine has {machine.axes} axes "
                          f"({', '.join(machine.axis_names)}); set machine.axes = 3 for a Z "
                          f"axis")
        axis_accel = {axis: self.build(AxisAccelConfig,
                                       self.table(table, axis, _names(AxisAccelConfig),
                                                  "machine."), f"machine.{axis}.")
                      for axis in machine.axis_names if axis in table}
        servo = self.servo(machine)
        run = self.build(RunConfig, self.table(self.data, "run", _names(RunConfig)), "run.")
        contour = self.build(ContourConfig, self.table(self.data, "contour",
                                                       _names(ContourConfig)), "contour.")
        try:
            return Job(name, machine, servo, program, run, axis_accel, contour)
        except ValueError as e:
            self.fail(str(e))

    def servo(self, machine: MachineConfig) -> dict[str, ServoConfig]:
        """Every axis's servo: ``[servo]``, each key overridden by ``[servo.x]``,
        ``[servo.y]`` (and ``[servo.z]`` on three axes); each table is checked against the
        plant on ``machine``, naming its own keys."""
        names = machine.axis_names
        table = self.table(self.data, "servo", (*_names(ServoConfig), *ALL_AXES))
        for axis in ALL_AXES:
            if axis in table and axis not in names:
                self.fail(f"servo.{axis}: the machine has {machine.axes} axes "
                          f"({', '.join(names)}); set machine.axes = 3 for a Z axis")
        common = {k: v for k, v in table.items() if k not in ALL_AXES}
        self.plant(machine, common, "servo.")
        axes = {axis: self.table(table, axis, _names(ServoConfig), "servo.") for axis in names}
        return {axis: self.plant(machine, {**common, **axes[axis]}, f"servo.{axis}.")
                for axis in names}

    def plant(self, machine: MachineConfig, values: dict, prefix: str) -> ServoConfig:
        servo = self.build(ServoConfig, values, prefix)
        try:
            check_servo(machine, servo)
        except (TypeError, ValueError) as e:
            self.fail(f"{prefix}{e}")
        return servo

    def program(self, machine: MachineConfig, axes_given: bool
                ) -> tuple[MachineConfig, Program]:
        """The program, and the machine it runs on (see
        :func:`k37.firmware_model.job.parse_for_machine` for ``axes_given``)."""
        if "program" not in self.data:
            self.fail("missing [program] table (give gcode or file)")
        table = self.table(self.data, "program", ("gcode", "file", "arc_tolerance", "tools"))
        if ("gcode" in table) == ("file" in table):
            self.fail("program must give exactly one of gcode (inline) and file")
        try:
            tolerance = OrAbsent(ARC_TOLERANCE_LIMIT).check(
                "arc_tolerance", table.get("arc_tolerance", self.arc_tolerance))
            if self.arc_tolerance is not None:
                tolerance = self.arc_tolerance
        except (TypeError, ValueError) as e:
            self.fail(f"program.{e}")
        tools = self.tools(table.get("tools", {}))
        key = "gcode" if "gcode" in table else "file"
        if not isinstance(table[key], str):
            self.fail(f"program.{key} must be a string, not {table[key]!r}")
        origin = None
        if key == "gcode":
            text, source = table["gcode"], f"{self.source}:program.gcode"
            if self.text is not None:
                origin = self.source, _inline_program_line(self.text)
        else:
            file = self.path.parent / table["file"]
            source = str(file)
            text = _read(file, f"{self.source}: program.file {source}")
        return parse_for_machine(machine, text, source=source, axes_given=axes_given,
                                 frontend=self.frontend, arc_tolerance=tolerance,
                                 origin=origin, tools=tools)

    def tools(self, table: Any) -> dict[int, Tool]:
        """``program.tools``: tool number -> its length (mm), or a table of its ``length`` and
        ``diameter`` (mm, each optional, default zero)."""
        if not isinstance(table, dict):
            self.fail(f"program.tools must be a table of tool number = length (mm) or "
                      f"{{ length, diameter }}, not {table!r}")
        tools = {}
        for number, value in table.items():
            key = f"program.tools.{number}"
            if not (number.isascii() and number.isdigit()):
                self.fail(f"{key}: a tool number is a non-negative integer")
            given = isinstance(value, dict)
            entry = self.table(table, number, ("length", "diameter"), "program.tools.") \
                if given else {"length": value}
            try:
                tools[int(number)] = Tool(
                    Limit(unit="mm").check(f"{key}.length" if given else key,
                                           entry.get("length", 0.0)),
                    TOOL_DIAMETER.check(f"{key}.diameter", entry.get("diameter", 0.0)))
            except (TypeError, ValueError) as e:
                self.fail(str(e))
        return tools

_INLINE_PROGRAM = re.compile(r"""^[ \t]*gcode[ \t]*=[ \t]*("{3}|'{3}|"|')(\r?\n)?""", re.M)


def _inline_program_line(text: str) -> int:
    """The TOML file's line of an inline program's first line (a multi-line string starts
    on the line after its quotes when they end their line)."""
    section = re.search(r"^[ \t]*\[program\]", text, re.M)
    match = _INLINE_PROGRAM.search(text, section.end() if section else 0)
    if match is None:
        return 1
    return text.count("\n", 0, match.start()) + 1 + (match.group(2) is not None)


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
    for table, config in (("machine", machine), ("servo", ServoConfig()), ("run", RunConfig()),
                          ("contour", ContourConfig())):
        for f in fields(config):
            valid: Valid = config.valid(f.name)
            if table == "servo" and f.name in plant:  # type checked there, range the plant's
                valid = OrAbsent(plant[f.name]) if f.default is None else plant[f.name]
            default = "absent" if f.default is None else _toml_value(f.default)
            rows.append(f"| {table}.{f.name} | {default} | {valid.describe()} | "
                        f"{f.metadata['doc']} |")
    for f in fields(AxisAccelConfig):
        rows.append(f"| machine.{'/'.join(ALL_AXES)}.{f.name} | the [machine] value | "
                    f"{AxisAccelConfig().valid(f.name).describe()} | {f.metadata['doc']} |")
    rows += ["| servo.x.*, servo.y.*, servo.z.* | the [servo] values | as in [servo] | per-axis "
             "servo overrides (servo.z on three axes) |",
             "| program.gcode | | a string | the program, inline (give gcode or file) |",
             "| program.file | | a string | the program's file, relative to the job file |",
             f"| program.arc_tolerance | absent | {ARC_TOLERANCE_LIMIT.describe()}, or absent | "
             f"largest difference (LSB) between an arc's start and end radii; absent: "
             f"LinuxCNC's, {ARC_TOLERANCE_MM[False]:g} mm in G21, "
             f"{ARC_TOLERANCE_MM[True] / 25.4:g} in in G20 |",
             "| program.tools | absent | a table of tool number = length (mm), or = { length, "
             f"diameter }} (mm, each optional, default 0; diameter {TOOL_DIAMETER.describe()}) "
             "| the tool table: lengths for G43, diameters for G41/G42 (a tool not in it is "
             "an error); absent: every length and diameter zero |"]
    return "\n".join(rows) + "\n"
