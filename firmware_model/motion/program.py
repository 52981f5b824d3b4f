"""A program as the firmware runs it: its items, in absolute machine positions.

A :class:`Program` is a tuple of items: :class:`Line`, :class:`Arc`, :class:`Parabola` and
:class:`Exponential` (K3701 blocks, with their exact plans), :class:`Dwell` and
:class:`Event` (words with no hardware here: spindle, coolant, tool change, stops; the
firmware records the cycle they are reached at). Positions are absolute machine LSB, one int
per machine axis (X, Y, and Z on a three-axis machine); the program starts at the origin.
Both G-code front ends build them with :class:`k37.firmware_model.motion.planner.Planner`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import cache

import numpy as np

from k37.firmware_model.motion.curves import (
    curve_distances,
    exponential_frame,
)
from k37.firmware_model.motion.splines import SplineSpan
from k37.hdl.common.constants import PLANE_AXES
from k37.hdl.k3701.block import Block
from k37.hdl.k3701.datapaths.model.parabolic import ExponentialPath, ParabolicPath
from k37.hdl.k3701.model.chip import Plan, make_path

__all__ = ["Arc", "Dwell", "Event", "Exponential", "Item", "Line", "Move",
           "Parabola", "Program", "chip_end"]


def chip_end(start: tuple[int, ...], axes: tuple[int, int, int], plane_end: tuple[int, int],
             normal: int) -> tuple[int, ...]:
    """Where a block from ``start`` (machine axes) ends: ``plane_end``, the chip's end in the
    plane of ``axes`` (machine-axis indices of its first, second and normal axes), and
    ``normal``, the travel along the normal axis."""
    first, second, normal_axis = axes
    delta = [0, 0, 0]
    delta[first], delta[second] = plane_end
    delta[normal_axis] = normal
    return tuple(s + d for s, d in zip(start, delta, strict=False))


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
        axes = self._chip_axes()
        return chip_end(self.start, axes, self.plan.end, (self.xe, self.ye, self.ze)[axes[2]])


@dataclass(frozen=True)
class Line(_Move):
    """A straight move (G00 or G01).

    ``index``: position in :attr:`Program.items`; ``line_no``: source line (from 1).
    ``xe, ye, ze``: end relative to the start (LSB). ``feed_mm_min``: the programmed feed, or
    None for a rapid move (``rapid``: the firmware picks the machine's rapid feed). ``start``:
    absolute machine position before the move (LSB). ``block`` is what the K3701 is loaded
    with and ``plan`` its exact step and FP counts (for the ``sqrt2`` setting);
    ``end`` the absolute position after the move. ``correction``: the host's short line from
    an arc's chip end to its programmed end (its line is the arc's). ``curve``: the exact
    curve a chord of a spline stands for (None: the line itself), what the contour error is
    measured against.
    """

    feed_mm_min: float | None
    rapid: bool
    correction: bool = field(default=False, kw_only=True)
    curve: SplineSpan | None = field(default=None, kw_only=True, compare=False)


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


def _arc_steps_bound(i: int, j: int, end: tuple[int, int], cw: bool) -> float:
    """At least how many steps the K3701 takes along an arc: its length over the diagonal
    step's sqrt(2) LSB (less 2 for the ends). A helix moving its normal axis further than
    this runs as chords (:meth:`Planner._chords`)."""
    return math.hypot(i, j) * _sweep(i, j, end, cw)[1] / math.sqrt(2) - 2


def _sweep(i: int, j: int, end: tuple[int, int], cw: bool) -> tuple[float, float]:
    a0 = math.atan2(-j, -i)
    a1 = math.atan2(end[1] - j, end[0] - i)
    return a0, ((a0 - a1) if cw else (a1 - a0)) % math.tau or math.tau


class _Curve(_Move):
    """A move along one of the K3701's curves, drawn in the curve's own frame (abscissa p,
    ordinate v: :class:`k37.hdl.k3701.datapaths.model.parabolic.ParabolicPath`,
    :class:`k37.hdl.k3701.datapaths.model.parabolic.ExponentialPath`).
    ``code``: its G code. The programmed curve is the chip's, through the start and the end."""

    code = ""

    def _path(self) -> ParabolicPath | ExponentialPath:
        return _curve_path(self.block)

    def _curve(self) -> Callable[[np.ndarray], tuple[np.ndarray, ...]]:
        """The programmed curve in its frame: v, dv/dp and d2v/dp2 at an array of p."""
        raise NotImplementedError

    def frame(self, points: np.ndarray) -> np.ndarray:
        """Absolute (x, y) rows in the curve's frame (p, v)."""
        path = self._path()
        rel = points - np.array(self.start[:2], dtype=float)
        p, v = (rel[:, 1], rel[:, 0]) if path.swap else (rel[:, 0], rel[:, 1])
        return np.column_stack([path.su * p, v])

    @property
    def extent(self) -> float:
        """The end's abscissa p in the curve's frame (the curve runs over [0, extent])."""
        return float(self._path().pe)

    def at(self, p: np.ndarray) -> np.ndarray:
        """Absolute (x, y) rows of the programmed curve at abscissae ``p`` of its frame."""
        path = self._path()
        v = self._curve()(p)[0]
        u = path.su * p
        rel = np.column_stack([v, u] if path.swap else [u, v])
        return rel + np.array(self.start[:2], dtype=float)

    def polyline(self, count: int = 720) -> np.ndarray:
        """``count`` absolute points along the programmed curve."""
        return self.at(np.linspace(0.0, self.extent, count))

    def distances(self, points: np.ndarray) -> np.ndarray:
        """Distance of each absolute (x, y) row, or (x, y, z) on a three-axis machine, to the
        programmed curve between its ends (LSB; the curve lies at its start's z)."""
        in_plane = curve_distances(self._curve(), self.frame(points[:, :2]),
                                   (0.0, float(self._path().pe)))
        if points.shape[1] < 3:
            return in_plane
        return np.hypot(in_plane, points[:, 2] - self.start[2])


