"""The built-in G-code front end: RS-274 text to K3701 blocks in machine LSB units.

:func:`parse` reads a program and returns a :class:`~firmware_model.gcode.program.Program`: its
:class:`Line`, :class:`Arc`, :class:`Dwell` and :class:`Event` items, each ready for the
firmware model. The words it takes, their modal groups and meanings are the tables of
:mod:`firmware_model.gcode.words` (``docs/gcode.md``); the lexer (:mod:`firmware_model.gcode.lex`)
says how a line is read. In short, what CAM post-processors emit: G00-G03 (I/J/K or R arcs,
helices on three axes), G04, G17-G19, G20/G21, G28/G30, G40, G43/G49, G53, G54-G59, G61/G64,
G80-G83, G90/G91, G90.1/G91.1, G92/G92.1, G94, G98/G99, F, S, T, H, N, M00-M09 and M30.

Semantics (RS-274/NGC's, as LinuxCNC's ``rs274``; the decisions are in the README):

* Within a block, words act in RS-274's order: F, S, T, M06, spindle and coolant M codes,
  G04, the modal settings (plane, units, tool length, coordinate system, distance modes),
  G28/G30/G92/G53, the motion, then M00/M01/M02/M30. Motion modes are modal (a block with
  only coordinates repeats the last G00-G03 or canned cycle).
* Coordinates are rounded to the nearest LSB (halves away from zero) with decimal
  arithmetic, each absolute coordinate on its own, so rounding never accumulates. Every
  block ends exactly on its programmed point (an arc's chip end an LSB or two off is followed
  by the host's correction line, :mod:`firmware_model.gcode.program`).
* The machine position is the program's start (the origin). G54-G59 offsets are zero; G92
  offsets, the tool length (Z) and G53 act as in RS-274/NGC. G28/G30 go to the origin.
* Canned cycles are expanded into moves as LinuxCNC does (G83 rapids back down to 0.254 mm,
  0.010 in, above the last peck).
* Arc ends must lie within the arc tolerance of the circle (default LinuxCNC's 0.028 mm in
  G21, 0.0028 in in G20).
* On a two-axis machine a block that moves Z (a Z word away from the current Z, a G18/G19
  or helical arc, a canned cycle) is an error naming ``machine.axes = 3``.

The RS-274/NGC language (parameters, expressions, O-word subroutines and loops, polar
coordinates, messages) is evaluated by :mod:`firmware_model.gcode.ngc`, which hands this
interpreter each line's words with their values, line and column.

Every error of a program is reported once (up to :data:`MAX_ERRORS`), each ``file:line:col:
message``; a line with an error does nothing else. An error in an O-word structure or its
control flow stops the program there. Errors are :class:`GcodeError`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from decimal import ROUND_HALF_UP, Decimal

from firmware_model.gcode import ngc
from firmware_model.gcode.lex import LexError, Word, read_line
from firmware_model.gcode.ngc_state import InterpreterHost, TooManyErrors
from firmware_model.gcode.program import (
    PLANE_AXES,
    Arc,
    Dwell,
    Event,
    Item,
    Line,
    Move,
    Parabola,
    PlanError,
    Planner,
    Program,
)
from firmware_model.gcode.splines import Nurbs, bezier
from firmware_model.gcode.words import (
    G_CODES,
    LETTERS,
    M_CODES,
    REFUSED_G,
    REFUSED_M,
    Code,
    code_key,
)
from hdl.common.params import Limit
from hdl.k3701.block import COORD_MAX

__all__ = ["ARC_TOLERANCE_LIMIT", "ARC_TOLERANCE_MM", "AXES_LIMIT", "INCH_MM", "LSB_MM_LIMIT",
           "MAX_ERRORS", "MAX_PECKS", "Arc", "Dwell", "Event", "GcodeError", "Item", "Line", "Move",
           "Parabola", "Program", "names_third_axis", "parse"]

#: Millimetres per inch (G20).
INCH_MM = Decimal("25.4")
#: The most pecks a G83 hole may take (each is three moves): a deeper hole or a smaller Q is
#: refused before it is expanded.
MAX_PECKS = 10_000
#: Default arc tolerance (mm) in G21 and G20: LinuxCNC's (0.028 mm, 0.0028 in): how far the
#: end's distance from the centre may differ from the start's.
ARC_TOLERANCE_MM = {False: 0.028, True: 0.0028 * 25.4}
#: The arc tolerances (LSB) the front end accepts instead of the default.
ARC_TOLERANCE_LIMIT = Limit(0, unit="LSB")
#: The LSB lengths it converts coordinates with.
LSB_MM_LIMIT = Limit(0, low_open=True, unit="mm")
#: Machine axes: X, Y (the paper's machine) or X, Y, Z.
AXES_LIMIT = Limit(2, 3, integer=True)
#: Most errors reported for one program.
MAX_ERRORS = 20
#: G83's rapid stop above the last peck: LinuxCNC's G83_RAPID_DELTA, 0.010 in.
G83_CLEARANCE_MM = Decimal("0.254")

_HINTS = {**dict.fromkeys("ABC", " (K37's axes are X, Y and Z)"),
          **dict.fromkeys("UVW", " (K37's axes are X, Y and Z)"),
          "D": " (no cutter radius compensation: G40 only)",
          "L": " (no G10 or canned-cycle repeats)", "E": ""}
#: What R and Q are for (in the error for one used elsewhere).
_USES = {"R": "arcs and canned cycles", "Q": "G83 (peck depth) and G64"}
_OFFSET_LETTERS = "IJK"
_AXIS_LETTERS = "XYZ"


def _g_name(key: int) -> str:
    """A G code as written from its table key (tenths): 10 is G01, 61 is G06.1."""
    return f"G{key // 10:02d}" + (f".{key % 10}" if key % 10 else "")


class GcodeError(ValueError):
    """A program the front end refuses. ``str()`` is one ``source:line:col: message`` line
    per error; ``errors`` lists them as (line, col, message); ``line``, ``col`` and
    ``message`` are the first's."""

    def __init__(self, source: str, errors: list[tuple[int, int, str]]):
        super().__init__("\n".join(f"{source}:{ln}:{col}: {msg}" for ln, col, msg in errors))
        self.source = source
        self.errors = errors
        self.line, self.col, self.message = errors[0]


