"""Cutter radius compensation, G41/G42 (the diameter of the loaded tool, or of tool D, from
the job's tool table), G41.1/G42.1 D (the cutter's diameter; L, a lathe tool's orientation,
in G18) and G40, in G17 and G18 (not G19, as LinuxCNC), as LinuxCNC's interpreter does it
(a mixin of :class:`k37.firmware_model.gcode.interpreter.Interpreter`).

The tool runs at the cutter's radius to the left (G41.1) or right (G42.1) of the programmed
path, in the plane's own coordinates (G18: Z, X; the plane cannot change while it is on).
The first move after turning it on (its end farther than the radius from its start) ends at
the radius from its programmed end, square to the path there: a line straight to it, an arc
on an arc from the tool's position. Each later move is held back until the next one is
known: where they meet at an outside corner the tool goes round the corner's point on an
arc of the cutter's radius; at an inside corner the held move ends where the two compensated
paths cross; corners within 0.05 rad of straight join directly, as LinuxCNC's. An arc's
compensated radius is its radius plus or minus the cutter's (an error when it is not
positive). G40 ends it: the held move runs to its square end and the next move (the exit,
a line) goes from there to its programmed point. Wherever rs274 moves or flushes a held
move's end (an inside corner, an outside corner before a line, G40, the program's end) it
checks it as rs274 does: a line must not run backwards, an arc not turn further than
programmed, else the tool would gouge (an error at that block). The program's position
stays the programmed one (G91 and arc centres add to it). G41.1/G42.1 D0 runs the path as
programmed; G41/G42 D0 takes the loaded tool's diameter, as without D (no tool loaded:
zero).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from decimal import ROUND_HALF_UP, Decimal

from k37.firmware_model.gcode.block_words import BlockError, BlockWords, g_name
from k37.firmware_model.gcode.comp_geometry import (
    arc_line_corner,
    circles,
    line_circle,
    sweep,
    unit,
)
from k37.firmware_model.gcode.lex import Word
from k37.firmware_model.gcode.tool_table import table_tool, tool_number
from k37.firmware_model.motion.planner import PlanError
from k37.hdl.common.constants import PLANE_AXES

__all__ = ["CutterComp"]

#: rs274 reads a tool table's diameters in inches, converting them with its external length
#: unit, 0.03937007874016 in per mm (a hair over 1/25.4): a table tool's radius is this much
#: under its nominal, and a move or an arc exactly as long as the radius passes its tests.
RS274_TABLE_SCALE = Decimal("25.4") * Decimal("0.03937007874016")

#: Corners within this angle (radians) of straight join without an arc or an intersection.
SMALL = 0.05


@dataclass(frozen=True)
class _Move:
    """A compensated move held back: its start and end (LSB, XY), its Z, and, for an arc,
    its centre (on the LSB grid for the planner, and ``exact``) and direction; a line's
    ``along`` is its programmed direction (an inside corner moves its end back along it).
    rs274's gouge check of a moved end: a line's must not be behind its start seen along
    ``gouge_dir`` (its programmed direction; the entry line's: the side the tool goes to),
    an arc's must not make it turn more than ``sweep`` (radians: the programmed arc's; the
    entry arc's own). ``then``: the moves along the plane's normal after it (their end, feed,
    feed's source, line and column), held with it: they run where it ends, as rs274 moves the
    end of each move it holds."""

    start: tuple[float, float]
    end: tuple[float, float]
    z: int
    feed: float | None
    feed_source: tuple[int, int, str] | None
    line_no: int
    col: int
    centre: tuple[int, int] | None = None
    cw: bool = False
    tolerance: float = 0.0
    along: tuple[float, float] = (1.0, 0.0)
    exact: tuple[float, float] = (0.0, 0.0)
    gouge_dir: tuple[float, float] = (1.0, 0.0)
    sweep: float = 0.0
    then: tuple[tuple[int, float | None, tuple[int, int, str] | None, int, int], ...] = ()

    @property
    def last_z(self) -> int:
        """The position along the plane's normal after it and the moves ``then``."""
        return self.then[-1][0] if self.then else self.z


def _back(held: _Move, point: tuple[float, float]) -> float:
    """How far back along the held move from its end ``point`` is (LSB along a line, radians
    around an arc); negative: ahead of its end."""
    if held.centre is None:
        return ((held.end[0] - point[0]) * held.along[0]
                + (held.end[1] - point[1]) * held.along[1])
    c = held.exact
    turn = math.atan2(held.end[1] - c[1], held.end[0] - c[0]) - math.atan2(point[1] - c[1],
                                                                          point[0] - c[0])
    return (-turn if held.cw else turn) % (2 * math.pi)


class CutterComp:
    """The cutter radius compensation of the interpreter (its state: ``comp_side`` 0, +1
    left, -1 right; ``comp_radius`` LSB; ``comp_held``, the move held back; ``comp_entry``,
    the next move is the entry move; ``comp_arc_centre``)."""

    def init_cutter_comp(self) -> None:
        self.comp_side = 0
        self.comp_plane = 17
        self.comp_radius = 0.0
        #: A lathe tool's shift (LSB, the plane's coordinates) from its orientation (L).
        self.comp_shift = (0.0, 0.0)
        self.comp_held: _Move | None = None
        self.comp_entry = False
        #: G40 ended compensation and no line has run since (the next move cannot be an arc).
        self.comp_exited = False
        #: Where G40 left the tool (its exact point in the plane, and the machine's position).
        self.comp_exit: tuple[tuple[float, float], tuple[int, ...]] | None = None
        #: The exact centre of the arc being planned (set by the interpreter's arc).
        self.comp_arc_centre = (0.0, 0.0)

    def cutter_mode(self, b: BlockWords) -> None:
        """G40, G41/G42 (the diameter of the loaded tool, or of tool D, from the job's tool
        table) and G41.1/G42.1 D, after the block's other modal settings."""
        d = b.word("D")
        mode = b.code("cutter")
        if d is not None and mode not in (410, 420, 411, 421):
            raise BlockError(d.col, f"{d.text}: D is only for G41/G42 (a tool number) and "
                                    f"G41.1/G42.1 (the cutter's diameter)")
        plane = b.g.get("plane")
        if self.comp_side and plane is not None and self.plane != self.comp_plane:
            self.plane = self.comp_plane
            raise BlockError(plane[1].col, f"{plane[1].text}: the plane cannot change with "
                                           f"cutter radius compensation on (G40 first)")
        if mode is None:
            return
        w = b.g["cutter"][1]
        if mode == 400:
            self.comp_off(w)
            return
        if self.comp_side:
            raise BlockError(w.col, f"{w.text}: cutter radius compensation is already on (G40 "
                                    f"first)")
        if self.plane == 19:
            raise BlockError(w.col, f"{w.text} in G19: cutter radius compensation is in the XY "
                                    f"and XZ planes (G17, G18), as LinuxCNC's")
        if mode in (410, 420):
            number = (0 if d is None else tool_number(d)) or self.tool  # D0: loaded
            diameter = (Decimal(repr(table_tool(self.tools, number, d or w).diameter))
                        / self.lsb_size / RS274_TABLE_SCALE)
        elif d is None or d.value < 0:
            raise BlockError(w.col, f"{w.text} needs D, the cutter's diameter (>= 0)")
        else:
            diameter = self.lsb_exact(d.value)
        self.comp_shift = self.comp_orientation(b, mode, float(diameter) / 2)
        self.comp_side = 1 if mode in (410, 411) else -1
        self.comp_plane = self.plane
        self.comp_radius = float(diameter) / 2
        self.comp_entry = True

    def comp_orientation(self, b: BlockWords, mode: int, r: float) -> tuple[float, float]:
        """G41.1/G42.1's L, a lathe tool's orientation (1-9, LinuxCNC's, in G18 only): the
        path is that of the point the tool's length is set to, ``r`` (the cutter's radius)
        off the cutter's centre in Z for orientations 1-5 and 7, in X for 1-4, 6 and 8, as
        rs274 shifts it."""
        w = b.word("L")
        if w is None or mode in (410, 420):  # G41/G42: the table's tools have none
            return 0.0, 0.0
        if self.plane != 18:
            raise BlockError(w.col, f"{w.text}: G41.1/G42.1's L (a lathe tool's orientation) "
                                    f"is for G18")
        if w.value != w.value.to_integral_value():
            raise BlockError(w.col, f"{w.text}: L must be an integer")
        o = int(w.value)
        z = -r if o in (2, 7, 3) else r if o in (1, 5, 4) else 0.0
        x = -r if o in (2, 6, 1) else r if o in (3, 8, 4) else 0.0
        return z, x

    def comp_centre(self, b: BlockWords, r: Word | None, first: int, second: int,
                    cw: bool) -> tuple[float, float]:
        """An arc's centre before its rounding to the LSB grid, from the exact programmed
        start and end, as rs274 has it (the compensated path is offset from it)."""
        start = tuple(float(self.exact_pos(axis)) for axis in range(3))
        end = self.exact_target()
        if r is not None:
            return self.centre_from_radius(r, start, end, first, second, cw, exact=True)
        centre = []
        for axis in (first, second):
            w = b.word("IJK"[axis])
            offset = 0.0 if w is None else float(self.lsb_exact(w.value))
            centre.append(offset + (self.offset(axis) if self.arc_absolute else start[axis]))
        return centre[0], centre[1]

    def comp_flush(self) -> None:
        """Run the held move as it is (its end square to its path)."""
        held, self.comp_held = self.comp_held, None
        if held is not None:
            self.comp_run(held)

    def comp_off(self, w: Word) -> None:
        """The end of compensation (by ``w``, G40 or the program's end): the held move runs
        as it is, unless it would gouge; the next move is a line."""
        held = self.comp_held
        if held is not None and self.comp_gouges(held, held.end):
            self.comp_held, self.comp_entry = None, True
            raise BlockError(w.col, self.comp_gouge_message(held, w.text))
        active = self.comp_side != 0 and self.comp_radius > 0 and not self.comp_entry
        self.comp_exited = self.comp_exited or active
        first, second, _ = PLANE_AXES[self.comp_plane]
        tool = ((held.end[0] + self.comp_shift[0], held.end[1] + self.comp_shift[1])
                if held is not None else (self.planner.position[first],
                                          self.planner.position[second]))
        self.comp_flush()
        if active:
            self.comp_exit = tool, self.planner.position
        self.comp_side = 0

    def comp_tool_change(self) -> None:
        """After a tool change, rs274 rereads the program's position from the machine's: one
        where G40 left the tool (no move since) is the tool's, off the programmed path."""
        exit_, self.comp_exit = self.comp_exit, None
        if exit_ is None or exit_[1] != self.planner.position:
            return
        programmed = list(self.planner.programmed)
        for axis, value in zip(PLANE_AXES[self.comp_plane][:2], exit_[0], strict=True):
            self.exact[axis] = Decimal(repr(value))
            programmed[axis] = int(self.exact[axis].to_integral_value(rounding=ROUND_HALF_UP))
        self.planner.programmed = tuple(programmed)

    def comp_exit_rule(self, col: int) -> None:
        """rs274's rule after G40: the move that follows it is a line, not an arc."""
        if self.motion in (0, 10):
            self.comp_exited = False
        elif self.motion in (20, 30) and self.comp_exited:
            raise BlockError(col, f"{g_name(self.motion)} just after G40: the move after the "
                                  f"end of cutter radius compensation is a line (G00/G01)")

    def comp_gouges(self, held: _Move, point: tuple[float, float]) -> bool:
        """Whether ending the held move at ``point`` would gouge, by rs274's test: a line
        that would run backwards, an arc that would turn further than it was programmed to
        (by 0.0254 rad in G21, 0.001 rad in G20)."""
        if held.centre is None:
            return ((point[0] - held.start[0]) * held.gouge_dir[0]
                    + (point[1] - held.start[1]) * held.gouge_dir[1]) < -1e-6
        turned = sweep(held.start, held.exact, held.cw, point)
        return turned > held.sweep + (0.001 if self.inch else 0.0254)

    def comp_gouge_message(self, held: _Move, where: str) -> str:
        """The error of a held move too short to reach ``where`` without gouging."""
        what = "line" if held.centre is None else "arc"
        return (f"cutter radius compensation: the {what} before {where} is too short for a "
                f"cutter of radius {self.planner.mm(self.comp_radius)} (it would gouge)")

    def comp_run(self, move: _Move) -> None:
        """Plan ``move`` from the machine's position (the program's position kept)."""
        programmed = self.planner.programmed
        self.planner.programmed = self.planner.position
        sa, sb = self.comp_shift  # a lathe tool's
        end = move.end[0] + sa, move.end[1] + sb
        target = self.comp_point(round(end[0]), round(end[1]), move.z)
        try:
            if move.centre is None:
                self.planner.line(move.line_no, target, move.feed, feed_source=move.feed_source)
            else:
                centre = move.centre if self.comp_shift == (0.0, 0.0) else (
                    round(move.exact[0] + sa), round(move.exact[1] + sb))
                self.planner.arc(move.line_no, target, centre, self.comp_plane, move.cw,
                                 move.feed, tolerance=move.tolerance,
                                 feed_source=move.feed_source,
                                 exact=self.comp_point(end[0], end[1], float(move.z)))
        except PlanError as e:
            raise BlockError(move.col, str(e)) from None
        finally:
            self.planner.programmed = programmed
        for z, feed, feed_source, line_no, col in move.then:
            self.comp_run(_Move(move.end, move.end, z, feed, feed_source, line_no, col))

    def comp_point(self, first: float, second: float, normal: float) -> tuple[float, ...]:
        """The point (X, Y, Z) of the plane's coordinates ``first``, ``second`` and the
        position ``normal`` along its normal axis."""
        point = [0.0, 0.0, 0.0]
        for axis, value in zip(PLANE_AXES[self.comp_plane], (first, second, normal),
                               strict=True):
            point[axis] = value
        return tuple(point)

    def comp_normal(self, direction: tuple[float, float]) -> tuple[float, float]:
        """The unit vector from the path to the tool, for a path going ``direction``."""
        return -direction[1] * self.comp_side, direction[0] * self.comp_side

    def comp_move(self, col: int, call, args: tuple, kwargs: dict) -> None:
        """A line or arc of the program (``call`` the planner's, with its arguments) run
        compensated."""
        if self.motion not in (0, 10, 20, 30) or call not in (self.planner.line,
                                                               self.planner.arc):
            name = "this move" if self.motion is None else g_name(self.motion)
            raise BlockError(col, f"{name} with cutter radius compensation: G40 first")
        first, second, normal = PLANE_AXES[self.comp_plane]
        start = (float(self.exact_pos(first)), float(self.exact_pos(second)))
        target = args[0]
        exact_target = self.exact_target()
        end = exact_target[first], exact_target[second]
        if call == self.planner.line:
            feed = args[1]
            if (target[first], target[second]) == (self.pos[first], self.pos[second]) and (
                    not self.comp_entry):  # (the entry move is in the plane: see comp_enter)
                held = self.comp_held  # along the plane's normal only: held with it
                assert held is not None
                self.comp_held = replace(held, then=(*held.then, (
                    target[normal], feed, kwargs.get("feed_source"), self.line_no, col)))
                self.planner.programmed = target
                return
            along = unit(end[0] - start[0], end[1] - start[1]) if end != start else (1.0, 0.0)
            move = _Move((0.0, 0.0), (0.0, 0.0), target[normal], feed,
                         kwargs.get("feed_source"), self.line_no, col, gouge_dir=along)
        else:
            centre, _, cw, feed = args[1:5]
            exact = self.comp_arc_centre
            move = _Move((0.0, 0.0), (0.0, 0.0), target[normal], feed,
                         kwargs.get("feed_source"), self.line_no, col, centre, cw,
                         kwargs["tolerance"], exact=exact,
                         sweep=sweep(start, exact, cw, end))
            radial = unit(start[0] - exact[0], start[1] - exact[1])
            along = (radial[1], -radial[0]) if cw else (-radial[1], radial[0])
        try:
            if self.comp_entry:
                self.comp_enter(move, start, end, col)
            else:
                self.comp_corner(replace(move, along=along), start, end)
        except BlockError:  # the moves after it start again, as after an entry
            self.comp_held, self.comp_entry = None, True
            raise
        self.planner.programmed = target

    def comp_enter(self, move: _Move, tool: tuple[float, float], target: tuple[float, float],
                   col: int) -> None:
        """The entry move, from the tool's position ``tool`` (the programmed one): a line
        ends square to its direction; an arc ends square to its programmed end, on an arc
        from the tool's position whose centre is on the line from that end to the programmed
        centre (as rs274's)."""
        r = self.comp_radius
        if math.dist(tool, target) <= r:
            raise BlockError(col, "the cutter radius compensation entry move is not longer "
                                  "than the cutter's radius" if move.centre is None else
                                  "the cutter radius compensation entry arc ends within the "
                                  "cutter's radius of its start")
        if move.centre is None:
            along = unit(target[0] - tool[0], target[1] - tool[1])
            n = self.comp_normal(along)
            self.comp_held = replace(move, start=tool, end=(target[0] + r * n[0],
                                                            target[1] + r * n[1]),
                                     along=along, gouge_dir=n)
            self.comp_entry = False
            return
        if self.comp_shift != (0.0, 0.0):
            # (rs274 runs a line to the tool's point first, and then moves that line's end
            # with the arc's wherever the arc's end moves)
            raise BlockError(col, "an entry arc with a lathe tool's orientation (G41.1/G42.1 "
                                  "L1-L8) is unsupported: enter with a line")
        end = self.comp_end(move, tool, target)
        c = move.exact
        toward = math.atan2(c[1] - end[1], c[0] - end[0])
        cos_a = math.cos(math.atan2(tool[1] - end[1], tool[0] - end[0]) - toward)
        if abs(cos_a) < 1e-6:
            raise BlockError(col, "the cutter radius compensation entry arc cannot start at "
                                  "the tool: its compensated centre is at infinity")
        reach = math.dist(tool, end) / 2 / cos_a
        centre = (end[0] + reach * math.cos(toward), end[1] + reach * math.sin(toward))
        self.comp_held = replace(move, start=tool, end=end, exact=centre,
                                 centre=(round(centre[0]), round(centre[1])),
                                 sweep=sweep(tool, centre, move.cw, end))
        self.comp_entry = False

    def comp_end(self, move: _Move, start: tuple[float, float],
                 target: tuple[float, float]) -> tuple[float, float]:
        """Where the compensated ``move`` from ``start`` to ``target`` ends (an error when an
        arc's compensated radius is not positive)."""
        r = self.comp_radius
        if move.centre is None:
            n = self.comp_normal(unit(target[0] - start[0], target[1] - start[1]))
            return target[0] + r * n[0], target[1] + r * n[1]
        c = move.exact
        radius = math.hypot(start[0] - c[0], start[1] - c[1])
        outward = (1 if move.cw else -1) * self.comp_side  # left of a CW arc: outside
        compensated = radius + outward * r
        if compensated <= 0:
            raise BlockError(move.col, f"the arc's radius {self.planner.mm(radius)} is not more "
                                       f"than the cutter's: cutter radius compensation cannot "
                                       f"follow it inside")
        u = unit(target[0] - c[0], target[1] - c[1])
        return c[0] + compensated * u[0], c[1] + compensated * u[1]

    def comp_corner(self, move: _Move, start: tuple[float, float],
                    target: tuple[float, float]) -> None:
        """``move`` (its start direction ``along``) after the held move, at the programmed
        corner ``start``."""
        along = move.along
        held = self.comp_held
        assert held is not None
        tool = held.end
        theta = math.atan2(tool[1] - start[1], tool[0] - start[0])
        alpha = math.atan2(along[1], along[0])
        if self.comp_side > 0:
            theta += 2 * math.pi if theta < alpha else 0.0
            beta = theta - alpha - math.pi / 2
        else:
            alpha += 2 * math.pi if alpha < theta else 0.0
            beta = alpha - theta - math.pi / 2
        n = self.comp_normal(along)
        mid = (start[0] + self.comp_radius * n[0], start[1] + self.comp_radius * n[1])
        end = self.comp_end(move, start, target)
        # an "h" (nearly back on itself): inside when the arc turns towards the tool
        toward = held.centre is not None and held.cw == (self.comp_side > 0)
        if move.centre is not None:
            toward = move.cw == (self.comp_side > 0)
        if beta < -SMALL or beta > math.pi + SMALL or (beta > math.pi - SMALL and toward):
            corner = self.comp_crossing(held, move, mid, end, start)
            self.comp_run(replace(held, end=corner))
            self.comp_held = replace(move, start=corner, end=end)
            return
        if beta > SMALL and move.centre is None and self.comp_gouges(held, held.end):
            raise BlockError(move.col, self.comp_gouge_message(
                held, f"the {self.comp_corner_name('outside', start)}"))
        self.comp_run(held)
        if beta > SMALL:  # outside: round the corner's point
            self.comp_run(_Move(tool, mid, held.last_z, move.feed, move.feed_source, move.line_no,
                                move.col, (round(start[0]), round(start[1])),
                                self.comp_side > 0, self.arc_tolerance(), exact=start))
            tool = mid
        self.comp_held = replace(move, start=tool, end=end)

    def comp_crossing(self, held: _Move, move: _Move, mid: tuple[float, float],
                      end: tuple[float, float],
                      corner: tuple[float, float]) -> tuple[float, float]:
        """Where the held move's compensated path crosses ``move``'s (which starts at
        ``mid``), nearest the programmed corner; an error where the tool would gouge."""
        r = self.comp_radius
        back = (held.end[0] - held.along[0], held.end[1] - held.along[1])
        if held.centre is None and move.centre is None:
            (bx, by), (ux, uy) = held.end, held.along
            (cx, cy), (vx, vy) = mid, move.along
            denom = ux * vy - uy * vx
            s = ((cx - bx) * vy - (cy - by) * vx) / denom if denom else 1.0
            points = [(bx + s * ux, by + s * uy)]
        elif move.centre is None:  # rs274's construction, not the crossing
            point = arc_line_corner(held.exact, math.dist(held.end, held.exact), not held.cw,
                                    held.cw != (self.comp_side > 0), corner,
                                    math.atan2(move.along[1], move.along[0]), r)
            points = [] if point is None else [point]
        elif held.centre is None:
            points = line_circle(back, held.end, move.exact, math.dist(end, move.exact))
        else:
            points = circles(held.exact, math.dist(held.end, held.exact), move.exact,
                              math.dist(end, move.exact))
        # the held move's end moves back to the nearest crossing behind it
        behind = [p for p in points if _back(held, p) >= -1e-6 or (
            held.centre is not None and move.centre is None)]
        point = min(behind, key=lambda p: _back(held, p)) if behind else None
        at = self.comp_corner_name("inside", corner)
        if point is not None and self.comp_gouges(held, point):
            raise BlockError(move.col, self.comp_gouge_message(held, f"the {at}"))
        if point is None:
            raise BlockError(move.col, f"cutter radius compensation: the {at} is too tight "
                                       f"for a cutter of radius {self.planner.mm(r)} (it "
                                       f"would gouge)")
        return point

    def comp_corner_name(self, kind: str, corner: tuple[float, float]) -> str:
        """``kind`` corner at the programmed point ``corner``, named by its coordinates."""
        first, second, _ = PLANE_AXES[self.comp_plane]
        return (f"{kind} corner at {'XYZ'[first]}{self.planner.mm(corner[0])} "
                f"{'XYZ'[second]}{self.planner.mm(corner[1])}")