@cache
def _curve_path(block: Block) -> ParabolicPath | ExponentialPath:
    """The K3701's path of a curve's block (built once per block: the host evaluates it at
    every contour sample)."""
    path = make_path(block)
    assert isinstance(path, ParabolicPath | ExponentialPath)
    return path


@dataclass(frozen=True)
class Parabola(_Curve):
    """A parabolic move (G06) in the XY plane.

    ``xe, ye``: end relative to the start (LSB); ``i, j``: the tangent point P (the point
    whose tangent is parallel to the chord) relative to the start (LSB, as programmed).
    ``block`` and ``plan`` are the chip's (:func:`k37.firmware_model.motion.curves.parabola_block`):
    it ends exactly on the end point. Other fields as in :class:`Line`. """

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
    in the XY plane.

    ``xe, ye``: end relative to the start (LSB); ``constant``: the curve's constant as
    programmed (LSB along its abscissa, X or with ``log`` Y). ``block`` and ``plan`` are the
    chip's (:func:`k37.firmware_model.motion.curves.exponential_block`): it ends exactly on the end
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
    written (``M03``, ``T2``...), ``kind`` (its meaning, see :mod:`k37.firmware_model.gcode.words`)
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
    #: What the front end left out and why, each ``file:line: text`` (blocks after the program
    #: end, a controller's own command lines): reported as warnings, never errors.
    notes: tuple[str, ...] = field(default=(), compare=False)
    #: The program's own block numbers: the N-word of each line that has one, by line.
    sequence: Mapping[int, int] = field(default_factory=dict, compare=False)

    def label(self, line: int) -> str:
        """How a person names the block on ``line``: its N-word (``N30``) where it has one,
        else ``line 5``."""
        number = self.sequence.get(line)
        return f"N{number}" if number is not None else f"line {line}"

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
