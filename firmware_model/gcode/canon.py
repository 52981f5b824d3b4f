"""The LinuxCNC front end: full RS-274/NGC through LinuxCNC's own interpreter.

``rs274 -g FILE OUT`` (Debian's ``linuxcnc-uspace``) resolves parameters, expressions, O-word
subroutines and loops, offsets and canned cycles, and writes the canonical machine commands
one per line (``   12 N..... STRAIGHT_FEED(1.0000, 2.0000, 0.0000, ...)``). :func:`parse_canon`
turns that text into the same :class:`~k37.firmware_model.motion.program.Program` the built-in front
end builds, through the same :class:`~k37.firmware_model.motion.planner.Planner` (exact ends,
correction lines, events); :func:`parse_linuxcnc` runs ``rs274`` on a program first.

Canonical positions are in the program's coordinate system and length units: the machine
position adds the G5x, G92 and tool length offsets the interpreter announces
(``SET_G5X_OFFSET``, ``SET_G92_OFFSET``, ``USE_TOOL_LENGTH_OFFSET``), as LinuxCNC's motion
planner does. An item's line is the canonical command's N word when the block has one, else
the command's sequence number in ``rs274``'s output (the interpreter does not print source
lines). Commands with no effect here (``SET_XY_ROTATION(0)``, ``SET_MOTION_CONTROL_MODE``,
``COMMENT``...) are skipped; a rotation or an unknown motion command is an error.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
from decimal import ROUND_HALF_UP, Decimal
from pathlib import Path

from k37.firmware_model.gcode.parser import GcodeError, parse
from k37.firmware_model.gcode.tool_table import ToolTable, tool_entry
from k37.firmware_model.gcode.units import (
    ARC_TOLERANCE_LIMIT,
    ARC_TOLERANCE_MM,
    AXES_LIMIT,
    INCH_MM,
    LSB_MM_LIMIT,
)
from k37.firmware_model.motion.planner import Planner
from k37.firmware_model.motion.program import Program
from k37.hdl.common.constants import PLANE_AXES

__all__ = ["FRONTENDS", "RS274", "parse_canon", "parse_linuxcnc", "rs274_canon"]

#: The interpreter's program name.
RS274 = "rs274"
#: Seconds ``rs274`` may take for one program.
RS274_TIMEOUT_S = 60

_COMMAND = re.compile(r"^\s*(\d+)\s+(N\S*)\s+([A-Z_0-9]+)\((.*)\)\s*$")
_PLANES = {"CANON_PLANE_XY": 17, "CANON_PLANE_XZ": 18, "CANON_PLANE_YZ": 19}
_EVENTS = {"START_SPINDLE_CLOCKWISE": ("M03", "spindle_cw"),
           "START_SPINDLE_COUNTERCLOCKWISE": ("M04", "spindle_ccw"),
           "STOP_SPINDLE_TURNING": ("M05", "spindle_stop"),
           "MIST_ON": ("M07", "coolant_mist"), "FLOOD_ON": ("M08", "coolant_flood"),
           "MIST_OFF": ("M09", "coolant_off"), "FLOOD_OFF": ("M09", "coolant_off"),
           "CHANGE_TOOL": ("M06", "tool_change"), "PROGRAM_STOP": ("M00", "program_stop"),
           "OPTIONAL_PROGRAM_STOP": ("M01", "optional_stop"),
           "SET_SPINDLE_SPEED": ("S", "spindle_speed"), "SELECT_TOOL": ("T", "tool_select")}
_SKIPPED = {"SET_FEED_REFERENCE", "ON_RESET", "SET_MOTION_CONTROL_MODE", "SET_NAIVECAM_TOLERANCE",
            "COMMENT", "SET_FEED_MODE", "SET_SPINDLE_MODE", "PALLET_SHUTTLE", "MESSAGE",
            "ENABLE_FEED_OVERRIDE", "ENABLE_SPEED_OVERRIDE", "DISABLE_FEED_OVERRIDE",
            "DISABLE_SPEED_OVERRIDE", "ENABLE_ADAPTIVE_FEED", "DISABLE_ADAPTIVE_FEED",
            "ENABLE_FEED_HOLD", "DISABLE_FEED_HOLD", "SET_CUTTER_RADIUS_COMPENSATION",
            "START_CUTTER_RADIUS_COMPENSATION", "STOP_CUTTER_RADIUS_COMPENSATION",
            "SET_TRAVERSE_RATE", "START_SPEED_FEED_SYNCH", "STOP_SPEED_FEED_SYNCH",
            "SET_SPINDLE_FORCE", "ORIENT_SPINDLE", "WAIT_SPINDLE_ORIENT_COMPLETE",
            "USE_NO_SPINDLE_FORCE", "SET_TOOL_TABLE_ENTRY", "CHANGE_TOOL_NUMBER",
            "SET_BLOCK_DELETE", "SET_OPTIONAL_PROGRAM_STOP", "TURN_PROBE_OFF", "TURN_PROBE_ON",
            "START_CHANGE", "FINISH", "LOGOPEN", "LOGAPPEND", "LOGCLOSE", "LOG"}
#: Tool numbers written to rs274's tool table (length zero) when a job gives none.
_DEFAULT_TOOLS = range(1000)


class _CanonError(ValueError):
    pass


def _numbers(args: str) -> list[Decimal]:
    return [Decimal(a) for a in re.split(r"[,\s]+", args.strip()) if a]


class _Canon:
    def __init__(self, planner: Planner, lsb_mm: float, tolerance: float | None):
        self.planner = planner
        self.lsb_size = Decimal(repr(lsb_mm))
        self.tolerance = tolerance
        self.inch = False
        self.plane = 17
        self.feed: float | None = None
        #: A SET_FEED_RATE's number not yet given its units (see :meth:`command`).
        self.feed_number: Decimal | None = None
        self.g5x = [Decimal(0)] * 3
        self.g92 = [Decimal(0)] * 3
        self.tool = [Decimal(0)] * 3
        self.end = False

    def mm(self, value: Decimal) -> Decimal:
        """A length in the program's units, in mm."""
        return value * INCH_MM if self.inch else value

    def machine(self, axis: int, value: Decimal) -> int:
        """The machine position (LSB) of a canonical coordinate: plus the offsets (kept in
        mm: they stay where they were set when the units change)."""
        mm = self.mm(value) + self.g5x[axis] + self.g92[axis] + self.tool[axis]
        return int((mm / self.lsb_size).to_integral_value(rounding=ROUND_HALF_UP))

    def command(self, line: int, name: str, args: str) -> None:
        planner = self.planner
        if name == "USE_LENGTH_UNITS":
            self.inch = "INCH" in args
            self.units_of_feed()
        elif name == "SET_FEED_RATE":
            # rs274 writes a block's F before its G20/G21: the number is in the units of the
            # first USE_LENGTH_UNITS after it, or of the move that comes first
            self.units_of_feed()
            self.feed_number = _numbers(args)[0]
        elif name in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED"):
            xyz = _numbers(args)[:3]
            target = tuple(self.machine(a, v) for a, v in enumerate(xyz))
            feed = None if name == "STRAIGHT_TRAVERSE" else self.positive_feed()
            planner.line(line, target, feed)
        elif name == "ARC_FEED":
            self.arc(line, _numbers(args))
        elif name == "DWELL":
            planner.dwell(line, float(_numbers(args)[0]))
        elif name == "SELECT_PLANE":
            self.plane = _PLANES[args.strip()]
        elif name == "SET_G5X_OFFSET":
            self.g5x = [self.mm(v) for v in _numbers(args)[1:4]]
        elif name == "SET_G92_OFFSET":
            self.g92 = [self.mm(v) for v in _numbers(args)[:3]]
        elif name == "USE_TOOL_LENGTH_OFFSET":
            self.tool = [self.mm(v) for v in _numbers(args)[:3]]
        elif name == "SET_XY_ROTATION":
            if _numbers(args)[0] != 0:
                raise _CanonError("a rotated coordinate system (G10 R) is unsupported")
        elif name in _EVENTS:
            word, kind = _EVENTS[name]
            value = _numbers(args)[-1] if word in "ST" and args.strip() else None
            planner.event(line, word if value is None else f"{word}{float(value):g}", kind,
                          None if value is None else float(value))
        elif name == "PROGRAM_END":
            self.end = True
        elif name not in _SKIPPED:
            raise _CanonError(f"canonical command {name} is unsupported")

    def units_of_feed(self) -> None:
        """The feed rate (mm/min) of the SET_FEED_RATE number waiting for its units, in the
        units now."""
        if self.feed_number is not None:
            self.feed = float(self.mm(self.feed_number))
            self.feed_number = None

    def positive_feed(self) -> float:
        self.units_of_feed()
        if not self.feed:
            raise _CanonError("a feed move with feed rate 0")
        return self.feed

    def arc(self, line: int, v: list[Decimal]) -> None:
        first_end, second_end, first_c, second_c, rotation, normal_end = v[:6]
        first, second, normal = PLANE_AXES[self.plane]
        if abs(rotation) != 1:
            raise _CanonError(f"an arc of {abs(rotation)} turns is unsupported")
        target = [0, 0, 0]
        target[first] = self.machine(first, first_end)
        target[second] = self.machine(second, second_end)
        target[normal] = self.machine(normal, normal_end)
        centre = (self.machine(first, first_c), self.machine(second, second_c))
        tolerance = self.tolerance
        if tolerance is None:
            tolerance = ARC_TOLERANCE_MM[self.inch] / float(self.lsb_size)
        self.planner.arc(line, (target[0], target[1], target[2]), centre, self.plane,
                         rotation < 0, self.positive_feed(), tolerance=tolerance)


