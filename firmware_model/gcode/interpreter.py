"""The built-in front end's interpreter: modal state, and each block's words in RS-274's
order (:mod:`k37.firmware_model.gcode.parser` reads a program through it). Splines, parabolas
and exponentials, canned cycles and work offsets are in
:mod:`k37.firmware_model.gcode.spline_motions`, :mod:`k37.firmware_model.gcode.curve_motions`,
:mod:`k37.firmware_model.gcode.cycles` and :mod:`k37.firmware_model.gcode.offsets`."""

from __future__ import annotations

import math
from decimal import ROUND_HALF_UP, Decimal

from k37.firmware_model.gcode.block_words import BlockError, BlockWords, g_name
from k37.firmware_model.gcode.curve_motions import CurveMotions
from k37.firmware_model.gcode.cutter_comp import CutterComp
from k37.firmware_model.gcode.cycles import CYCLES, CannedCycles
from k37.firmware_model.gcode.lex import Word
from k37.firmware_model.gcode.modal_state import ModalState
from k37.firmware_model.gcode.offsets import SYSTEMS, Offsets
from k37.firmware_model.gcode.spline_motions import SplineMotions
from k37.firmware_model.gcode.tool_table import (
    ToolTable,
    table_tool,
    tool_entry,
    tool_number,
)
from k37.firmware_model.gcode.units import (
    ARC_TOLERANCE_MM,
    AXIS_LETTERS,
    INCH_MM,
    MAX_R_LSB,
    OFFSET_LETTERS,
    USES,
)
from k37.firmware_model.gcode.words import M_CODES
from k37.firmware_model.motion.planner import PlanError, Planner
from k37.hdl.common.constants import PLANE_AXES
from k37.hdl.k3701.block import COORD_MAX

__all__ = ["Interpreter"]