class _BlockError(Exception):
    def __init__(self, col: int, message: str):
        super().__init__(message)
        self.col = col
        self.message = message


class _Block:
    """The words of one line, sorted: G and M codes by group, the rest by letter."""

    def __init__(self, words: list[Word]):
        self.g: dict[str, tuple[int, Word]] = {}
        self.m: dict[str, tuple[int, Word]] = {}
        self.words: dict[str, Word] = {}
        for w in words:
            if w.letter in "GM":
                self._code(w, G_CODES if w.letter == "G" else M_CODES,
                           self.g if w.letter == "G" else self.m)
            elif w.letter not in LETTERS:
                raise _BlockError(w.col, f"unsupported word {w.text}{_HINTS.get(w.letter, '')}")
            elif w.letter in self.words:
                raise _BlockError(w.col, f"{w.letter} appears twice in one block")
            else:
                self.words[w.letter] = w

    @staticmethod
    def _code(w: Word, table: dict[int, Code], found: dict[str, tuple[int, Word]]) -> None:
        key = code_key(w.value) if w.letter == "G" else None
        if w.letter == "M" and w.value == w.value.to_integral_value():
            key = int(w.value)
        if w.letter == "G" and key in REFUSED_G:
            raise _BlockError(w.col, f"{w.text}: {REFUSED_G[key]}")
        for (first, last), why in REFUSED_M.items() if w.letter == "M" else ():
            if key is not None and first <= key <= last:
                raise _BlockError(w.col, f"{w.text}: {why}")
        if key is None or key not in table or w.value * 10 != int(w.value * 10):
            raise _BlockError(w.col, f"{w.text} is unsupported")
        group = table[key].group
        if group in found:
            raise _BlockError(w.col, f"{found[group][1].text} and {w.text} are in the same "
                                     f"modal group ({group})")
        found[group] = key, w

    def code(self, group: str) -> int | None:
        return self.g[group][0] if group in self.g else None

    def word(self, letter: str) -> Word | None:
        return self.words.get(letter)