def parse_canon(canon: str, *, source: str = "<canon>", lsb_mm: float = 0.001,
                sqrt2: bool = True, arc_tolerance: float | None = None, axes: int = 2,
                origin: tuple[str, int] | None = None) -> Program:
    """A program from ``rs274``'s canonical commands (its ``OUT`` file's text); the
    keywords as :func:`k37.firmware_model.gcode.parser.parse`'s. Raises
    :class:`~k37.firmware_model.gcode.parser.GcodeError`, naming the command's line."""
    lsb_mm = LSB_MM_LIMIT.check("lsb_mm", lsb_mm)
    if arc_tolerance is not None:
        arc_tolerance = ARC_TOLERANCE_LIMIT.check("arc_tolerance", arc_tolerance)
    axes = AXES_LIMIT.check("axes", axes)
    planner = Planner(axes=axes, sqrt2=bool(sqrt2), lsb_mm=lsb_mm)
    canon_state = _Canon(planner, lsb_mm, arc_tolerance)
    errors = []
    sequence = {}
    for number, text in enumerate(canon.splitlines(), start=1):
        m = _COMMAND.match(text)
        if m is None:
            continue
        n_word = m.group(2)[1:]
        line = int(n_word) if n_word.isdigit() else int(m.group(1))
        if n_word.isdigit():  # the block's line is its N-word: labelled so
            sequence[line] = line
        try:
            canon_state.command(line, m.group(3), m.group(4))
        except (ArithmeticError, LookupError, ValueError) as e:  # PlanError, _CanonError too
            errors.append((number, 1, f"{m.group(3)}: {e}"))
    name = origin[0] if origin else source
    if errors:
        raise GcodeError(f"{name} (rs274 output)", errors[:20])
    return Program(tuple(planner.items), canon_state.end, source, lsb_mm, bool(sqrt2),
                   arc_tolerance, axes, origin, sequence=sequence)


