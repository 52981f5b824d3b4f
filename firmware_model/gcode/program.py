"""A program as the firmware runs it, and the planner both G-code front ends build it with.

A :class:`Program` is a tuple of items: :class:`Line`, :class:`Arc`, :class:`Parabola` and
:class:`Exponential` (K3701 blocks, with their exact plans), :class:`Dwell` and
:class:`Event` (words with no hardware here: spindle, coolant, tool change, stops; the
firmware records the cycle they are reached at). Positions
are absolute machine LSB, one int per machine axis (X, Y, and Z on a three-axis machine);
the program starts at the origin.

:class:`Planner` turns moves to absolute targets into items. Every block starts where the
previous one really ended and runs to its programmed target, an absolute position in integer
LSB, so nothing accumulates. A line ends exactly on its target. An arc's chip end can differ
from its programmed end (the K3701 stops where its digital path reaches the end's long-axis
coordinate, ``docs/chips/k3701.md``): within :data:`CORRECTION_MAX` LSB on every axis (the
datasheet's promise) it is left, and the next block starts there; farther, the planner adds a
*correction line*, a short linear block at the arc's feed from the chip's end to the
programmed end (``Line.correction``). If the chip would stop far from the programmed end (a
tiny arc whose digital path runs a full extra turn, or leaves the end quadrant with ERROR),
the block's end point is moved to the grid point near the programmed end whose chip end is
closest to it, within :data:`REPAIR_REACH` LSB, and the correction line follows if needed.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from firmware_model.gcode.arcs import plan_block
from firmware_model.gcode.curves import (
    CurveError,
    curve_distances,
    exponential_block,
    exponential_frame,
    parabola_block,
)
from hdl.k3701.block import COORD_MAX, MAX_RADIUS_SQUARED, Block, BlockError
from hdl.k3701.datapaths.parabolic_model import ExponentialPath, ParabolicPath
from hdl.k3701.model import Plan, make_path

__all__ = ["CORRECTION_MAX", "PLANE_AXES", "REPAIR_REACH", "Arc", "Dwell", "Event",
           "Exponential", "Item", "Line", "Move", "Parabola", "PlanError", "Planner", "Program"]

#: Machine-axis indices of a plane's first, second and normal axes (as LinuxCNC's canon).
PLANE_AXES = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}
#: How far (LSB, each axis) from the programmed end a repaired arc's block end may be moved.
REPAIR_REACH = 3
#: How far (LSB, each axis) an arc's chip end may stay from its programmed end without a
#: correction line: the K3701 datasheet's 1 LSB.
CORRECTION_MAX = 1
_AXIS_NAMES = "XYZ"


@dataclass(frozen=True)
class _Move:
    """What every move has. ``start``, ``block``, ``plan`` and the rest are keyword-only."""

    index: int
    line_no: int
    xe: int
    ye: int
    start: tuple[int, ...] = field(kw_only=True)
    block: Block = field(kw_only=True)
    plan: Plan = field(kw_only=True)
    ze: int = field(default=0, kw_only=True)
    #: Where the feed in force was programmed: (line, column, word), or None.
    feed_source: tuple[int, int, str] | None = field(default=None, kw_only=True, compare=False)

    def _chip_axes(self) -> tuple[int, int, int]:
        return 0, 1, 2

    @property
    def end(self) -> tuple[int, ...]:
        """Absolute machine position after the move (LSB)."""
        first, second, normal = self._chip_axes()
        delta = [0, 0, 0]
        delta[first], delta[second] = self.plan.end
        delta[normal] = (self.xe, self.ye, self.ze)[normal]
        return tuple(s + d for s, d in zip(self.start, delta, strict=False))


@dataclass(frozen=True)
class Line(_Move):
    """A straight move (G00 or G01).

    ``index``: position in :attr:`Program.items`; ``line_no``: source line (from 1).
    ``xe, ye, ze``: end relative to the start (LSB). ``feed_mm_min``: the programmed feed, or
    None for a rapid move (``rapid``: the firmware picks the machine's rapid feed). ``start``:
    absolute machine position before the move (LSB). ``block`` is what the K3701 is loaded
    with and ``plan`` its exact step and FP counts (for the ``sqrt2`` setting);
    ``end`` the absolute position after the move. ``correction``: the host's short line from
    an arc's chip end to its programmed end (its line is the arc's).
    """

    feed_mm_min: float | None
    rapid: bool
    correction: bool = field(default=False, kw_only=True)


@dataclass(frozen=True)
class Arc(_Move):
    """A circular or helical move (G02 CW, G03 CCW) in the plane ``plane`` (17, 18 or 19).

    ``xe, ye, ze``: programmed end and ``i, j, k``: centre, relative to the start (LSB,
    machine axes). ``block`` and ``plan`` are in the plane's (first, second) coordinates, as
    the K3701 takes them; ``plan.end`` is where the chip stops (a :class:`Line` with
    ``correction`` follows when that is not the programmed end). The travel along the
    plane's normal axis makes a helix. Other fields as in :class:`Line`.
    """

    i: int
    j: int
    cw: bool
    feed_mm_min: float
    k: int = field(default=0, kw_only=True)
    plane: int = field(default=17, kw_only=True)

    @property
    def plane_axes(self) -> tuple[int, int, int]:
        """Machine-axis indices of the plane's first, second and normal axes."""
        return PLANE_AXES[self.plane]

    def _chip_axes(self) -> tuple[int, int, int]:
        return self.plane_axes

    @property
    def center(self) -> tuple[int, int]:
        """Absolute position of the centre in the plane's (first, second) coordinates."""
        first, second, _ = self.plane_axes
        offset = (self.i, self.j, self.k)
        return self.start[first] + offset[first], self.start[second] + offset[second]

    @property
    def radius(self) -> float:
        """Distance from the centre to the start (LSB)."""
        return math.hypot(self.block.i, self.block.j)

    @property
    def span(self) -> tuple[float, float]:
        """The start's angle around the centre and the angle swept from it to :attr:`end` in
        the direction of travel (radians, in the plane; the sweep is in (0, 2 pi]: an end at
        the start is a full circle)."""
        return _sweep(self.block.i, self.block.j, self.plan.end, self.cw)