class _Interpreter:
    def __init__(self, planner: Planner, *, lsb_mm: float, tolerance: float | None,
                 tools: Mapping[int, float] | None):
        self.planner = planner
        self.lsb_size = Decimal(repr(lsb_mm))
        self.tolerance = tolerance
        self.tools = tools
        self.end = False
        self.motion: int | None = None
        self.inch = False
        self.incremental = False
        self.arc_absolute = False
        self.plane = 17
        self.coordinate_system = 540
        self.retract_r = True  # G99, rs274's initial retract mode
        self.feed: float | None = None
        self.feed_source: tuple[int, int, str] | None = None
        self.g92 = [0, 0, 0]
        self.tool_offset = 0
        self.selected: int | None = None
        self.tool: int | None = None
        self.cycle: dict[str, Decimal] = {}
        self.cycle_planes: tuple[int, int, int] | None = None
        self.line_no = 0
        #: The G05.2 NURBS being read: control points (LSB), weights, order, its G05.2 word
        #: and line.
        self.nurbs: tuple[list[tuple[float, float]], list[float], int, Word, int] | None = None
        #: The last G05's second control point from its end (LSB), for the next G05.
        self.g05_pq: tuple[float, float] | None = None

    # -- helpers ----------------------------------------------------------------------------

    @property
    def pos(self) -> tuple[int, int, int]:
        """The programmed position (the machine's may be up to 1 LSB off after an arc)."""
        return self.planner.programmed

    def lsb(self, value: Decimal, inch: bool | None = None) -> int:
        mm = value * INCH_MM if (self.inch if inch is None else inch) else value
        return int((mm / self.lsb_size).to_integral_value(rounding=ROUND_HALF_UP))

    def offset(self, axis: int) -> int:
        return self.g92[axis] + (self.tool_offset if axis == 2 else 0)

    def check_range(self, word: Word, value: int, what: str) -> None:
        if abs(value) > COORD_MAX:
            raise _BlockError(word.col, f"{word.text}: {what} {value} LSB is outside "
                                  f"-(2^23-1)..2^23-1 LSB (+-{self.planner.mm(COORD_MAX)})")

    def target(self, b: _Block, *, machine: bool = False,
               incremental: bool | None = None) -> tuple[int, int, int]:
        """The absolute machine target of a block's X/Y/Z words (unnamed axes stay)."""
        incremental = self.incremental if incremental is None else incremental
        target = list(self.pos)
        for axis, letter in enumerate(_AXIS_LETTERS):
            w = b.word(letter)
            if w is None:
                continue
            target[axis] = self.base(axis, incremental, machine) + self.lsb(w.value)
            self.check_range(w, target[axis], "the position")
            self.check_range(w, target[axis] - self.pos[axis], "the move")
            if axis == 2 and self.planner.axes == 2 and target[2] != self.pos[2]:
                raise _BlockError(w.col, f"{w.text} moves Z: this machine has two axes "
                                   f"(machine.axes = 3 runs it)")
        return target[0], target[1], target[2]

    def exact_target(self, b: _Block) -> tuple[float, float, float]:
        """:meth:`target` before its words are rounded to the LSB grid (LSB)."""
        target = [float(v) for v in self.pos]
        for axis, letter in enumerate(_AXIS_LETTERS):
            w = b.word(letter)
            if w is not None:
                mm = w.value * INCH_MM if self.inch else w.value
                target[axis] = self.base(axis, self.incremental, False) + float(mm / self.lsb_size)
        return target[0], target[1], target[2]

    def base(self, axis: int, incremental: bool, machine: bool) -> int:
        """What an axis word adds to: the position (G91), the origin (G53), else the offsets."""
        return self.pos[axis] if incremental else (0 if machine else self.offset(axis))

    def plan(self, col: int, call, *args, **kwargs) -> None:
        try:
            call(self.line_no, *args, **kwargs)
        except PlanError as e:
            raise _BlockError(col, str(e)) from None

    def event(self, w: Word, kind: str, value: float | None = None) -> None:
        self.planner.event(self.line_no, w.text, kind, value)

    # -- one block --------------------------------------------------------------------------

    def block(self, words: list[Word]) -> None:
        b = _Block(words)
        n = b.word("N")
        if n is not None and (n.value < 0 or n.value != n.value.to_integral_value()):
            raise _BlockError(n.col, f"{n.text}: N must be a non-negative integer")
        units = b.code("units")
        if units is not None:
            self.inch = units == 200
        self.feed_word(b)
        self.spindle_tool_coolant(b)
        if "non-modal" in b.g and b.g["non-modal"][0] == 40:
            self.dwell(b)
        elif b.word("P") is not None and not self.takes_p(b):
            p = b.word("P")
            raise _BlockError(p.col, f"{p.text}: P is only for G04 (dwell), G82, G64 and arcs")
        self.modal_settings(b)
        self.non_modal(b)
        self.motion_of(b)
        if "stop" in b.m:
            key, w = b.m["stop"]
            if key in (2, 30):
                self.end = True
            else:
                self.event(w, M_CODES[key].event)

    def recover(self, words: list[Word]) -> None:
        """After a refused block: its programmed end becomes the next block's start, as if it
        had run, so that the blocks after it are checked from where the program meant to be
        and one fault is reported once. A block that sets rather than moves (G04, G10, G28,
        G92, ...) or whose end cannot be known moves nothing."""
        try:
            b = _Block(words)
        except _BlockError:
            return
        if "non-modal" in b.g or not any(b.word(a) for a in _AXIS_LETTERS):
            return
        target = list(self.pos)
        for axis, letter in enumerate(_AXIS_LETTERS):
            w = b.word(letter)
            if w is not None and (axis < 2 or self.planner.axes == 3):
                base = self.pos[axis] if self.incremental else self.offset(axis)
                target[axis] = base + self.lsb(w.value)
        if all(abs(v) <= COORD_MAX for v in target):
            self.planner.position = self.planner.programmed = (target[0], target[1], target[2])

    def takes_p(self, b: _Block) -> bool:
        motion = b.code("motion") if "motion" in b.g else self.motion
        return (b.code("path") == 640 or motion in (20, 30, 50, 52, 820)
                or self.nurbs is not None)

    # -- splines ----------------------------------------------------------------------------

    def offset_lsb(self, w: Word | None) -> float:
        """A control point offset word in LSB, unrounded (0 if absent)."""
        if w is None:
            return 0.0
        return float((w.value * INCH_MM if self.inch else w.value) / self.lsb_size)

    def spline_start(self, anchor: Word, b: _Block) -> tuple[float, float]:
        """Where a spline starts (LSB), after checking its plane and that Z stays."""
        if self.plane != 17:
            raise _BlockError(anchor.col, f"{anchor.text} is for the XY plane (G17)")
        z = b.word("Z")
        if z is not None and self.target(b)[2] != self.pos[2]:
            raise _BlockError(z.col, f"{z.text}: a spline stays in the XY plane")
        return float(self.pos[0]), float(self.pos[1])

    def spline(self, b: _Block, anchor: Word) -> None:
        """G05 (cubic) and G05.1 (quadratic) from the position to the block's X/Y."""
        start = self.spline_start(anchor, b)
        target = self.target(b)
        end = self.exact_target(b)[:2]
        i, j = b.word("I"), b.word("J")
        if self.motion == 50:
            p, q = b.word("P"), b.word("Q")
            if p is None or q is None:
                raise _BlockError(anchor.col, "G05 needs P and Q (the second control point, "
                                              "from the end)")
            if i is None and j is None:
                if self.g05_pq is None:
                    raise _BlockError(anchor.col, "G05 needs I and J (the first control point, "
                                                  "from the start) unless it follows a G05")
                first = (start[0] - self.g05_pq[0], start[1] - self.g05_pq[1])
            else:
                first = (start[0] + self.offset_lsb(i), start[1] + self.offset_lsb(j))
            pq = (self.offset_lsb(p), self.offset_lsb(q))
            curve = bezier(start, first, (end[0] + pq[0], end[1] + pq[1]), end)
        else:
            if i is None and j is None:
                raise _BlockError(anchor.col, "G05.1 needs I and/or J (the control point, from "
                                              "the start)")
            control = (start[0] + self.offset_lsb(i), start[1] + self.offset_lsb(j))
            curve = Nurbs((start, control, end), (1.0, 1.0, 1.0), 3)
            pq = None
        self.plan(anchor.col, self.planner.spline, curve, target, self.feed,
                  tolerance=self.arc_tolerance(), feed_source=self.feed_source)
        self.g05_pq = pq

    def nurbs_block(self, b: _Block, g: tuple[int, Word] | None) -> None:
        """A line of a G05.2 ... G05.3 NURBS block: its opening, a control point, its end."""
        code = None if g is None else g[0]
        if self.nurbs is None:
            if code == 53:
                raise _BlockError(g[1].col, "G05.3 without a G05.2 NURBS before it")
            anchor = g[1]
            start = self.spline_start(anchor, b)
            if self.feed is None:
                raise _BlockError(anchor.col, "G05.2 without a feed rate: program F first")
            order_word = b.word("L")
            order = 3 if order_word is None else int(order_word.value)
            if order_word is not None and (order != order_word.value or order < 2):
                raise _BlockError(order_word.col, f"{order_word.text}: the order must be an "
                                                  f"integer of at least 2")
            weight = self.weight(b)
            has_point = b.word("X") is not None or b.word("Y") is not None
            self.nurbs = ([start], [1.0 if has_point else weight], order, anchor, self.line_no)
            if has_point:
                self.nurbs_point(b, weight)
            self.motion = None
            return
        if code == 53:
            self.nurbs_end(g[1])
        elif code is not None:
            raise _BlockError(g[1].col, f"{g[1].text} inside a G05.2 NURBS block: it ends with "
                                        f"G05.3")
        else:
            self.nurbs_point(b, self.weight(b))

    def weight(self, b: _Block) -> float:
        p = b.word("P")
        if p is not None and p.value <= 0:
            raise _BlockError(p.col, f"{p.text}: a weight must be positive")
        return 1.0 if p is None else float(p.value)

    def nurbs_point(self, b: _Block, weight: float) -> None:
        assert self.nurbs is not None
        self.spline_start(self.nurbs[3], b)
        target = self.target(b)
        self.nurbs[0].append(self.exact_target(b)[:2])
        self.nurbs[1].append(weight)
        self.planner.programmed = (target[0], target[1], self.pos[2])

    def nurbs_end(self, anchor: Word) -> None:
        assert self.nurbs is not None
        points, weights, order, _, opening_line = self.nurbs
        self.nurbs = None
        self.planner.programmed = self.planner.position
        if len(points) < order:
            raise _BlockError(anchor.col, f"the G05.2 NURBS of order {order} needs at least "
                                          f"{order} control points, the start included, not "
                                          f"{len(points)}")
        end = points[-1]
        target = (round(end[0]), round(end[1]), self.pos[2])
        self.line_no, line = opening_line, self.line_no
        try:
            self.plan(anchor.col, self.planner.spline, Nurbs(tuple(points), tuple(weights), order),
                      target, self.feed, tolerance=self.arc_tolerance(),
                      feed_source=self.feed_source)
        finally:
            self.line_no = line

    def arc_tolerance(self) -> float:
        """The arc tolerance in LSB (the program's, or LinuxCNC's in the units in force)."""
        if self.tolerance is not None:
            return self.tolerance
        return ARC_TOLERANCE_MM[self.inch] / float(self.lsb_size)

    def feed_word(self, b: _Block) -> None:
        f = b.word("F")
        if f is None:
            return
        if f.value <= 0:
            raise _BlockError(f.col, f"{f.text}: the feed must be positive")
        self.feed = float(f.value * INCH_MM if self.inch else f.value)
        self.feed_source = (self.line_no, f.col, f.text)

    def spindle_tool_coolant(self, b: _Block) -> None:
        s, t = b.word("S"), b.word("T")
        if s is not None:
            if s.value < 0:
                raise _BlockError(s.col, f"{s.text}: the spindle speed must not be negative")
            self.event(s, "spindle_speed", float(s.value))
        if t is not None:
            if t.value < 0 or t.value != t.value.to_integral_value():
                raise _BlockError(t.col, f"{t.text}: T must be a non-negative integer")
            self.selected = int(t.value)
            self.event(t, "tool_select", float(t.value))
        for group in ("tool change", "spindle", "coolant"):
            if group in b.m:
                key, w = b.m[group]
                value = None
                if key == 6:
                    self.tool = self.selected
                    value = None if self.tool is None else float(self.tool)
                self.event(w, M_CODES[key].event, value)

    def dwell(self, b: _Block) -> None:
        g4 = b.g["non-modal"][1]
        for letter in _AXIS_LETTERS if "motion" not in b.g else "":  # else: the motion's
            if b.word(letter) is not None:
                w = b.word(letter)
                raise _BlockError(w.col, f"{w.text}: G04 takes only P (seconds)")
        p = b.word("P")
        if p is None:
            raise _BlockError(g4.col, "G04 needs P (the dwell in seconds)")
        if p.value < 0:
            raise _BlockError(p.col, f"{p.text}: the dwell must not be negative")
        self.planner.dwell(self.line_no, float(p.value))

    def modal_settings(self, b: _Block) -> None:
        plane = b.code("plane")
        if plane is not None:
            self.plane = plane // 10
        distance = b.code("distance")
        if distance is not None:
            self.incremental = distance == 910
        system = b.code("coordinate system")
        if system is not None:
            self.coordinate_system = system
        arc = b.code("arc distance")
        if arc is not None:
            self.arc_absolute = arc == 901
        retract = b.code("retract")
        if retract is not None:
            self.retract_r = retract == 990
        h = b.word("H")
        length = b.code("tool length")
        if h is not None and length != 430:
            raise _BlockError(h.col, f"{h.text}: H is only for G43 (tool length offset)")
        if length == 490:
            self.tool_offset = 0
        elif length == 430:
            self.tool_offset = self.tool_length(b.g["tool length"][1], h)

    def tool_length(self, g43: Word, h: Word | None) -> int:
        if h is not None and (h.value < 0 or h.value != h.value.to_integral_value()):
            raise _BlockError(h.col, f"{h.text}: H must be a non-negative integer")
        number = int(h.value) if h is not None else self.tool
        if not self.tools or number in (None, 0):
            return 0
        if number not in self.tools:
            raise _BlockError((h or g43).col, f"{(h or g43).text}: tool {number} is not in the "
                                        f"job's tool table ({sorted(self.tools)})")
        return self.lsb(Decimal(repr(self.tools[number])), inch=False)

    def non_modal(self, b: _Block) -> None:
        if "non-modal" not in b.g:
            return
        key, w = b.g["non-modal"]
        if key in (280, 300):
            if b.code("motion") is not None:
                raise _BlockError(w.col, f"{w.text} and a motion code in one block")
            via = self.target(b)
            self.plan(w.col, self.planner.line, via, None)
            named = [b.word(letter) is not None for letter in _AXIS_LETTERS]
            home = tuple(0 if (named[a] or not any(named)) else via[a] for a in range(3))
            self.check_z(w, home)
            self.plan(w.col, self.planner.line, home, None)
        elif key == 920:
            for axis, letter in enumerate(_AXIS_LETTERS):
                v = b.word(letter)
                if v is not None:
                    self.g92[axis] = self.pos[axis] - self.lsb(v.value) - (
                        self.tool_offset if axis == 2 else 0)
        elif key == 921:
            self.g92 = [0, 0, 0]

    def check_z(self, w: Word, target: tuple[int, ...]) -> None:
        if self.planner.axes == 2 and target[2] != self.pos[2]:
            raise _BlockError(w.col, f"{w.text} moves Z: this machine has two axes "
                               f"(machine.axes = 3 runs it)")

    def axis_words(self, b: _Block) -> list[Word]:
        return [w for letter in _AXIS_LETTERS if (w := b.word(letter)) is not None]

    # -- motion -----------------------------------------------------------------------------

    def motion_of(self, b: _Block) -> None:
        g = b.g.get("motion")
        order = b.word("L")
        if order is not None and (g is None or g[0] != 52 or self.nurbs is not None):
            raise _BlockError(order.col, f"{order.text}: L is only for G05.2 (a NURBS's order)")
        if self.nurbs is not None or (g is not None and g[0] in (52, 53)):
            for letter in "IJKRQ":
                w = b.word(letter)
                if w is not None:
                    raise _BlockError(w.col, f"{w.text}: a G05.2 NURBS takes X, Y, P and L")
            self.nurbs_block(b, g)
            return
        if g is not None:
            if g[0] != self.motion:
                self.cycle, self.cycle_planes = {}, None
            self.motion = None if g[0] == 800 else g[0]
        if "non-modal" in b.g and b.g["non-modal"][0] in (280, 300, 920):
            return  # their axis words are theirs
        axes = self.axis_words(b)
        for letter in "IJKRQ":
            w = b.word(letter)
            if w is not None and not self.uses(letter, b):
                raise _BlockError(w.col, f"{w.text}: {letter} is only for "
                                   f"{'arcs (G02/G03)' if letter in 'IJK' else _USES[letter]}")
        if not axes and not (g is not None and g[0] in (20, 30, 60) and self.has_offsets(b)):
            return
        if self.motion is None:
            if g is not None and g[0] == 800:
                raise _BlockError(axes[0].col, f"{axes[0].text}: G80 cancels the motion mode")
            raise _BlockError(axes[0].col, f"{axes[0].text} without a motion mode "
                                           f"(G00/G01/G02/G03)")
        anchor = g[1] if g is not None else axes[0]
        if self.motion != 0 and self.feed is None:
            raise _BlockError(anchor.col, f"{_g_name(self.motion)} without a feed rate: program "
                                    f"F first")
        machine = "non-modal" in b.g and b.g["non-modal"][0] == 530
        if machine and self.motion not in (0, 10):
            raise _BlockError(b.g["non-modal"][1].col, "G53 is only for G00/G01 moves")
        if machine and self.incremental:
            raise _BlockError(b.g["non-modal"][1].col, "G53 takes absolute machine "
                                                      "coordinates: not in G91")
        if self.motion in (0, 10):
            target = self.target(b, machine=machine, incremental=False if machine else None)
            self.plan(anchor.col, self.planner.line, target,
                      None if self.motion == 0 else self.feed, feed_source=self.feed_source)
        elif self.motion in (20, 30):
            self.arc(b, anchor)
        elif self.motion == 60:
            self.parabola(b, anchor)
        elif self.motion in (61, 62):
            self.exponential(b, anchor)
        elif self.motion in (50, 51):
            self.spline(b, anchor)
        else:
            self.canned_cycle(b, anchor)

    def uses(self, letter: str, b: _Block) -> bool:
        if letter in "IJK":
            return (self.motion in (20, 30) or (self.motion in (50, 51, 60) and letter != "K")
                    or (self.motion in (61, 62) and letter == "K"))
        if letter == "R":
            return self.motion in (20, 30, 810, 820, 830)
        return self.motion in (50, 830) or b.code("path") == 640  # Q

    def has_offsets(self, b: _Block) -> bool:
        return any(b.word(letter) is not None for letter in _OFFSET_LETTERS)

    def arc(self, b: _Block, anchor: Word) -> None:
        first, second, normal = PLANE_AXES[self.plane]
        cw = self.motion == 20
        name = f"G0{self.motion // 10}"
        wrong = _OFFSET_LETTERS[normal]
        if b.word(wrong) is not None:
            w = b.word(wrong)
            raise _BlockError(w.col, f"{w.text}: a G{self.plane} arc takes "
                               f"{_OFFSET_LETTERS[first]} and {_OFFSET_LETTERS[second]}")
        if self.planner.axes == 2 and self.plane != 17:
            raise _BlockError(anchor.col, f"{name} in G{self.plane} moves Z: this machine has two "
                                    f"axes (machine.axes = 3 runs it)")
        p = b.word("P")
        if p is not None and p.value != 1:
            raise _BlockError(p.col, f"{p.text}: arcs of more than one turn are unsupported")
        target = self.target(b)
        start = self.pos
        r = b.word("R")
        if r is not None:
            if self.has_offsets(b):
                raise _BlockError(r.col, f"{r.text}: an arc takes R or centre offsets, not both")
            centre = self.centre_from_radius(r, start, target, first, second, cw)
        elif not self.has_offsets(b):
            raise _BlockError(anchor.col, f"{name} needs {_OFFSET_LETTERS[first]} and/or "
                                    f"{_OFFSET_LETTERS[second]} (the centre offsets) or R")
        else:
            centre = []
            for axis in (first, second):
                w = b.word(_OFFSET_LETTERS[axis])
                if self.arc_absolute:
                    c = self.offset(axis) + self.lsb(w.value) if w else self.offset(axis)
                else:
                    c = start[axis] + (self.lsb(w.value) if w else 0)
                centre.append(c)  # beyond the K3701's registers: the planner runs chords
        self.plan(anchor.col, self.planner.arc, target, (centre[0], centre[1]), self.plane,
                  cw, self.feed, tolerance=self.arc_tolerance(), feed_source=self.feed_source,
                  exact=self.exact_target(b))

    def parabola(self, b: _Block, anchor: Word) -> None:
        """G06: the tangent point relative to the start, as an arc's centre (absolute under
        G90.1)."""
        if self.plane != 17:
            raise _BlockError(anchor.col, f"G06 in G{self.plane}: parabolas are in the XY "
                                          f"plane (G17)")
        if b.word("I") is None and b.word("J") is None:
            raise _BlockError(anchor.col, "G06 needs I and/or J (the tangent point)")
        target = self.target(b)
        start = self.pos
        tangent = []
        for axis in (0, 1):  # the point as an arc's centre is, from the machine's position
            w = b.word("IJ"[axis])
            if self.arc_absolute:
                point = self.offset(axis) + (self.lsb(w.value) if w else 0)
            else:
                point = start[axis] + (self.lsb(w.value) if w else 0)
            if w is not None:
                self.check_range(w, point - start[axis], "the tangent point")
            tangent.append(point - self.planner.position[axis])
        self.plan(anchor.col, self.planner.parabola, target, (tangent[0], tangent[1]),
                  self.feed, feed_source=self.feed_source)

    def exponential(self, b: _Block, anchor: Word) -> None:
        """G06.1 (exponential of X) and G06.2 (logarithm: exponential of Y): K the curve's
        constant, a length along the abscissa (negative: the curve flattens)."""
        name = _g_name(self.motion)
        if self.plane != 17:
            raise _BlockError(anchor.col, f"{name} in G{self.plane}: exponentials are in the "
                                          f"XY plane (G17)")
        k = b.word("K")
        if k is None:
            raise _BlockError(anchor.col, f"{name} needs K (the curve's constant)")
        constant = self.lsb(k.value)
        self.check_range(k, constant, "the curve's constant")
        self.plan(anchor.col, self.planner.exponential, self.target(b), constant,
                  self.motion == 62, self.feed, feed_source=self.feed_source)

    def centre_from_radius(self, r: Word, start, target, first: int, second: int,
                           cw: bool) -> list[int]:
        """RS-274's R form: the centre on the chord's bisector, left of the chord for CCW,
        right for CW (R < 0: the other side, the arc over 180 degrees)."""
        sx, sy = start[first], start[second]
        ex, ey = target[first], target[second]
        radius = self.lsb(r.value)
        chord = math.hypot(ex - sx, ey - sy)
        if chord == 0:
            raise _BlockError(r.col, f"{r.text}: an R-form arc cannot be a full circle (use I/J/K)")
        if radius == 0 or abs(radius) < chord / 2 - 0.5:
            raise _BlockError(r.col, f"{r.text}: the radius is shorter than half the distance to "
                               f"the end point ({self.planner.mm(chord / 2)})")
        h = math.sqrt(max(0.0, radius * radius - chord * chord / 4))
        side = (1 if cw else -1) * (1 if radius > 0 else -1)
        ux, uy = (ex - sx) / chord, (ey - sy) / chord
        return [round((sx + ex) / 2 + side * h * uy), round((sy + ey) / 2 - side * h * ux)]

    def canned_cycle(self, b: _Block, anchor: Word) -> None:
        """G81/G82/G83 at the block's X/Y, expanded as LinuxCNC's interpreter does."""
        if self.plane != 17:
            raise _BlockError(anchor.col, f"G{self.motion // 10} in G{self.plane} is "
                                          f"unsupported: canned cycles drill along Z, in G17")
        for letter in "ZRPQ":
            w = b.word(letter)
            if w is not None:
                self.cycle[letter] = w.value
        needs = "ZR" + ("P" if self.motion == 820 else "") + ("Q" if self.motion == 830 else "")
        missing = [letter for letter in needs if letter not in self.cycle]
        if missing:
            raise _BlockError(anchor.col, f"G{self.motion // 10} needs {' and '.join(missing)}")
        if self.motion == 830 and self.cycle["Q"] <= 0:
            raise _BlockError(anchor.col, f"G83: the peck Q{self.cycle['Q']} must be positive")
        old_z = self.pos[2]
        if self.cycle_planes is None or "motion" in b.g or b.word("R") or b.word("Z"):
            # R and Z as of the cycle's first block (in G91: from the Z there), kept for its
            # repeats, with that block's Z for G98's retract
            if self.incremental:
                r = old_z + self.lsb(self.cycle["R"])
                bottom = r + self.lsb(self.cycle["Z"])
            else:
                r = self.offset(2) + self.lsb(self.cycle["R"])
                bottom = self.offset(2) + self.lsb(self.cycle["Z"])
            self.cycle_planes = r, bottom, old_z
        r, bottom, start_z = self.cycle_planes
        if r < bottom:
            raise _BlockError(anchor.col, f"G{self.motion // 10}: the retract plane R is below "
                                          f"the bottom Z")
        xy = self.target(_Block([w for w in (b.word("X"), b.word("Y")) if w is not None]))
        clear = r if self.retract_r else max(r, start_z)
        if self.planner.axes == 2 and (r != old_z or bottom != old_z):
            raise _BlockError(anchor.col, f"G{self.motion // 10} moves Z: this machine has two "
                                          f"axes (machine.axes = 3 runs it)")
        moves: list[tuple[int, bool]] = []  # (z, feed?) at the hole
        if old_z < r:
            self.plan(anchor.col, self.planner.line, (*self.pos[:2], r), None)
        if self.motion == 830:
            delta = self.lsb(self.cycle["Q"])
            if delta < 1:
                raise _BlockError(anchor.col, f"G83: the peck Q{self.cycle['Q']} is under half "
                                              f"an LSB ({self.planner.mm(1)})")
            pecks = -(-(r - bottom) // delta)
            if pecks > MAX_PECKS:
                raise _BlockError(anchor.col, f"G83: {pecks} pecks of Q{self.cycle['Q']} from R "
                                              f"to Z; at most {MAX_PECKS} a hole")
            rapid_delta = self.lsb(G83_CLEARANCE_MM, inch=False)
            depth = r - delta
            while depth > bottom:
                moves += [(depth, True), (r, False), (depth + rapid_delta, False)]
                depth -= delta
        moves += [(bottom, True)]
        self.plan(anchor.col, self.planner.line, (xy[0], xy[1], self.pos[2]), None)
        self.plan(anchor.col, self.planner.line, (xy[0], xy[1], r), None)
        for z, feed in moves:
            self.plan(anchor.col, self.planner.line, (xy[0], xy[1], z),
                      self.feed if feed else None, feed_source=self.feed_source)
        if self.motion == 820:
            self.planner.dwell(self.line_no, float(self.cycle["P"]))
        self.plan(anchor.col, self.planner.line, (xy[0], xy[1], clear), None)


def names_third_axis(text: str) -> bool:
    """Whether a program's words name the third axis: a Z word, or G18/G19 (an arc plane with
    Z). Lines the lexer cannot read are passed over."""
    for line in text.split("\n"):
        try:
            words = read_line(line).words
        except LexError:
            continue
        if any(w.letter == "Z" or (w.letter == "G" and w.literal is not None
                                   and Decimal(w.literal[1:]) in (18, 19)) for w in words):
            return True
    return False


def parse(text: str, *, source: str = "<gcode>", lsb_mm: float = 0.001, sqrt2: bool = True,
          arc_tolerance: float | None = None, axes: int = 2,
          tools: Mapping[int, float] | None = None,
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
        centre, in :data:`ARC_TOLERANCE_LIMIT`; None: LinuxCNC's (:data:`ARC_TOLERANCE_MM`).
    axes : int
        The machine's axes: 2 (X, Y) or 3 (X, Y, Z).
    tools : mapping or None
        Tool lengths (mm) by tool number, for G43; None: every length is zero.
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
    interp = _Interpreter(planner, lsb_mm=lsb_mm, tolerance=arc_tolerance, tools=tools)
    host = InterpreterHost(interp, _BlockError, MAX_ERRORS)
    try:
        ngc.run(text.removeprefix("\ufeff").split("\n"), host)
    except ngc.NgcError as e:
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
                   notes=tuple(f"{name}:{line + first - 1}: {text}" for line, text in notes))
