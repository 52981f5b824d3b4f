"""The built-in G-code front end: RS-274 text to K3701 blocks in machine LSB units.

:func:`parse` reads a program and returns a
:class:`~k37.firmware_model.motion.program.Program`: its
:class:`~k37.firmware_model.motion.program.Line`,
:class:`~k37.firmware_model.motion.program.Arc`,
:class:`~k37.firmware_model.motion.program.Dwell` and
:class:`~k37.firmware_model.motion.program.Event` items, each ready for the firmware model. The
words it takes, their modal groups and meanings are the tables of
:mod:`k37.firmware_model.gcode.words` (``docs/gcode.md``); the lexer
(:mod:`k37.firmware_model.gcode.lex`) says how a line is read. In short, what CAM post-processors
emit: G00-G03 (I/J/K or R arcs, helices on three axes), G04, G17-G19, G20/G21, G28/G30, G40,
G41.1/G42.1, G43/G49, G53, G54-G59, G61/G64, G80-G83 (L repeats), G90/G91, G90.1/G91.1,
G92/G92.1, G93/G94, G98/G99, F, S, T, H, D, N, M00-M09, M30 and M70-M73.

Semantics (RS-274/NGC's, as LinuxCNC's ``rs274``; the decisions are in the README):

* Within a block, words act in RS-274's order: F, S, T, M06, spindle and coolant M codes,
  G04, the modal settings (plane, units, tool length, coordinate system, distance modes),
  G28/G30/G92/G53, the motion, then M00/M01/M02/M30. Motion modes are modal (a block with
  only coordinates repeats the last G00-G03 or canned cycle).
* Coordinates are rounded to the nearest LSB (halves away from zero) with decimal
  arithmetic, each absolute coordinate on its own, so rounding never accumulates. Every
  block ends exactly on its programmed point (an arc's chip end an LSB or two off is followed
  by the host's correction line, :mod:`k37.firmware_model.motion.program`).
* The machine position is the program's start (the origin). G54-G59 offsets are zero; G92
  offsets, the tool length (Z) and G53 act as in RS-274/NGC. G28/G30 go to the origin.
* Canned cycles are expanded into moves as LinuxCNC does (G83 rapids back down to 0.254 mm,
  0.010 in, above the last peck).
* Arc ends must lie within the arc tolerance of the circle (default LinuxCNC's 0.028 mm in
  G21, 0.0028 in in G20).
* On a two-axis machine a block that moves Z (a Z word away from the current Z, a G18/G19
  or helical arc, a canned cycle) is an error naming ``machine.axes = 3``.

The RS-274/NGC language (parameters, expressions, O-word subroutines and loops, polar
coordinates, messages) is evaluated by :mod:`k37.firmware_model.gcode.ngc`, which hands the
interpreter (:mod:`k37.firmware_model.gcode.interpreter`) each line's words with their values,
line and column.

Every error of a program is reported once (up to :data:`MAX_ERRORS`), each ``file:line:col:
message``; a line with an error does nothing else. An error in an O-word structure or its
control flow stops the program there. Errors are :class:`GcodeError`.
"""
from __future__ import annotations

import contextlib
import gc
from collections.abc import Iterator

from k37.firmware_model.gcode import ngc
from k37.firmware_model.gcode.block_words import BlockError
from k37.firmware_model.gcode.interpreter import Interpreter
from k37.firmware_model.gcode.lex import LexError, Word, read_line
from k37.firmware_model.gcode.ngc_state import InterpreterHost, TooManyErrors
from k37.firmware_model.gcode.ngc_structure import NgcError
from k37.firmware_model.gcode.tool_table import ToolTable
from k37.firmware_model.gcode.units import ARC_TOLERANCE_LIMIT, AXES_LIMIT, LSB_MM_LIMIT, MAX_ERRORS
from k37.firmware_model.motion.planner import Planner
from k37.firmware_model.motion.program import Program

__all__ = ["GcodeError", "names_third_axis", "parse"]


class GcodeError(ValueError):
    """A program the front end refuses. ``str()`` is one ``source:line:col: message`` line
    per error; ``errors`` lists them as (line, col, message); ``line``, ``col`` and
    ``message`` are the first's."""

    def __init__(self, source: str, errors: list[tuple[int, int, str]]):
        super().__init__("\n".join(f"{source}:{ln}:{col}: {msg}" for ln, col, msg in errors))
        self.source = source
        self.errors = errors
        self.line, self.col, self.message = errors[0]