def rs274_canon(text: str, *, source: str = "<gcode>", origin: tuple[str, int] | None = None,
                tools: ToolTable | None = None) -> str:
    """Run LinuxCNC's ``rs274`` on a program; its canonical commands. ``tools``: the tool
    table (mm) by number, written as ``rs274``'s (which it reads in inches); none: tools 0 to
    999 of length and diameter zero, as the built-in front end's. Raises
    :class:`~k37.firmware_model.gcode.parser.GcodeError` when it is not installed or refuses the
    program (its message, at the line of the block it quotes)."""
    name, first = origin or (source, 1)
    exe = shutil.which(RS274)
    if exe is None:
        raise GcodeError(name, [(first, 1, "--frontend linuxcnc needs LinuxCNC's interpreter "
                                         "rs274 on the PATH (Debian: apt-get install "
                                         "linuxcnc-uspace)")])
    with tempfile.TemporaryDirectory(prefix="k37-rs274-") as tmp:
        program, out = Path(tmp) / "program.ngc", Path(tmp) / "canon.txt"
        program.write_text(text.removeprefix("\ufeff"), encoding="utf-8")
        table = Path(tmp) / "tools.tbl"
        table.write_text("".join(
            f"T{n} P{n} Z{Decimal(repr(t.length)) / INCH_MM} "
            f"D{Decimal(repr(t.diameter)) / INCH_MM} ;\n"
            for n, t in ((n, tool_entry(v)) for n, v in
                         (tools or dict.fromkeys(_DEFAULT_TOOLS, 0.0)).items())))
        try:
            # rs274 keeps its tool data in a file mapped from $HOME (.tool.mmap), which runs
            # at the same time would share and clobber: each run gets its own HOME
            run = subprocess.run([exe, "-t", str(table), "-g", str(program), str(out)],
                                 stdin=subprocess.DEVNULL,
                                 capture_output=True, text=True, timeout=RS274_TIMEOUT_S,
                                 cwd=_folder(name) or tmp, check=False,
                                 env={**os.environ, "HOME": tmp})
        except subprocess.TimeoutExpired:
            raise GcodeError(name, [(first, 1, f"rs274 took more than {RS274_TIMEOUT_S} s")]) \
                from None
        canon = out.read_text(errors="replace") if out.exists() else ""
    if run.returncode != 0:
        line, col, message = _rs274_error(run.stdout + run.stderr, text)
        raise GcodeError(name, [(line + first - 1, col, message)])
    return canon