class Interpreter(SplineMotions, CurveMotions, CannedCycles, Offsets, ModalState, CutterComp):
    """The modal state of a program being read, and what each block does with it."""

    def __init__(self, planner: Planner, *, lsb_mm: float, tolerance: float | None,
                 tools: ToolTable | None):
        self.planner = planner
        self.lsb_size = Decimal(repr(lsb_mm))
        self.tolerance = tolerance
        self.tools = {n: tool_entry(t) for n, t in (tools or {}).items()}
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
        #: Each coordinate system's offsets (LSB), by its code (G54: 540).
        self.g5x: dict[int, list[int]] = {code: [0, 0, 0] for code in SYSTEMS}
        self.tool_offset = 0
        #: The tool length offset (LSB) in force at the last move (see M06's re-read).
        self.move_tool_offset = 0
        self.selected: int | None = None
        self.tool: int | None = None
        self.cycle: dict[str, Decimal] = {}
        self.cycle_planes: tuple[int, int, int] | None = None
        #: The Z where the canned cycles since the last other motion mode began (LSB).
        self.cycle_il: int | None = None
        self.line_no = 0
        #: The N-word of each line that has one (the program's own block numbers), by line.
        self.sequence: dict[int, int] = {}
        #: The G05.2 NURBS being read: control points (LSB), weights, order, its G05.2 word
        #: and line.
        self.nurbs: tuple[list[tuple[float, float]], list[float], int, Word, int] | None = None
        #: The last G05's second control point from its end (LSB), for the next G05.
        self.g05_pq: tuple[float, float] | None = None
        #: The programmed position before its rounding to the LSB grid (LSB), per axis, as the
        #: last move's words gave it (None: unknown); incremental words add to it, so their
        #: roundings do not add up. Valid while it rounds to the position (:meth:`exact_pos`).
        self.exact: list[Decimal | None] = [None, None, None]
        #: What the last :meth:`target` computed, kept by :meth:`keep_exact` once it is run.
        self.pending_exact: list[Decimal | None] = [None, None, None]
        self.init_modal_state()
        self.init_cutter_comp()

    # -- helpers ----------------------------------------------------------------------------

    @property
    def pos(self) -> tuple[int, int, int]:
        """The programmed position (the machine's may be up to 1 LSB off after an arc)."""
        return self.planner.programmed

    def lsb(self, value: Decimal, inch: bool | None = None) -> int:
        mm = value * INCH_MM if (self.inch if inch is None else inch) else value
        return int((mm / self.lsb_size).to_integral_value(rounding=ROUND_HALF_UP))

    def lsb_exact(self, value: Decimal) -> Decimal:
        """A length word in LSB, unrounded."""
        return (value * INCH_MM if self.inch else value) / self.lsb_size

    def exact_pos(self, axis: int) -> Decimal:
        """The programmed position on ``axis`` before its rounding: :attr:`exact` while it
        rounds to the position, else the position."""
        e = self.exact[axis]
        if e is not None and int(e.to_integral_value(rounding=ROUND_HALF_UP)) == self.pos[axis]:
            return e
        return Decimal(self.pos[axis])

    def keep_exact(self) -> None:
        """The last :meth:`target`'s exact coordinates become the position's (after its move
        was planned)."""
        for axis, value in enumerate(self.pending_exact):
            if value is not None:
                self.exact[axis] = value

    def check_range(self, word: Word, value: int, what: str) -> None:
        if abs(value) > COORD_MAX:
            raise BlockError(word.col, f"{word.text}: {what} {value} LSB is outside "
                                  f"-(2^23-1)..2^23-1 LSB (+-{self.planner.mm(COORD_MAX)})")

    def target(self, b: BlockWords, *, machine: bool = False,
               incremental: bool | None = None) -> tuple[int, int, int]:
        """The absolute machine target of a block's X/Y/Z words (unnamed axes stay)."""
        incremental = self.incremental if incremental is None else incremental
        target = list(self.pos)
        self.pending_exact = [None, None, None]
        for axis, letter in enumerate(AXIS_LETTERS):
            w = b.word(letter)
            if w is None:
                continue
            target[axis], self.pending_exact[axis] = self.word_target(axis, w, incremental,
                                                                       machine)
            self.check_range(w, target[axis], "the position")
            self.check_range(w, target[axis] - self.pos[axis], "the move")
            if axis == 2 and self.planner.axes == 2 and target[2] != self.pos[2]:
                raise BlockError(w.col, f"{w.text} moves Z: this machine has two axes "
                                   f"(machine.axes = 3 runs it)")
        return target[0], target[1], target[2]

    def exact_target(self) -> tuple[float, float, float]:
        """The last :meth:`target` before its words were rounded to the LSB grid (LSB)."""
        x, y, z = (float(p if e is None else e) for p, e in zip(self.pos, self.pending_exact,
                                                                strict=True))
        return x, y, z

    def word_target(self, axis: int, w: Word, incremental: bool,
                    machine: bool) -> tuple[int, Decimal]:
        """Where an axis word goes, in LSB: rounded, and before its rounding. An incremental
        word adds to the exact position (:meth:`exact_pos`), so roundings do not add up; an
        absolute one is rounded on its own."""
        if incremental:
            exact = self.exact_pos(axis) + self.lsb_exact(w.value)
            return int(exact.to_integral_value(rounding=ROUND_HALF_UP)), exact
        base = self.base(axis, False, machine)
        exact = self.lsb_exact(w.value)  # rounded on its own, as lsb() rounds it
        return base + int(exact.to_integral_value(rounding=ROUND_HALF_UP)), base + exact

    def base(self, axis: int, incremental: bool, machine: bool) -> int:
        """What an axis word adds to: the position (G91), the origin (G53), else the offsets."""
        return self.pos[axis] if incremental else (0 if machine else self.offset(axis))

    def plan(self, col: int, call, *args, **kwargs) -> None:
        if self.comp_side and self.comp_radius > 0:  # D0: the path as programmed
            self.comp_move(col, call, args, kwargs)
            self.move_tool_offset = self.tool_offset
            return
        try:
            call(self.line_no, *args, **kwargs)
        except PlanError as e:
            raise BlockError(col, str(e)) from None
        self.move_tool_offset = self.tool_offset

    def event(self, w: Word, kind: str, value: float | None = None) -> None:
        self.planner.event(self.line_no, w.text, kind, value)
        self.track(kind, value)

    # -- one block --------------------------------------------------------------------------

    def block(self, words: list[Word]) -> None:
        b = BlockWords(words)
        n = b.word("N")
        if n is not None and (n.value < 0 or n.value != n.value.to_integral_value()):
            raise BlockError(n.col, f"{n.text}: N must be a non-negative integer")
        if n is not None:
            self.sequence[self.line_no] = int(n.value)
        units = b.code("units")
        if units is not None:
            self.inch = units == 200
        self.feed_mode(b)
        self.feed_word(b)
        self.spindle_tool_coolant(b)
        self.modal_state(b)
        if "non-modal" in b.g and b.g["non-modal"][0] == 40:
            self.dwell(b)
        elif b.word("P") is not None and not self.takes_p(b):
            p = b.word("P")
            raise BlockError(p.col, f"{p.text}: P is only for G04 (dwell), G10, G82, G64 and "
                                    f"arcs")
        self.modal_settings(b)
        self.cutter_mode(b)
        self.non_modal(b)
        self.motion_of(b)
        if "tool change" in b.m:
            self.resync_after_tool_change()
        if "stop" in b.m:
            key, w = b.m["stop"]
            if key in (2, 30):
                self.comp_off(w)
                self.end = True
            else:
                self.event(w, M_CODES[key].event)

    def resync_after_tool_change(self) -> None:
        """At the end of an M06 block the program position is re-read from the last move's,
        as ``rs274`` does: a tool length set since moves the next move's Z by the change (and
        one where G40 left the tool is the tool's)."""
        self.comp_tool_change()
        shift = self.tool_offset - self.move_tool_offset
        if shift and self.planner.axes == 3:
            x, y, z = self.planner.programmed
            self.planner.programmed = (x, y, z + shift)
        self.move_tool_offset = self.tool_offset

    def recover(self, words: list[Word]) -> None:
        """After a refused block: its programmed end becomes the next block's start, as if it
        had run, so that the blocks after it are checked from where the program meant to be
        and one fault is reported once. A block that sets rather than moves (G04, G10, G28,
        G92, ...) or whose end cannot be known moves nothing."""
        try:
            b = BlockWords(words)
        except BlockError:
            return
        if "non-modal" in b.g or not any(b.word(a) for a in AXIS_LETTERS):
            return
        target = list(self.pos)
        for axis, letter in enumerate(AXIS_LETTERS):
            w = b.word(letter)
            if w is not None and (axis < 2 or self.planner.axes == 3):
                target[axis] = self.word_target(axis, w, self.incremental, False)[0]
        if all(abs(v) <= COORD_MAX for v in target):
            self.planner.position = self.planner.programmed = (target[0], target[1], target[2])

    def takes_p(self, b: BlockWords) -> bool:
        motion = b.code("motion") if "motion" in b.g else self.motion
        return (b.code("path") == 640 or motion in (20, 30, 50, 52, 820)
                or b.code("non-modal") == 100 or self.nurbs is not None)

    def arc_tolerance(self) -> float:
        """The arc tolerance in LSB (the program's, or LinuxCNC's in the units in force)."""
        if self.tolerance is not None:
            return self.tolerance
        return ARC_TOLERANCE_MM[self.inch] / float(self.lsb_size)

    def feed_word(self, b: BlockWords) -> None:
        f = b.word("F")
        if f is None or self.inverse_time:
            return
        if f.value <= 0:
            raise BlockError(f.col, f"{f.text}: the feed must be positive")
        self.feed = float(f.value * INCH_MM if self.inch else f.value)
        self.feed_source = (self.line_no, f.col, f.text)

    def spindle_tool_coolant(self, b: BlockWords) -> None:
        s, t = b.word("S"), b.word("T")
        if s is not None:
            if s.value < 0:
                raise BlockError(s.col, f"{s.text}: the spindle speed must not be negative")
            self.event(s, "spindle_speed", float(s.value))
        if t is not None:
            if t.value < 0 or t.value != t.value.to_integral_value():
                raise BlockError(t.col, f"{t.text}: T must be a non-negative integer")
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

    def dwell(self, b: BlockWords) -> None:
        g4 = b.g["non-modal"][1]
        for letter in AXIS_LETTERS if "motion" not in b.g else "":  # else: the motion's
            if b.word(letter) is not None:
                w = b.word(letter)
                raise BlockError(w.col, f"{w.text}: G04 takes only P (seconds)")
        p = b.word("P")
        if p is None:
            raise BlockError(g4.col, "G04 needs P (the dwell in seconds)")
        if p.value < 0:
            raise BlockError(p.col, f"{p.text}: the dwell must not be negative")
        self.planner.dwell(self.line_no, float(p.value))

    def modal_settings(self, b: BlockWords) -> None:
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
            raise BlockError(h.col, f"{h.text}: H is only for G43 (tool length offset)")
        if length == 490:
            self.tool_offset = 0
        elif length == 430:
            self.tool_offset = self.tool_length(b.g["tool length"][1], h)

    def tool_length(self, g43: Word, h: Word | None) -> int:
        number = self.tool if h is None else tool_number(h)
        return self.lsb(Decimal(repr(table_tool(self.tools, number, h or g43).length)),
                        inch=False)

    def non_modal(self, b: BlockWords) -> None:
        if "non-modal" not in b.g:
            return
        key, w = b.g["non-modal"]
        if key in (280, 300):
            if b.code("motion") is not None:
                raise BlockError(w.col, f"{w.text} and a motion code in one block")
            via = self.target(b)
            self.plan(w.col, self.planner.line, via, None)
            named = [b.word(letter) is not None for letter in AXIS_LETTERS]
            home = tuple(0 if (named[a] or not any(named)) else via[a] for a in range(3))
            self.check_z(w, home)
            self.plan(w.col, self.planner.line, home, None)
        elif key in (100, 520, 920, 921):
            self.set_offsets(b, key, w)

    def check_z(self, w: Word, target: tuple[int, ...]) -> None:
        if self.planner.axes == 2 and target[2] != self.pos[2]:
            raise BlockError(w.col, f"{w.text} moves Z: this machine has two axes "
                               f"(machine.axes = 3 runs it)")

    def axis_words(self, b: BlockWords) -> list[Word]:
        return [w for letter in AXIS_LETTERS if (w := b.word(letter)) is not None]

    # -- motion -----------------------------------------------------------------------------

    def motion_of(self, b: BlockWords) -> None:
        g = b.g.get("motion")
        order = b.word("L")
        g10 = b.code("non-modal") == 100
        comp = b.code("cutter") in (410, 411, 420, 421)  # L: a lathe tool's orientation
        if order is not None and not (g10 or comp) and (g is None or g[0] != 52
                                                        or self.nurbs is not None):
            raise BlockError(order.col, f"{order.text}: L is only for G05.2 (a NURBS's order), "
                                        f"G10, G41/G42 and canned cycles (repeats)")
        if self.nurbs is not None or (g is not None and g[0] in (52, 53)):
            for letter in "IJKRQ":
                w = b.word(letter)
                if w is not None:
                    raise BlockError(w.col, f"{w.text}: a G05.2 NURBS takes X, Y, P and L")
            self.nurbs_block(b, g)
            return
        if g is not None:
            if g[0] != self.motion:
                self.cycle, self.cycle_planes = {}, None
                self.cycle_il = self.cycle_il if g[0] in CYCLES else None
            self.motion = None if g[0] == 800 else g[0]
        if "non-modal" in b.g and b.g["non-modal"][0] in (100, 280, 300, 520, 920):
            return  # their axis words are theirs
        axes = self.axis_words(b)
        for letter in "IJKRQ":
            w = b.word(letter)
            if w is not None and not self.uses(letter, b):
                raise BlockError(w.col, f"{w.text}: {letter} is only for "
                                   f"{'arcs (G02/G03)' if letter in 'IJK' else USES[letter]}")
        if not axes and not (g is not None and g[0] in (20, 30, 60) and self.has_offsets(b)):
            return
        if self.motion is None:
            if g is not None and g[0] == 800:
                raise BlockError(axes[0].col, f"{axes[0].text}: G80 cancels the motion mode")
            raise BlockError(axes[0].col, f"{axes[0].text} without a motion mode "
                                           f"(G00/G01/G02/G03)")
        anchor = g[1] if g is not None else axes[0]
        self.comp_exit_rule(anchor.col)
        if self.motion not in (0, 10, 20, 30):
            self.inverse_time_feed(anchor, 0.0)  # refused in G93
        if self.motion != 0 and self.feed is None and not self.inverse_time:
            raise BlockError(anchor.col, f"{g_name(self.motion)} without a feed rate: program "
                                    f"F first")
        machine = "non-modal" in b.g and b.g["non-modal"][0] == 530
        if machine and self.motion not in (0, 10):
            raise BlockError(b.g["non-modal"][1].col, "G53 is only for G00/G01 moves")
        if machine and self.incremental:
            raise BlockError(b.g["non-modal"][1].col, "G53 takes absolute machine "
                                                      "coordinates: not in G91")
        if self.motion in (0, 10):
            target = self.target(b, machine=machine, incremental=False if machine else None)
            if self.motion == 10:
                self.inverse_time_feed(anchor, math.dist(self.pos, target))
            self.plan(anchor.col, self.planner.line, target,
                      None if self.motion == 0 else self.feed, feed_source=self.feed_source)
            self.keep_exact()
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

    def uses(self, letter: str, b: BlockWords) -> bool:
        if letter in "IJK":
            return (self.motion in (20, 30) or (self.motion in (50, 51, 60) and letter != "K")
                    or (self.motion in (61, 62) and letter == "K"))
        if letter == "R":
            return self.motion in (20, 30, 810, 820, 830)
        return self.motion in (50, 830) or b.code("path") == 640  # Q

    def has_offsets(self, b: BlockWords) -> bool:
        return any(b.word(letter) is not None for letter in OFFSET_LETTERS)

    def arc(self, b: BlockWords, anchor: Word) -> None:
        first, second, normal = PLANE_AXES[self.plane]
        cw = self.motion == 20
        name = f"G0{self.motion // 10}"
        wrong = OFFSET_LETTERS[normal]
        if b.word(wrong) is not None:
            w = b.word(wrong)
            raise BlockError(w.col, f"{w.text}: a G{self.plane} arc takes "
                               f"{OFFSET_LETTERS[first]} and {OFFSET_LETTERS[second]}")
        if self.planner.axes == 2 and self.plane != 17:
            raise BlockError(anchor.col, f"{name} in G{self.plane} moves Z: this machine has two "
                                    f"axes (machine.axes = 3 runs it)")
        p = b.word("P")
        if p is not None and p.value != 1:
            raise BlockError(p.col, f"{p.text}: arcs of more than one turn are unsupported")
        target = self.target(b)
        start = self.pos
        r = b.word("R")
        if r is not None:
            if self.has_offsets(b):
                raise BlockError(r.col, f"{r.text}: an arc takes R or centre offsets, not both")
            centre = [round(c) for c in self.centre_from_radius(r, start, target, first,
                                                                 second, cw)]
        elif not self.has_offsets(b):
            raise BlockError(anchor.col, f"{name} needs {OFFSET_LETTERS[first]} and/or "
                                    f"{OFFSET_LETTERS[second]} (the centre offsets) or R")
        else:
            centre = []
            for axis in (first, second):
                w = b.word(OFFSET_LETTERS[axis])
                if self.arc_absolute:
                    c = self.offset(axis) + self.lsb(w.value) if w else self.offset(axis)
                else:
                    c = start[axis] + (self.lsb(w.value) if w else 0)
                centre.append(c)  # beyond the K3701's registers: the planner runs chords
        if self.comp_side:
            self.comp_arc_centre = self.comp_centre(b, r, first, second, cw)
        if self.inverse_time:
            self.inverse_time_feed(anchor, self.arc_length((centre[0], centre[1]), target,
                                                           PLANE_AXES[self.plane], cw))
        self.plan(anchor.col, self.planner.arc, target, (centre[0], centre[1]), self.plane,
                  cw, self.feed, tolerance=self.arc_tolerance(), feed_source=self.feed_source,
                  exact=self.exact_target())
        self.keep_exact()

    def centre_from_radius(self, r: Word, start, target, first: int, second: int,
                           cw: bool, exact: bool = False) -> tuple[float, float]:
        """RS-274's R form: the centre on the chord's bisector, left of the chord for CCW,
        right for CW (R < 0: the other side, the arc over 180 degrees; ``exact``: R before its
        rounding to the LSB). A centre beyond the K3701's registers runs as chords."""
        sx, sy = start[first], start[second]
        ex, ey = target[first], target[second]
        radius = float(self.lsb_exact(r.value)) if exact else self.lsb(r.value)
        if abs(radius) > MAX_R_LSB:
            raise BlockError(r.col, f"{r.text}: the radius is outside -(2^40)..2^40 LSB "
                                    f"(+-{self.planner.mm(MAX_R_LSB)})")
        chord = math.hypot(ex - sx, ey - sy)
        if chord == 0:
            raise BlockError(r.col, f"{r.text}: an R-form arc cannot be a full circle (use I/J/K)")
        if radius == 0 or abs(radius) < chord / 2 - 0.5:
            raise BlockError(r.col, f"{r.text}: the radius is shorter than half the distance to "
                               f"the end point ({self.planner.mm(chord / 2)})")
        h = math.sqrt(max(0.0, radius * radius - chord * chord / 4))
        side = (1 if cw else -1) * (1 if radius > 0 else -1)
        ux, uy = (ex - sx) / chord, (ey - sy) / chord
        return (sx + ex) / 2 + side * h * uy, (sy + ey) / 2 - side * h * ux