def names_third_axis(text: str) -> bool:
    """Whether a program's words name the third axis: a Z word, or G18/G19 (an arc plane with
    Z). Lines the lexer cannot read are passed over."""
    for line in text.split("\n"):
        compact = "".join(line.split()).lower()
        if "z" not in compact and "18" not in compact and "19" not in compact:
            continue  # (blanks are nothing in a word: "G 1 8" is G18)
        try:
            words = read_line(line).words
        except LexError:
            continue
        if any(w.letter == "Z" or (w.letter == "G" and isinstance(w, Word)
                                   and w.value in (18, 19)) for w in words):
            return True
    return False


@contextlib.contextmanager
def _collector_paused() -> Iterator[None]:
    """Python's cycle collector off while a program is read: reading makes many objects that
    live until the end and no cycles, and the collector's passes over them took a fifth of
    the time. It is back on (if it was) when reading ends, however it ends."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def parse(text: str, *, source: str = "<gcode>", lsb_mm: float = 0.001, sqrt2: bool = True,
          arc_tolerance: float | None = None, axes: int = 2,
          tools: ToolTable | None = None,
          origin: tuple[str, int] | None = None) -> Program:
    """Parse a G-code program into K3701 blocks.

    Parameters
    ----------
    text : str
        The program (a leading UTF-8 byte-order mark is skipped).
    source : str
        Name used in error messages (a file name).
    lsb_mm : float
        Millimetres per LSB (1 um by default), in :data:`LSB_MM_LIMIT`.
    sqrt2 : bool
        The machine's sqrt(2) control setting: it decides the FP counts of the plans.
    arc_tolerance : float or None
        Largest difference (LSB) between the start's and the end's distances from an arc's
        centre, in :data:`ARC_TOLERANCE_LIMIT`; None: LinuxCNC's
        (:data:`~k37.firmware_model.gcode.units.ARC_TOLERANCE_MM`).
    axes : int
        The machine's axes: 2 (X, Y) or 3 (X, Y, Z).
    tools : mapping or None
        The tool table by tool number: each tool's length (G43) and diameter (G41/G42), a
        :class:`~k37.firmware_model.gcode.tool_table.Tool` or a plain length (mm); None: every
        length and diameter is zero.
    origin : (str, int) or None
        The file and line the text's first line is on, for error messages (a program inline
        in a job file); None: ``source``, line 1. Items keep the program's own lines.

    Raises
    ------
    GcodeError
        For anything the front end or the K3701 cannot run: every error (up to
        :data:`MAX_ERRORS`), each naming line and column.
    TypeError, ValueError
        ``lsb_mm``, ``arc_tolerance`` or ``axes`` is out of its limit.
    """
    lsb_mm = LSB_MM_LIMIT.check("lsb_mm", lsb_mm)
    if arc_tolerance is not None:
        arc_tolerance = ARC_TOLERANCE_LIMIT.check("arc_tolerance", arc_tolerance)
    axes = AXES_LIMIT.check("axes", axes)
    planner = Planner(axes=axes, sqrt2=bool(sqrt2), lsb_mm=lsb_mm)
    interp = Interpreter(planner, lsb_mm=lsb_mm, tolerance=arc_tolerance, tools=tools)
    host = InterpreterHost(interp, BlockError, MAX_ERRORS)
    try:
        with _collector_paused():
            ngc.run(text.removeprefix("\ufeff").split("\n"), host)
    except NgcError as e:
        host.errors.append((e.line, e.col, e.message))
    except TooManyErrors:
        pass
    except RecursionError:
        host.errors.append((interp.line_no or 1, 1, "the program nests too deep to run"))
    errors, notes = host.errors, host.notes
    name, first = origin or (source, 1)
    if errors:
        raise GcodeError(name, [(line + first - 1, col, msg) for line, col, msg in errors])
    notes = sorted([*planner.notes, *notes], key=lambda note: note[0])
    return Program(tuple(planner.items), interp.end, source, lsb_mm, bool(sqrt2),
                   arc_tolerance, axes, origin,
                   notes=tuple(f"{name}:{line + first - 1}: {text}" for line, text in notes),
                   sequence=interp.sequence)
