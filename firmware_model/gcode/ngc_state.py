"""What the RS-274/NGC language reads from the modal interpreter: predefined parameters,
the current position, and polar coordinates.

The interpreter keeps positions in whole LSB; a program that reads its position (``#5420``,
``#<_x>``) or moves in polar steps (``G91 @0.1 ^5``) would see each rounding and add them up.
:class:`State` gives the interpreter's exact programmed coordinates instead (as LinuxCNC's
interpreter has them) while the machine's position rounds to them, else the machine's.

Predefined parameters (in the program's units):

========================  ==========================================================
``#5161``-``#5169``,      G28 and G30 home positions: zero (both are the origin)
``#5181``-``#5189``
``#5210``-``#5219``       G92 offset in force (1/0) and its X, Y, Z (A-W zero)
``#5220``                 the coordinate system, 1 (G54) to 9 (G59.3)
``#5221``-``#5390``       G54-G59.3 offsets (X, Y, Z; A-W zero), as G10 set them
``#5400``, ``#5403``      the loaded tool and its length offset (``#5401``-``#5409``
                          other axes: zero)
``#5420``-``#5428``       the current position (X, Y, Z; A-W zero)
``#<_x>`` ``#<_y>``       the current position; ``_a`` ... ``_w`` zero
``#<_z>``
``#<_metric>`` ...        ``_metric _imperial _absolute _incremental _feed
                          _motion_mode _plane _coord_system _current_tool
                          _selected_tool _rpm``
========================  ==========================================================

Offsets are in the program's units (LinuxCNC gives them in its machine units).

Probe results (``#5061``-``#5070``), M66's input (``#5399``), tool diameters and any other
``#5001``-``#5602`` are errors naming the parameter.
"""

from __future__ import annotations

import math
from decimal import Decimal
from typing import Protocol

from k37.firmware_model.gcode.cycles import CYCLES, cycle_repeats
from k37.firmware_model.gcode.expr import ExprError
from k37.firmware_model.gcode.lex import Word
from k37.firmware_model.gcode.offsets import SYSTEMS, system_number
from k37.firmware_model.gcode.units import AXIS_LETTERS
from k37.firmware_model.gcode.words import G_CODES, code_key
from k37.firmware_model.motion.planner import Planner
from k37.hdl.common.constants import ALL_AXES

__all__ = ["InterpreterHost", "Modal", "PolarError", "State", "TooManyErrors"]

_INCH_MM = Decimal("25.4")
_MOTION = {k for k, c in G_CODES.items() if c.group == "motion"}
#: The last numbered parameter LinuxCNC's interpreter has.
_LAST_PREDEFINED = 5602


class Modal(Protocol):
    """The modal interpreter's state, as :mod:`k37.firmware_model.gcode.parser` keeps it."""

    inch: bool
    incremental: bool
    plane: int
    motion: int | None
    feed: float | None
    tool: int | None
    selected: int | None
    g92: list[int]
    g5x: dict[int, list[int]]
    tool_offset: int
    coordinate_system: int
    speed: float
    lsb_size: Decimal
    end: bool
    line_no: int
    planner: Planner
    exact: list[Decimal | None]

    @property
    def pos(self) -> tuple[int, int, int]: ...

    def offset(self, axis: int) -> int: ...

    def lsb(self, value: Decimal, inch: bool | None = None) -> int: ...

    def lsb_exact(self, value: Decimal) -> Decimal: ...

    def exact_pos(self, axis: int) -> Decimal: ...

    def block(self, words: list[Word]) -> None: ...

    def recover(self, words: list[Word]) -> None: ...

    def enter_call(self) -> None: ...

    def leave_call(self) -> None: ...


class PolarError(ValueError):
    def __init__(self, col: int, message: str):
        super().__init__(message)
        self.col, self.message = col, message