def _folder(name: str) -> Path | None:
    """The folder of the file a program is written in (``rs274`` looks for subroutine files,
    ``o<name> call``, in its working folder), or None."""
    path = Path(name)
    return path.parent if path.is_file() else None


def _rs274_error(output: str, text: str) -> tuple[int, int, str]:
    """rs274's message (the line before the quoted block) at the quoted block's line."""
    lines = [ln.replace("executing", "").strip() for ln in output.splitlines()]
    lines = [ln for ln in lines if ln]
    if not lines:
        return 1, 1, "rs274 refused the program"
    block = lines[-1]
    message = lines[-2] if len(lines) > 1 else block
    source_lines = [ln.strip() for ln in text.removeprefix("\ufeff").split("\n")]
    line = source_lines.index(block) + 1 if block in source_lines else 1
    return line, 1, f"rs274: {message}"


def parse_linuxcnc(text: str, *, source: str = "<gcode>",
                   tools: ToolTable | None = None, **kwargs) -> Program:
    """:func:`parse_canon` of ``rs274``'s output for the program ``text``; the keywords as
    :func:`k37.firmware_model.gcode.parser.parse`'s."""
    canon = rs274_canon(text, source=source, origin=kwargs.get("origin"), tools=tools)
    return parse_canon(canon, source=source, **kwargs)


#: The front ends by name (``--frontend``): the built-in one needs nothing outside pip.
FRONTENDS = {"builtin": parse, "linuxcnc": parse_linuxcnc}
