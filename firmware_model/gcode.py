"""G-code front end: RS-274 text to K3701 blocks in machine LSB units.

:func:`parse` reads a program and returns a :class:`Program`: a list of :class:`Line`,
:class:`Arc` and :class:`Dwell` items, each ready for the firmware model to load into the
chipset. Every coordinate is an integer number of LSB (1 LSB = ``lsb_mm`` mm, 1 um by
default), relative to the block's start as the K3701 takes it.

The dialect, a strict subset of RS-274/NGC:

* ``G00`` rapid and ``G01`` feed lines, ``G02``/``G03`` CW/CCW arcs with ``I``/``J`` centre
  offsets (always relative to the arc's start; ``X``/``Y`` may be omitted: the end defaults
  to the start, so ``G02 I5`` is a full circle), ``G06`` parabolas (DIN 66025: ``I``/``J``
  the point whose tangent is parallel to the chord, relative to the start as arc centres;
  :mod:`firmware_model.curves`), ``G04 P<seconds>`` dwell, ``G17`` (the only
  plane), ``G20``/``G21`` inch/mm, ``G90``/``G91`` absolute/incremental, ``F`` feed in units
  per minute (modal), ``N`` sequence numbers (ignored), ``M02``/``M30`` program end.
* Motion modes are modal: a line with only coordinates repeats the last G00-G03. Unit and
  distance modes take effect for the whole block they appear in. ``F`` is converted to mm/min
  when it is programmed.
* Comments ``( ... )`` and ``; ...``; a line holding only ``%`` (tape marker) is skipped;
  letters are case-insensitive; spaces between words and inside a word are allowed.
* Anything else is an error, as is any word after the program end.

Coordinates are rounded to the nearest LSB (halves away from zero), with decimal arithmetic so
that ``X0.0015`` is exactly 1.5 um. Positions are tracked twice: the *programmed* position
(where the program says the tool is) and the *machine* position (where the K3701 really
stops). They differ only after an arc whose end is not on its digital path (the chip stops
near it, up to 2 LSB away within the default tolerance); each block runs from the machine
position to the programmed target, and an arc's centre is the programmed start plus (I, J),
so such errors never accumulate. An arc whose programmed end equals its programmed start is a
full circle (end = start on the chip, too).

Checks, each an error naming the word's line and column (the G02/G03 word, or the first
coordinate of a modal block, for whole-arc errors):

* absolute positions, moves and centre offsets beyond -(2^23-1)..2^23-1 LSB, and an arc whose
  path between its ends reaches beyond that range (checked on the true circle, rounded up);
* an arc end whose distance from the centre differs from the start's by more than
  ``arc_tolerance`` LSB (default 2: rounding the end and the centre to the grid alone can
  make sqrt(2));
* an arc the K3701 refuses (:class:`~hdl.k3701_model.BlockError`: radius 0, circle too big) or
  would not finish (its reference model's :func:`~hdl.k3701_model.plan` reports ``error``:
  the arc leaves its end quadrant first, which happens for radii of a few LSB);
* a feed move (G01-G03) before any ``F``.

Errors are :class:`GcodeError`, one line each: ``file:line:col: message``.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from decimal import ROUND_HALF_UP, Decimal

from firmware_model.curves import CurveError, Parabola, parabola_block
from hdl.k3701_model import COORD_MAX, Block, BlockError, Plan, make_path, plan
from hdl.limits import Limit

__all__ = ["ARC_TOLERANCE", "ARC_TOLERANCE_LIMIT", "INCH_MM", "LSB_MM_LIMIT", "Arc", "Dwell",
           "GcodeError", "Item", "Line", "Program", "parse"]

#: Millimetres per inch (G20).
INCH_MM = Decimal("25.4")
#: Default arc tolerance (LSB): how far the end's distance from the centre may differ from the
#: start's. Rounding the end point and the centre to the LSB grid alone changes it by up to
#: sqrt(2) LSB.
ARC_TOLERANCE = 2.0
#: The arc tolerances the front end accepts.
ARC_TOLERANCE_LIMIT = Limit(0, unit="LSB")
#: The LSB lengths it converts coordinates with.
LSB_MM_LIMIT = Limit(0, low_open=True, unit="mm")


class GcodeError(ValueError):
    """A program the front end refuses; ``str()`` is ``source:line:col: message``."""

    def __init__(self, source: str, line: int, col: int, message: str):
        super().__init__(f"{source}:{line}:{col}: {message}")
        self.source = source
        self.line = line
        self.col = col
        self.message = message


@dataclass(frozen=True)
class _Move:
    """What every move has. ``start``, ``block`` and ``plan`` are keyword-only."""

    index: int
    line_no: int
    xe: int
    ye: int
    start: tuple[int, int] = field(kw_only=True)
    block: Block = field(kw_only=True)
    plan: Plan = field(kw_only=True)

    @property
    def end(self) -> tuple[int, int]:
        """Absolute machine position after the move (LSB)."""
        return self.start[0] + self.plan.end[0], self.start[1] + self.plan.end[1]


@dataclass(frozen=True)
class Line(_Move):
    """A straight move (G00 or G01).

    ``index``: position in :attr:`Program.items`; ``line_no``: source line (from 1).
    ``xe, ye``: end relative to the start (LSB). ``feed_mm_min``: the programmed feed, or
    None for a rapid move (``rapid``: the firmware picks the machine's rapid feed). ``start``:
    absolute machine position before the move (LSB; the program starts at the origin).
    ``block`` is what the K3701 is loaded with and ``plan`` its exact step and FP counts (for
    the ``sqrt2`` setting of :func:`parse`); ``end`` the absolute position after the move.
    """

    feed_mm_min: float | None
    rapid: bool


@dataclass(frozen=True)
class Arc(_Move):
    """A circular move (G02 CW, G03 CCW).

    ``xe, ye``: programmed end and ``i, j``: centre, both relative to the start (LSB).
    ``plan.end`` is where the K3701 really stops: ``(xe, ye)`` when that point is on the
    digital path, else a point near it (at most 2 LSB away for ends within the default
    tolerance); ``plan.fp`` is the FP budget. Other fields as in :class:`Line`.
    """

    i: int
    j: int
    cw: bool
    feed_mm_min: float

    @property
    def center(self) -> tuple[int, int]:
        """Absolute position of the centre (LSB)."""
        return self.start[0] + self.i, self.start[1] + self.j

    @property
    def radius(self) -> float:
        """Distance from the centre to the start (LSB)."""
        return math.hypot(self.i, self.j)

    @property
    def span(self) -> tuple[float, float]:
        """The start's angle around the centre and the angle swept from it to :attr:`end` in
        the direction of travel (radians; the sweep is in (0, 2 pi]: an end at the start is a
        full circle)."""
        cx, cy = self.center
        a0 = math.atan2(-self.j, -self.i)
        a1 = math.atan2(self.end[1] - cy, self.end[0] - cx)
        return a0, ((a0 - a1) if self.cw else (a1 - a0)) % math.tau or math.tau


@dataclass(frozen=True)
class Dwell:
    """A pause (G04) of ``seconds``."""

    index: int
    line_no: int
    seconds: float


Item = Line | Arc | Parabola | Dwell


@dataclass(frozen=True)
class Program:
    """A parsed program: its items in order, and whether it ended with M02/M30."""

    items: tuple[Item, ...]
    end: bool
    source: str
    lsb_mm: float
    sqrt2: bool
    arc_tolerance: float

    @property
    def final_position(self) -> tuple[int, int]:
        """Absolute machine position after the last move (LSB; the start is the origin)."""
        for item in reversed(self.items):
            if not isinstance(item, Dwell):
                return item.end
        return 0, 0

    def to_dict(self) -> dict[str, object]:
        """A JSON-able summary: source, settings and item counts."""
        return {
            "source": self.source, "lsb_mm": self.lsb_mm, "sqrt2": self.sqrt2,
            "arc_tolerance": self.arc_tolerance, "end": self.end,
            "lines": sum(isinstance(it, Line) for it in self.items),
            "arcs": sum(isinstance(it, Arc) for it in self.items),
            "dwells": sum(isinstance(it, Dwell) for it in self.items),
        }


@dataclass(frozen=True)
class _Word:
    letter: str
    text: str  # as written, e.g. "G01", "X-1.5"
    value: Decimal
    col: int


_NUMBER = re.compile(r"\s*([+-]?\s*(?:\d+\.?\d*|\.\d+))")
_AXES = ("X", "Y", "I", "J")
_SUPPORTED = frozenset("GMNFPXYIJ")
#: Why some RS-274 words are refused.
_HINTS = {
    "Z": " (K37 has two axes, X and Y)", "A": " (K37 has two axes, X and Y)",
    "B": " (K37 has two axes, X and Y)", "C": " (K37 has two axes, X and Y)",
    "K": " (only the XY plane, G17: arcs take I and J)",
    "R": " (arcs take I and J centre offsets)",
    "S": " (no spindle control)", "T": " (no tool control)",
}
_MOTION = {0, 1, 2, 3}
_GROUPS = {0: "motion", 1: "motion", 2: "motion", 3: "motion", 4: "dwell", 6: "motion",
           17: "plane", 18: "plane", 19: "plane", 20: "units", 21: "units", 90: "distance",
           91: "distance"}


def _tokenize(text: str, fail) -> list[_Word]:
    """The words of one line, comments removed."""
    words = []
    pos = 0
    while pos < len(text):
        c = text[pos]
        if c in " \t\r":
            pos += 1
        elif c == ";":
            break
        elif c == "(":
            close = text.find(")", pos)
            if close < 0:
                fail(pos + 1, "comment '(' is not closed on its line")
            pos = close + 1
        elif c.isascii() and c.isalpha():
            m = _NUMBER.match(text, pos + 1)
            if m is None:
                fail(pos + 1, f"word {c.upper()} has no number")
            number = m.group(1).replace(" ", "").replace("\t", "")
            words.append(_Word(c.upper(), c.upper() + number, Decimal(number), pos + 1))
            pos = m.end()
        else:
            fail(pos + 1, f"unexpected character {c!r}")
    return words


def _integer_code(word: _Word, fail) -> int:
    if word.value != word.value.to_integral_value():
        fail(word.col, f"{word.text} is unsupported")
    return int(word.value)


class _Parser:
    def __init__(self, source: str, lsb_mm: float, sqrt2: bool, arc_tolerance: float):
        self.source = source
        self.lsb_mm = lsb_mm
        self.lsb_size = Decimal(repr(lsb_mm))
        self.sqrt2 = sqrt2
        self.tol = arc_tolerance
        self.items: list[Item] = []
        self.end = False
        self.motion: int | None = None
        self.inch = False
        self.incremental = False
        self.feed: float | None = None
        self.prog = (0, 0)     # programmed position
        self.machine = (0, 0)  # where the K3701 stopped
        self.line_no = 0

    def fail(self, col: int, message: str):
        raise GcodeError(self.source, self.line_no, col, message) from None

    def lsb(self, value: Decimal) -> int:
        mm = value * INCH_MM if self.inch else value
        return int((mm / self.lsb_size).to_integral_value(rounding=ROUND_HALF_UP))

    def mm(self, lsb: float) -> str:
        """A length in LSB as mm, to the LSB's resolution."""
        return f"{lsb * self.lsb_mm:.{max(0, -self.lsb_size.as_tuple().exponent)}f} mm"

    def check_range(self, word: _Word, value: int, what: str) -> None:
        if abs(value) > COORD_MAX:
            self.fail(word.col, f"{word.text}: {what} {value} LSB is outside "
                                f"-(2^23-1)..2^23-1 LSB (+-{self.mm(COORD_MAX)})")

    def line(self, text: str) -> None:
        if text.strip() == "%":
            return
        words = _tokenize(text, self.fail)
        if not words:
            return
        if self.end:
            self.fail(words[0].col, "block after the program end (M02/M30)")
        by_letter: dict[str, _Word] = {}
        gcodes: dict[str, tuple[int, _Word]] = {}
        for w in words:
            if w.letter not in _SUPPORTED:
                self.fail(w.col, f"unsupported word {w.text}{_HINTS.get(w.letter, '')}")
            if w.letter == "G":
                self.g_word(w, gcodes)
                continue
            if w.letter in by_letter:
                self.fail(w.col, f"{w.letter} appears twice in one block")
            by_letter[w.letter] = w
        self.apply(by_letter, gcodes)

    def g_word(self, w: _Word, gcodes: dict[str, tuple[int, _Word]]) -> None:
        code = _integer_code(w, self.fail)
        group = _GROUPS.get(code)
        if group is None:
            self.fail(w.col, f"{w.text} is unsupported")
        if code in (18, 19):
            self.fail(w.col, f"{w.text} is unsupported: only the XY plane (G17)")
        if group in gcodes:
            self.fail(w.col, f"{gcodes[group][1].text} and {w.text} are in the same modal "
                             f"group ({group})")
        gcodes[group] = code, w

    def apply(self, words: dict[str, _Word], gcodes: dict[str, tuple[int, _Word]]) -> None:
        if "N" in words and (words["N"].value < 0
                             or words["N"].value != words["N"].value.to_integral_value()):
            self.fail(words["N"].col, f"{words['N'].text}: N must be a non-negative integer")
        if "units" in gcodes:
            self.inch = gcodes["units"][0] == 20
        if "distance" in gcodes:
            self.incremental = gcodes["distance"][0] == 91
        if "F" in words:
            f = words["F"]
            if f.value <= 0:
                self.fail(f.col, f"{f.text}: the feed must be positive")
            self.feed = float(f.value * INCH_MM if self.inch else f.value)
        end = None
        if "M" in words:
            m = words["M"]
            if _integer_code(m, self.fail) not in (2, 30):
                self.fail(m.col, f"{m.text} is unsupported")
            end = m
        axes = [words[a] for a in _AXES if a in words]
        if "dwell" in gcodes:
            self.dwell(words, gcodes["dwell"][1], axes)
        elif "P" in words:
            self.fail(words["P"].col, f"{words['P'].text}: P is only for G04 (dwell)")
        if "motion" in gcodes:
            self.motion = gcodes["motion"][0]
        if axes:
            anchor = gcodes["motion"][1] if "motion" in gcodes else axes[0]
            self.move(words, axes, anchor)
        if end is not None:
            self.end = True

    def dwell(self, words: dict[str, _Word], g4: _Word, axes: list[_Word]) -> None:
        if axes:
            self.fail(axes[0].col, f"{axes[0].text}: G04 takes only P (seconds)")
        p = words.get("P")
        if p is None:
            self.fail(g4.col, "G04 needs P (the dwell in seconds)")
        if p.value < 0:
            self.fail(p.col, f"{p.text}: the dwell must not be negative")
        self.items.append(Dwell(len(self.items), self.line_no, float(p.value)))

    def target(self, word: _Word | None, axis: int) -> int:
        """The programmed absolute coordinate of an axis after the move."""
        if word is None:
            return self.prog[axis]
        value = self.lsb(word.value) + (self.prog[axis] if self.incremental else 0)
        self.check_range(word, value, "the position")
        self.check_range(word, value - self.machine[axis], "the move")
        return value

    def move(self, words: dict[str, _Word], axes: list[_Word], anchor: _Word) -> None:
        if self.motion is None:
            self.fail(axes[0].col, f"{axes[0].text} without a motion mode (G00/G01/G02/G03)")
        if self.motion in (0, 1):
            for w in axes:
                if w.letter in "IJ":
                    self.fail(w.col, f"{w.text}: {w.letter} is only for arcs (G02/G03)")
        elif "I" not in words and "J" not in words:
            self.fail(anchor.col, f"G0{self.motion} needs I and/or J (the "
                                  f"{'tangent point' if self.motion == 6 else 'centre offsets'})")
        if self.motion != 0 and self.feed is None:
            self.fail(anchor.col, f"G0{self.motion} without a feed rate: program F first")
        tx = self.target(words.get("X"), 0)
        ty = self.target(words.get("Y"), 1)
        start = self.machine
        xe, ye = tx - start[0], ty - start[1]
        index, line_no = len(self.items), self.line_no
        if self.motion in (0, 1):
            block = Block.line(xe, ye, sqrt2=self.sqrt2)
            item: Item = Line(index, line_no, xe, ye, None if self.motion == 0 else self.feed,
                              self.motion == 0, start=start, block=block, plan=plan(block))
        elif self.motion == 6:
            item = self.parabola(words, anchor, (tx, ty), start)
        else:
            item = self.arc(words, anchor, (tx, ty), start)
        self.items.append(item)
        self.prog = (tx, ty)
        self.machine = item.end

    def arc(self, words: dict[str, _Word], anchor: _Word, target: tuple[int, int],
            start: tuple[int, int]) -> Arc:
        centre = []
        for axis, letter in enumerate("IJ"):
            w = words.get(letter)
            c = self.prog[axis] + (self.lsb(w.value) if w else 0)
            if w is not None:
                self.check_range(w, c - start[axis], "the centre offset")
            centre.append(c)
        i, j = centre[0] - start[0], centre[1] - start[1]
        if target == self.prog:  # a full circle from wherever the machine is
            xe = ye = 0
        else:
            xe, ye = target[0] - start[0], target[1] - start[1]
        if i == 0 and j == 0:
            self.fail(anchor.col, "the arc's centre is its start point (radius 0)")
        cw = self.motion == 2
        r0, r1 = math.hypot(i, j), math.hypot(xe - i, ye - j)
        if abs(r1 - r0) > self.tol:
            self.fail(anchor.col, f"the arc's end is not on its circle: radius {self.mm(r0)} "
                                  f"at the start, {self.mm(r1)} at the end (they differ by "
                                  f"{abs(r1 - r0):.1f} LSB; tolerance {self.tol:g} LSB)")
        try:
            block = Block.arc(xe, ye, i, j, cw=cw, sqrt2=self.sqrt2)
            make_path(block)  # the chip's own checks, before the walk of plan()
        except BlockError as e:
            self.fail(anchor.col, f"the K3701 refuses this arc: {e}")
        self.check_sweep(anchor, start, (i, j), (xe, ye), cw)
        result = plan(block)
        if result.error:
            self.fail(anchor.col, f"the K3701 would not reach this arc's end point "
                                  f"({xe}, {ye}) LSB relative to the start: it leaves the end "
                                  f"quadrant first and stops with ERROR")
        return Arc(len(self.items), self.line_no, xe, ye, i, j, cw, self.feed, start=start,
                   block=block, plan=result)

    def parabola(self, words: dict[str, _Word], anchor: _Word, target: tuple[int, int],
                 start: tuple[int, int]) -> Parabola:
        """G06: the tangent point is the programmed start plus (I, J), as an arc's centre."""
        i, j = (self.prog[axis] + (self.lsb(words[k].value) if k in words else 0) - start[axis]
                for axis, k in enumerate("IJ"))
        xe, ye = target[0] - start[0], target[1] - start[1]
        try:
            block, result = parabola_block(start, xe, ye, i, j, self.sqrt2)
        except CurveError as e:
            self.fail(anchor.col, str(e))
        return Parabola(len(self.items), self.line_no, xe, ye, i, j, self.feed, start, block,
                        result)

    def check_sweep(self, anchor: _Word, start: tuple[int, int], ij: tuple[int, int],
                    end: tuple[int, int], cw: bool) -> None:
        """Refuse an arc whose path leaves the 24-bit absolute range between its ends."""
        i, j = ij
        r = math.hypot(i, j)
        cx, cy = start[0] + i, start[1] + j
        a0 = math.atan2(-j, -i)
        a1 = math.atan2(end[1] - j, end[0] - i)
        sign = -1 if cw else 1
        sweep = (sign * (a1 - a0)) % math.tau or math.tau
        for k, (axis, limit) in enumerate(((0, cx + r), (1, cy + r), (0, cx - r), (1, cy - r))):
            offset = (sign * (k * math.pi / 2 - a0)) % math.tau
            crossed = offset <= sweep + 1e-9 or offset >= math.tau - 1e-9
            if crossed and math.ceil(abs(limit) - 1e-9) > COORD_MAX:
                self.fail(anchor.col, f"the arc leaves the coordinate range on "
                                      f"{'XY'[axis]}: it reaches {limit:.0f} LSB, beyond "
                                      f"+-(2^23-1) LSB (+-{self.mm(COORD_MAX)})")


def parse(text: str, *, source: str = "<gcode>", lsb_mm: float = 0.001, sqrt2: bool = True,
          arc_tolerance: float = ARC_TOLERANCE) -> Program:
    """Parse a G-code program into K3701 blocks.

    Parameters
    ----------
    text : str
        The program.
    source : str
        Name used in error messages (a file name).
    lsb_mm : float
        Millimetres per LSB (1 um by default), in :data:`LSB_MM_LIMIT`.
    sqrt2 : bool
        The machine's sqrt(2) control setting: it decides the FP counts of the plans.
    arc_tolerance : float
        Largest difference (LSB) between the start's and the end's distances from an arc's
        centre, in :data:`ARC_TOLERANCE_LIMIT`.

    Raises
    ------
    GcodeError
        For anything the front end or the K3701 cannot run, naming line and column.
    TypeError, ValueError
        ``lsb_mm`` or ``arc_tolerance`` is out of its limit.
    """
    lsb_mm = LSB_MM_LIMIT.check("lsb_mm", lsb_mm)
    arc_tolerance = ARC_TOLERANCE_LIMIT.check("arc_tolerance", arc_tolerance)
    parser = _Parser(source, lsb_mm, bool(sqrt2), arc_tolerance)
    for number, text_line in enumerate(text.split("\n"), start=1):
        parser.line_no = number
        parser.line(text_line)
    return Program(tuple(parser.items), parser.end, source, lsb_mm, bool(sqrt2), arc_tolerance)