class State:
    """The predefined parameters and polar coordinates of one program's run, on the modal
    interpreter's exact position."""

    def __init__(self, modal: Modal):
        self.modal = modal
        #: A polar block's exact end (program units, by axis), kept once the block has run.
        self.pending: dict[int, float] = {}

    # -- lengths ------------------------------------------------------------------------------

    def unit_lsb(self) -> float:
        """One LSB in the program's units."""
        size = self.modal.lsb_size / _INCH_MM if self.modal.inch else self.modal.lsb_size
        return float(size)

    def length(self, lsb: int) -> float:
        """A length in LSB, in the program's units."""
        return lsb * self.unit_lsb()

    def position(self) -> tuple[float, float, float]:
        """The current position in the program's coordinates and units: the interpreter's
        exact one (its ``exact_pos``: the programmed position before its rounding, while the
        machine's rounds to it)."""
        m = self.modal
        x, y, z = (float(m.exact_pos(axis) - m.offset(axis)) * self.unit_lsb()
                   for axis in range(3))
        return x, y, z

    def after(self) -> None:
        """A block has run: a polar end becomes the interpreter's exact position."""
        pending, self.pending = self.pending, {}
        m = self.modal
        for axis, value in pending.items():
            m.exact[axis] = m.offset(axis) + m.lsb_exact(Decimal(repr(value)))

    def forget(self) -> None:
        self.pending = {}

    # -- polar coordinates --------------------------------------------------------------------

    def polar(self, words: list[Word]) -> list[Word]:
        """A block's ``@`` (radius) and ``^`` (angle, degrees) as X and Y words, as LinuxCNC
        finds a polar end point; other blocks unchanged."""
        if not any(w.letter in "@^" for w in words):
            return words
        radius = next((w for w in words if w.letter == "@"), None)
        angle = next((w for w in words if w.letter == "^"), None)
        first = radius or angle
        assert first is not None
        if any(w.letter in "XY" for w in words):
            raise PolarError(first.col, "polar coordinates (@, ^) and X or Y in one block")
        keys = [code_key(w.value) for w in words if w.letter == "G"]
        motion = next((k for k in keys if k in _MOTION), self.modal.motion)
        if 530 in keys or (motion not in (0, 10) and motion not in CYCLES):
            raise PolarError(first.col, "polar coordinates (@, ^) are for G00 and G01 moves "
                                        "and canned cycles (not G53 or arcs)")
        if {200, 210} & set(keys):
            raise PolarError(first.col, "polar coordinates and G20/G21 in one block: change "
                                        "the units on a line before")
        incremental = 910 in keys or (self.modal.incremental and 900 not in keys)
        cx, cy = self.position()[:2]
        if incremental:
            if cx == 0 and cy == 0:
                raise PolarError(first.col, "G91 polar coordinates at the origin: the "
                                            "direction is undefined")
            r, theta = math.hypot(cx, cy), math.atan2(cy, cx)
            if radius is not None:
                r += float(radius.value)
            if angle is not None:
                theta += math.radians(float(angle.value))
        else:
            if angle is None and cx == 0 and cy == 0:
                raise PolarError(first.col, "a polar radius without an angle at the origin: "
                                            "the direction is undefined")
            r = float(radius.value) if radius is not None else math.hypot(cx, cy)
            theta = (math.radians(float(angle.value)) if angle is not None
                     else math.atan2(cy, cx))
        px, py = r * math.cos(theta), r * math.sin(theta)
        self.pending = {0: px, 1: py}
        out = [w for w in words if w.letter not in "@^"]
        for axis, target in ((0, px), (1, py)):
            if incremental:  # the step that lands on the exact end's LSB
                lsb = (self.modal.offset(axis) + self.modal.lsb(Decimal(repr(target)))
                       - self.modal.pos[axis])
                value = Decimal(lsb) * self.modal.lsb_size
                value = value / _INCH_MM if self.modal.inch else value
            else:
                value = Decimal(repr(target))
            letter = AXIS_LETTERS[axis]
            out.append(Word(letter, f"{letter}{float(value):.6f}".rstrip("0").rstrip("."),
                            value, first.col))
        return out

    # -- predefined parameters ----------------------------------------------------------------

    def predefined(self, key: int | str, col: int) -> float | None:
        if isinstance(key, str):
            return self.named(key, col)
        m = self.modal
        n = key
        if not 5000 < n <= _LAST_PREDEFINED:
            return None
        if 5161 <= n <= 5169 or 5181 <= n <= 5189:
            return 0.0
        if n == 5210:
            return 1.0 if any(m.g92) else 0.0
        if 5211 <= n <= 5219:
            return self.length(m.g92[n - 5211]) if n <= 5213 else 0.0
        if n == 5220:
            return float(system_number(m.coordinate_system))
        if 5221 <= n <= 5390 and (n - 5221) % 20 <= 9:
            axis = (n - 5221) % 20
            return self.length(m.g5x[SYSTEMS[(n - 5221) // 20]][axis]) if axis < 3 else 0.0
        if n == 5400:
            return float(m.tool or 0)
        if 5401 <= n <= 5409:
            return self.length(m.tool_offset) if n == 5403 else 0.0
        if 5420 <= n <= 5428:
            return self.position()[n - 5420] if n <= 5422 else 0.0
        if 5061 <= n <= 5070:
            raise ExprError(col, f"#{n} is a probe result: probing (G38.x) is unsupported")
        if n == 5399:
            raise ExprError(col, "#5399 is M66's input: digital and analog inputs are "
                                 "unsupported")
        raise ExprError(col, f"the interpreter's parameter #{n} is unsupported here")

    def named(self, name: str, col: int) -> float | None:
        m = self.modal
        if name in ("_x", "_y", "_z"):
            return self.position()[ALL_AXES.index(name[1])]
        values = {
            "_a": 0.0, "_b": 0.0, "_c": 0.0, "_u": 0.0, "_v": 0.0, "_w": 0.0,
            "_metric": float(not m.inch), "_imperial": float(m.inch),
            "_absolute": float(not m.incremental), "_incremental": float(m.incremental),
            "_feed": 0.0 if m.feed is None else m.feed / (25.4 if m.inch else 1.0),
            "_motion_mode": 800.0 if m.motion is None else float(m.motion),
            "_plane": float(m.plane * 10), "_coord_system": float(m.coordinate_system),
            "_current_tool": float(m.tool or 0), "_rpm": m.speed,
            "_selected_tool": -1.0 if m.selected is None else float(m.selected),
        }
        if name in values:
            return values[name]
        if name.startswith(("_ini[", "_hal[")):
            raise ExprError(col, f"#<{name}>: INI and HAL values are unsupported (K37 has "
                                 f"no INI file or HAL)")
        return None


class TooManyErrors(Exception):  # noqa: N818 - the program stops, not an error of its own
    """The program has as many errors as are reported."""


class InterpreterHost:
    """The modal interpreter as :func:`k37.firmware_model.gcode.ngc.run` runs it
    (:class:`~k37.firmware_model.gcode.ngc.Host`): its errors (``block_error``, with ``col`` and
    ``message``) each reported once, at most ``max_errors``; messages as events."""

    def __init__(self, modal: Modal, block_error: type[Exception], max_errors: int):
        self.modal = modal
        self.block_error = block_error
        self.max_errors = max_errors
        self.state = State(modal)
        self.errors: list[tuple[int, int, str]] = []
        self.seen: set[tuple[int, int, str]] = set()
        self.notes: list[tuple[int, str]] = []

    @property
    def ended(self) -> bool:
        return self.modal.end

    def execute(self, line: int, words: list[Word]) -> None:
        self.modal.line_no = line
        try:
            words, again, repeats = cycle_repeats(words, self.modal.motion,
                                                  self.modal.incremental)
            for block in [words, *[again] * repeats]:  # a canned cycle's L repeats
                words = self.state.polar(block)
                self.modal.block(words)
                self.state.after()
        except (self.block_error, PolarError) as e:
            self.modal.recover(words)
            self.state.forget()
            self.error(line, getattr(e, "col", 1), getattr(e, "message", str(e)))

    def error(self, line: int, col: int, message: str) -> None:
        if (line, col, message) in self.seen:
            return  # a line in a loop: its error once
        self.seen.add((line, col, message))
        self.errors.append((line, col, message))
        if len(self.errors) == self.max_errors:
            self.errors.append((line, 1, f"stopped after {self.max_errors} errors"))
            raise TooManyErrors

    def note(self, line: int, text: str) -> None:
        self.notes.append((line, text))

    def message(self, line: int, kind: str, text: str) -> None:
        name = "MSG" if kind == "message" else kind.upper()
        self.modal.planner.event(line, f"({name},{text})", kind)

    def predefined(self, key: int | str, col: int) -> float | None:
        return self.state.predefined(key, col)

    def enter_call(self) -> None:
        self.modal.enter_call()

    def leave_call(self) -> None:
        self.modal.leave_call()