def _sweep(i: int, j: int, end: tuple[int, int], cw: bool) -> tuple[float, float]:
    a0 = math.atan2(-j, -i)
    a1 = math.atan2(end[1] - j, end[0] - i)
    return a0, ((a0 - a1) if cw else (a1 - a0)) % math.tau or math.tau


class _Curve(_Move):
    """A move along one of the K3701's curves, drawn in the curve's own frame (abscissa p,
    ordinate v: :class:`hdl.k3701.datapaths.parabolic_model.ParabolicPath`,
    :class:`hdl.k3701.datapaths.parabolic_model.ExponentialPath`).
    ``code``: its G code. The programmed curve is the chip's, through the start and the end."""

    code = ""

    def _path(self) -> ParabolicPath | ExponentialPath:
        path = make_path(self.block)
        assert isinstance(path, ParabolicPath | ExponentialPath)
        return path

    def _curve(self) -> Callable[[np.ndarray], tuple[np.ndarray, ...]]:
        """The programmed curve in its frame: v, dv/dp and d2v/dp2 at an array of p."""
        raise NotImplementedError

    def frame(self, points: np.ndarray) -> np.ndarray:
        """Absolute (x, y) rows in the curve's frame (p, v)."""
        path = self._path()
        rel = points - np.array(self.start[:2], dtype=float)
        p, v = (rel[:, 1], rel[:, 0]) if path.swap else (rel[:, 0], rel[:, 1])
        return np.column_stack([path.su * p, v])

    def polyline(self, count: int = 720) -> np.ndarray:
        """``count`` absolute points along the programmed curve."""
        path = self._path()
        p = np.linspace(0.0, path.pe, count)
        v = self._curve()(p)[0]
        u = path.su * p
        rel = np.column_stack([v, u] if path.swap else [u, v])
        return rel + np.array(self.start[:2], dtype=float)

    def distances(self, points: np.ndarray) -> np.ndarray:
        """Distance of each absolute (x, y) row to the programmed curve between its ends
        (LSB)."""
        return curve_distances(self._curve(), self.frame(points),
                               (0.0, float(self._path().pe)))


@dataclass(frozen=True)
class Parabola(_Curve):
    """A parabolic move (G06) on the two-axis chip.

    ``xe, ye``: end relative to the start (LSB); ``i, j``: the tangent point P (the point
    whose tangent is parallel to the chord) relative to the start (LSB, as programmed).
    ``block`` and ``plan`` are the chip's (:func:`firmware_model.gcode.curves.parabola_block`): it
    ends exactly on the end point. Other fields as in :class:`Line`.
    """

    i: int
    j: int
    feed_mm_min: float
    code = "G06"

    def _curve(self) -> Callable[[np.ndarray], tuple[np.ndarray, ...]]:
        path = self._path()
        assert isinstance(path, ParabolicPath)
        qa, qb = path.b / path.a, path.c / path.a
        return lambda q: (qa * q * q + qb * q, 2 * qa * q + qb, 2 * qa + 0 * q)


@dataclass(frozen=True)
class Exponential(_Curve):
    """An exponential (G06.1) or, with ``log``, logarithmic (G06.2: an exponential of Y) move
    on the two-axis chip.

    ``xe, ye``: end relative to the start (LSB); ``constant``: the curve's constant as
    programmed (LSB along its abscissa, X or with ``log`` Y). ``block`` and ``plan`` are the
    chip's (:func:`firmware_model.gcode.curves.exponential_block`): it ends exactly on the end
    point. Other fields as in :class:`Line`.
    """

    constant: int
    log: bool
    feed_mm_min: float

    @property
    def code(self) -> str:
        return "G06.2" if self.log else "G06.1"

    def _curve(self) -> Callable[[np.ndarray], tuple[np.ndarray, ...]]:
        path = self._path()
        assert isinstance(path, ExponentialPath)
        return exponential_frame(path)


@dataclass(frozen=True)
class Dwell:
    """A pause (G04) of ``seconds``."""

    index: int
    line_no: int
    seconds: float


@dataclass(frozen=True)
class Event:
    """A word with no hardware here, recorded when the program reaches it: ``word`` as
    written (``M03``, ``T2``...), ``kind`` (its meaning, see :mod:`firmware_model.gcode.words`)
    and its ``value`` (S, T), if any."""

    index: int
    line_no: int
    word: str
    kind: str
    value: float | None = None


Move = Line | Arc | Parabola | Exponential
Item = Line | Arc | Parabola | Exponential | Dwell | Event


@dataclass(frozen=True)
class Program:
    """A parsed program: its items in order, and whether it ended with M02/M30."""

    items: tuple[Item, ...]
    end: bool
    source: str
    lsb_mm: float
    sqrt2: bool
    arc_tolerance: float | None
    axes: int = 2
    #: The file and line the program's first line is on, for messages (None: ``source``,
    #: line 1; a program inline in a job file is on the job file's lines).
    origin: tuple[str, int] | None = field(default=None, compare=False)

    def locate(self, line: int, col: int | None = None) -> str:
        """``file:line[:col]`` of a program line, in the file it is written in."""
        name, first = self.origin or (self.source, 1)
        return f"{name}:{line + first - 1}" + ("" if col is None else f":{col}")

    @property
    def moves(self) -> tuple[Move, ...]:
        """The items that move (the K3701's blocks)."""
        return tuple(it for it in self.items
                     if isinstance(it, Line | Arc | Parabola | Exponential))

    @property
    def events(self) -> tuple[Event, ...]:
        return tuple(it for it in self.items if isinstance(it, Event))

    @property
    def final_position(self) -> tuple[int, ...]:
        """Absolute machine position after the last move (LSB; the start is the origin)."""
        moves = self.moves
        return moves[-1].end if moves else (0,) * self.axes

    def to_dict(self) -> dict[str, object]:
        """A JSON-able summary: source, settings and item counts (events and the axis count
        only where a program has them)."""
        summary: dict[str, object] = {
            "source": self.source, "lsb_mm": self.lsb_mm, "sqrt2": self.sqrt2,
            "arc_tolerance": self.arc_tolerance, "end": self.end,
            "lines": sum(isinstance(it, Line) for it in self.items),
            "arcs": sum(isinstance(it, Arc) for it in self.items),
            "dwells": sum(isinstance(it, Dwell) for it in self.items),
        }
        if self.events:
            summary["events"] = len(self.events)
        for kind, name in ((Parabola, "parabolas"), (Exponential, "exponentials")):
            count = sum(isinstance(it, kind) for it in self.items)
            if count:
                summary[name] = count
        if self.axes != 2:
            summary["axes"] = self.axes
        return summary


class PlanError(ValueError):
    """A move the planner refuses; the front end adds the place (line, column)."""


class Planner:
    """Builds the items of a program from moves to absolute machine targets (LSB).

    ``position`` is the machine position and ``programmed`` the programmed one (three ints
    each; Z stays 0 on a two-axis machine): they differ by at most :data:`CORRECTION_MAX`
    after an arc. Methods raise :class:`PlanError` for a move the K3701 cannot run.
    """

    def __init__(self, *, axes: int, sqrt2: bool, lsb_mm: float):
        self.axes = axes
        self.sqrt2 = sqrt2
        self.lsb_mm = lsb_mm
        self.items: list[Item] = []
        self.position = (0, 0, 0)
        self.programmed = (0, 0, 0)

    def mm(self, lsb: float) -> str:
        """A length in LSB as mm, to the LSB's resolution."""
        digits = max(0, -math.floor(math.log10(self.lsb_mm) + 1e-9))
        return f"{lsb * self.lsb_mm:.{digits}f} mm"

    def _start(self) -> tuple[int, ...]:
        return self.position[:self.axes]

    def _check_target(self, target: tuple[int, int, int]) -> tuple[int, int, int]:
        for axis in range(3):
            for value, what in ((target[axis], "position"),
                                (target[axis] - self.position[axis], "move")):
                if abs(value) > COORD_MAX:
                    raise PlanError(f"{_AXIS_NAMES[axis]}: the {what} {value} LSB is outside "
                                    f"-(2^23-1)..2^23-1 LSB (+-{self.mm(COORD_MAX)})")
        if self.axes == 2 and target[2] != self.position[2]:
            raise PlanError("this move moves Z: the machine has two axes (machine.axes = 3 "
                            "runs it)")
        return target

    def line(self, line_no: int, target: tuple[int, int, int], feed: float | None, *,
             feed_source: tuple[int, int, str] | None = None, correction: bool = False) -> None:
        """A straight move to ``target``; ``feed`` None: rapid (G00)."""
        target = self._check_target(target)
        xe, ye, ze = (t - p for t, p in zip(target, self.position, strict=True))
        block = Block.line(xe, ye, ze, sqrt2=self.sqrt2)
        result = plan_block(block)
        self.items.append(Line(len(self.items), line_no, xe, ye, feed, feed is None, ze=ze,
                               start=self._start(), block=block, plan=result,
                               feed_source=feed_source, correction=correction))
        self.position = self.programmed = target

    def parabola(self, line_no: int, target: tuple[int, int, int], tangent: tuple[int, int],
                 feed: float, *, feed_source: tuple[int, int, str] | None = None) -> None:
        """A parabola (G06) to ``target`` through the tangent point ``tangent`` (relative to
        the start), on the two-axis chip: the three-axis build has no parabolic datapath."""
        target = self._check_target(target)
        if self.axes == 3:
            raise PlanError("G06: the three-axis K3701 has no parabolic interpolation (the "
                            "two-axis machine runs it)")
        xe, ye = target[0] - self.position[0], target[1] - self.position[1]
        try:
            block, result = parabola_block(self.position[:2], xe, ye, *tangent, self.sqrt2)
        except CurveError as e:
            raise PlanError(str(e)) from None
        self.items.append(Parabola(len(self.items), line_no, xe, ye, *tangent, feed,
                                   start=self._start(), block=block, plan=result,
                                   feed_source=feed_source))
        self.position = self.programmed = target

    def exponential(self, line_no: int, target: tuple[int, int, int], constant: int,
                    log: bool, feed: float, *,
                    feed_source: tuple[int, int, str] | None = None) -> None:
        """An exponential (G06.1), or with ``log`` a logarithm (G06.2), to ``target`` of
        constant ``constant`` (LSB along X, or Y with ``log``), on the two-axis chip."""
        target = self._check_target(target)
        name = "G06.2" if log else "G06.1"
        if self.axes == 3:
            raise PlanError(f"{name}: the three-axis K3701 has no exponential interpolation "
                            f"(the two-axis machine runs it)")
        xe, ye = target[0] - self.position[0], target[1] - self.position[1]
        try:
            block, result = exponential_block(xe, ye, constant, log=log, sqrt2=self.sqrt2)
        except CurveError as e:
            raise PlanError(f"{name}: {e}") from None
        self.items.append(Exponential(len(self.items), line_no, xe, ye, constant, log, feed,
                                      start=self._start(), block=block, plan=result,
                                      feed_source=feed_source))
        self.position = self.programmed = target

    def dwell(self, line_no: int, seconds: float) -> None:
        self.items.append(Dwell(len(self.items), line_no, seconds))

    def event(self, line_no: int, word: str, kind: str, value: float | None = None) -> None:
        self.items.append(Event(len(self.items), line_no, word, kind, value))

    def arc(self, line_no: int, target: tuple[int, int, int], centre: tuple[int, int],
            plane: int, cw: bool, feed: float, *, tolerance: float,
            feed_source: tuple[int, int, str] | None = None) -> None:
        """An arc (a helix if the normal axis moves) from the position to ``target`` around
        ``centre`` (absolute, in the plane's (first, second) coordinates). An end equal to
        the start in the plane is a full circle."""
        target = self._check_target(target)
        first, second, normal = PLANE_AXES[plane]
        if self.axes == 2 and (plane != 17 or target[normal] != self.position[normal]):
            raise PlanError(f"{'a helical arc' if plane == 17 else f'a G{plane} arc'} moves "
                            f"Z: the machine has two axes (machine.axes = 3 runs it)")
        start = self.position
        i, j = centre[0] - start[first], centre[1] - start[second]
        end = (target[first] - start[first], target[second] - start[second])
        if (target[first], target[second]) == (self.programmed[first], self.programmed[second]):
            end = (0, 0)  # a full circle from wherever the machine is
        if i == 0 and j == 0:
            raise PlanError("the arc's centre is its start point (radius 0)")
        r0, r1 = math.hypot(i, j), math.hypot(end[0] - i, end[1] - j)
        if abs(r1 - r0) > tolerance:
            raise PlanError(f"the arc's end is not on its circle: radius {self.mm(r0)} at the "
                            f"start, {self.mm(r1)} at the end (they differ by "
                            f"{abs(r1 - r0):.1f} LSB; tolerance {tolerance:g} LSB)")
        block, result = self._arc_block(end, i, j, cw)
        self._check_sweep(start, (first, second), (i, j), result.end, cw)
        offsets = [0, 0, 0]
        offsets[first], offsets[second] = i, j
        rel = tuple(t - p for t, p in zip(target, start, strict=True))
        if rel[normal] or plane != 17:  # the three-axis chip's helix and plane routing
            try:
                result = plan_block(replace(block, ze=rel[normal], plane=plane - 17))
            except BlockError as e:
                raise PlanError(f"the K3701 refuses this helix: {e}") from None
            block = replace(block, ze=rel[normal], plane=plane - 17,
                            helix_steps=result.steps if rel[normal] else 0)
        self.items.append(Arc(len(self.items), line_no, rel[0], rel[1], offsets[0], offsets[1],
                              cw, feed, ze=rel[2], k=offsets[2], plane=plane,
                              start=self._start(), block=block, plan=result,
                              feed_source=feed_source))
        self.position = tuple(self.items[-1].end) + (0,) * (3 - self.axes)
        self.programmed = target
        if max(abs(p - t) for p, t in zip(self.position, target, strict=True)) > CORRECTION_MAX:
            self.line(line_no, target, feed, feed_source=feed_source, correction=True)

    def _arc_block(self, end: tuple[int, int], i: int, j: int, cw: bool) -> tuple[Block, Plan]:
        """The block to load for an arc to ``end`` and its plan: the programmed end, or the
        grid point near it whose chip end is closest to it (see the module's docstring)."""
        refused = None
        try:
            block = Block.arc(end[0], end[1], i, j, cw=cw, sqrt2=self.sqrt2)
            result = plan_block(block)
            if self._close(end, result, i, j, cw):
                return block, result
        except BlockError as e:
            refused = e
        if i * i + j * j > MAX_RADIUS_SQUARED:
            raise PlanError(f"the K3701 refuses this arc: {refused}")
        best = None
        reach = range(-REPAIR_REACH, REPAIR_REACH + 1)
        for dx in reach:
            for dy in reach:
                try:
                    candidate = Block.arc(end[0] + dx, end[1] + dy, i, j, cw=cw,
                                          sqrt2=self.sqrt2)
                    trial = plan_block(candidate)
                except BlockError:
                    continue
                if self._close(end, trial, i, j, cw):
                    key = (math.dist(trial.end, end), abs(dx) + abs(dy))
                    if best is None or key < best[0]:
                        best = key, candidate, trial
        if best is None and refused is not None:
            raise PlanError(f"the K3701 refuses this arc: {refused}")
        if best is None:
            raise PlanError(f"the K3701 cannot end this arc near its end point {end} LSB "
                            f"(relative to the start): its digital path of radius "
                            f"{math.hypot(i, j):.1f} LSB does not pass within "
                            f"{REPAIR_REACH} LSB of it in the programmed direction")
        return best[1], best[2]

    @staticmethod
    def _close(end: tuple[int, int], result: Plan, i: int, j: int, cw: bool) -> bool:
        """Whether the chip's plan ends near ``end`` after the programmed sweep: no ERROR,
        and the arc length between the two sweeps no longer than their distance + 2 LSB."""
        if result.error:
            return False
        full = end == (0, 0)
        sweep = _sweep(i, j, end, cw)[1]
        chip = _sweep(i, j, result.end, cw)[1]
        if full:  # a full circle must close
            return result.end == (0, 0)
        return math.hypot(i, j) * abs(chip - sweep) <= math.dist(result.end, end) + 2

    def _check_sweep(self, start: tuple[int, int, int], axes: tuple[int, int],
                     ij: tuple[int, int], end: tuple[int, int], cw: bool) -> None:
        """Refuse an arc whose path leaves the 24-bit absolute range between its ends."""
        i, j = ij
        r = math.hypot(i, j)
        cx, cy = start[axes[0]] + i, start[axes[1]] + j
        a0, sweep = _sweep(i, j, end, cw)
        sign = -1 if cw else 1
        for k, (axis, limit) in enumerate(((0, cx + r), (1, cy + r), (0, cx - r), (1, cy - r))):
            offset = (sign * (k * math.pi / 2 - a0)) % math.tau
            crossed = offset <= sweep + 1e-9 or offset >= math.tau - 1e-9
            if crossed and math.ceil(abs(limit) - 1e-9) > COORD_MAX:
                raise PlanError(f"the arc leaves the coordinate range on "
                                f"{_AXIS_NAMES[axes[axis]]}: it reaches {limit:.0f} LSB, "
                                f"beyond +-(2^23-1) LSB (+-{self.mm(COORD_MAX)})")
