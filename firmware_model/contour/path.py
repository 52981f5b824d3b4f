"""The programmed path as one geometry: every consumer of the contour error measures with it
(the report and its plots, the sweeps, the host's contour controllers).

A :class:`Path` holds each move of a program as a parametric segment Q(u), u in [0, 1], in
machine coordinates (LSB): a line (a correction move is one), an arc or helix, the K3701's
parabola or exponential in its own frame, or the exact curve of a G5 spline's chord. For a
batch of positions, :meth:`Path.foot` gives each one's nearest point of a segment and its
parameter: in closed form on a line and a plane arc (a helix that does not rise is one); on a
rising helix and the curves, a golden-section search closes in on the minimum beside the
nearest of points spaced evenly along the segment's length (on a curve, on each of the two
spacings beside it and on the nearest other valley of those points' distances: a tight turn
or a loop of a curve has two minima near each other), never a step outside its bracket; the
nearest of what it finds, the ends and the nearest point is the foot. No numerical warning
comes out: the curves are only evaluated between their ends.

:class:`k37.firmware_model.contour.tracker.Tracker` follows the tool along a path.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import overload

import numpy as np

from k37.firmware_model.contour.rowwise import (
    along,
    arc_dist2,
    arc_param,
    arc_points,
    dist2,
    line_foot,
    sum_axes,
)
from k37.firmware_model.motion.program import Arc, Line, Move

__all__ = ["ARC", "LINE", "REACH", "SAMPLED", "TIE", "Foot", "Path", "Segment"]

#: Arc length (LSB) a tracker's window reaches past the end of the last matched segment, on
#: top of the tool's distance to it and twice its travel since the previous sample.
REACH = 16.0

#: Points spaced evenly along a curve or helix that bracket its nearest point.
GRID = 64
#: Rows whose distances to the grid are computed at a time.
GRID_BLOCK = 1024
#: Golden-section steps on a bracket: it shrinks to 0.618^40 (1e-8) of its width.
GOLDEN_STEPS = 40
#: Distances this close (LSB) count as equal: the furthest segment is taken.
TIE = 1e-6
_GOLD = (math.sqrt(5) - 1) / 2
#: A segment's kind: a line and a plane arc have closed forms, the rest are searched along.
LINE, ARC, SAMPLED = 0, 1, 2


@dataclass(frozen=True)
class Segment:
    """One move's path: :meth:`at` maps parameters in [0, 1] to rows of machine coordinates."""

    move: Move
    axes: int

    @cached_property
    def start(self) -> np.ndarray:
        """Where the segment starts (LSB, machine axes)."""
        return np.array(self.move.start[:self.axes], dtype=float)

    @cached_property
    def end(self) -> np.ndarray:
        """Where the segment ends (LSB, machine axes)."""
        return np.array(self.move.end[:self.axes], dtype=float)

    @cached_property
    def circle(self) -> tuple[int, int, np.ndarray, float, float, float, bool]:
        """An arc's plane axes, centre, radius, start angle, sweep and direction."""
        m = self.move
        assert isinstance(m, Arc)
        first, second, _ = m.plane_axes
        return (first, second, np.array(m.center, dtype=float), m.radius, *m.span, m.cw)

    def at(self, u: np.ndarray) -> np.ndarray:
        """Rows of machine coordinates (LSB) at parameters ``u``."""
        u = np.clip(np.asarray(u, dtype=float), 0.0, 1.0)
        m = self.move
        if isinstance(m, Line):
            if m.curve is None:
                return along(self.start, u, self.end - self.start)
            span = m.curve
            plane = span.curve.at(span.t0 + (span.t1 - span.t0) * u)
            return plane if self.axes == 2 else np.column_stack([plane, np.full(len(u), span.z)])
        if isinstance(m, Arc):
            first, second, centre, radius, a0, sweep, cw = self.circle
            return arc_points(u, self.start, self.end - self.start, first, second, centre,
                               radius, a0, -sweep if cw else sweep)
        plane = m.at(u * m.extent)
        return plane if self.axes == 2 else np.column_stack(
            [plane, np.full(len(u), float(m.start[2]))])

    @cached_property
    def length(self) -> float:
        """The segment's arc length (LSB): exact on a line, an arc and a helix; along 256
        chords on a curve."""
        m = self.move
        if isinstance(m, Arc):
            normal = m.plane_axes[2]
            rise = float(self.end[normal] - self.start[normal]) if normal < self.axes else 0.0
            return math.hypot(m.radius * m.span[1], rise)
        if isinstance(m, Line) and m.curve is None:
            return math.sqrt(self.length2)
        q = self.at(np.linspace(0.0, 1.0, 257))
        return float(np.sqrt(((q[1:] - q[:-1]) ** 2).sum(axis=1)).sum())

    @cached_property
    def sampled(self) -> bool:
        """No closed form: a spline's chord, a curve, a rising helix."""
        return _kind(self.move, self.axes) == SAMPLED

    def foot(self, p: np.ndarray, top: np.ndarray | None = None
             ) -> tuple[np.ndarray, np.ndarray]:
        """The parameter of each row of ``p``'s nearest point of the segment, and that point;
        with ``top``, of the part of it up to that parameter (per row; on a curve, the
        nearest point beyond it is drawn back to it)."""
        if self.sampled:
            u, q = self._search(p)
            if top is None or not (u > top).any():
                return u, q
            u = np.minimum(u, top)
            return u, self.at(u)
        end = np.ones(len(p)) if top is None else top
        if isinstance(self.move, Line):
            return line_foot(p, self.start, self.end - self.start, self.length2, end)
        first, second, centre, _, a0, sweep, cw = self.circle
        u = arc_param(p, first, second, centre, a0, sweep, cw, end)
        return u, self.at(u)

    @cached_property
    def length2(self) -> float:
        """A line's squared length (LSB squared)."""
        d = self.end - self.start
        return float((d * d).sum())

    def _search(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # A row equal to the one before it (a tool at rest, or slow) is that row's answer.
        fresh = np.ones(len(p), dtype=bool)
        for axis in range(p.shape[1]):
            fresh[1:] &= p[1:, axis] == p[:-1, axis]
        fresh[1:] = ~fresh[1:]
        if not fresh.all():
            u, q = self._search(p[fresh])
            which = np.cumsum(fresh) - 1
            return u[which], q[which]
        grid = self._grid
        # The grid's nearest point of each row and its squared distance, and the nearest of
        # its other valleys (a grid point nearer than its neighbours, two or more points away;
        # -1: none): a block of rows at a time, so that the distances stay in the cache.
        curve = not isinstance(self.move, Arc)
        k, near2 = np.empty(len(p), dtype=np.intp), np.empty(len(p))
        other = np.full(len(p), -1, dtype=np.intp)
        for block in range(0, len(p), GRID_BLOCK):
            rows = np.arange(block, min(len(p), block + GRID_BLOCK))
            grid_off2 = dist2(p[rows, None, :], self._grid_points[None])
            k[rows] = np.argmin(grid_off2, axis=1)
            near2[rows] = grid_off2[rows - block, k[rows]]
            if not curve:
                continue
            valley = np.ones(grid_off2.shape, dtype=bool)
            valley[:, 1:] &= grid_off2[:, 1:] <= grid_off2[:, :-1]
            valley[:, :-1] &= grid_off2[:, :-1] <= grid_off2[:, 1:]
            valley &= np.abs(np.arange(len(grid))[None] - k[rows, None]) >= 2
            masked = np.where(valley, grid_off2, np.inf)
            best = np.argmin(masked, axis=1)
            other[rows] = np.where(np.isfinite(masked[rows - block, best]), best, -1)
        rows = np.arange(len(p))
        off2 = self._off2(p)
        below, above = grid[np.maximum(k - 1, 0)], grid[np.minimum(k + 1, len(grid) - 1)]
        # Each row's minimum is the nearest of its grid valley's, the ends', the grid point's
        # (the minimum may sit on an end) and, on a curve, the other valley's; a curve's valley
        # is searched on each side of its grid point (a tight turn can hold two minima), a
        # helix's whole (its turns are many grid spacings long).
        u1, f1 = self._golden(off2, below, grid[k] if curve else above)
        u3, f3 = self._golden(off2, grid[k], above) if curve else (u1, f1)
        u2, f2 = np.zeros(len(p)), np.full(len(p), np.inf)
        two = np.flatnonzero(other >= 0)
        if len(two):
            j = other[two]
            u2[two], f2[two] = self._golden(self._off2(p[two]), grid[np.maximum(j - 1, 0)],
                                            grid[np.minimum(j + 1, len(grid) - 1)])
        cands = np.column_stack([u1, np.zeros(len(p)), np.ones(len(p)), grid[k], u2, u3])
        d2 = np.column_stack([f1, off2(cands[:, 1]), off2(cands[:, 2]), near2, f2, f3])
        u = cands[rows, np.argmin(d2, axis=1)]
        return u, self.at(u)

    @staticmethod
    def _golden(off2: Callable[[np.ndarray], np.ndarray], lo: np.ndarray, hi: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
        """The golden-section search of each row's squared distance ``off2`` on [lo, hi]: the
        parameter it closes in on and its squared distance."""
        gap = _GOLD * (hi - lo)
        a, b = hi - gap, lo + gap
        fa, fb = off2(a), off2(b)
        for _ in range(GOLDEN_STEPS):
            left = fa <= fb  # the minimum is in [lo, b]: a is the new b, else b the new a
            hi, lo = np.where(left, b, hi), np.where(left, lo, a)
            gap = _GOLD * (hi - lo)
            new = np.where(left, hi - gap, lo + gap)
            a, b = np.where(left, new, b), np.where(left, a, new)
            fresh = off2(new)
            fa, fb = np.where(left, fresh, fb), np.where(left, fa, fresh)
        nearer = fa <= fb
        return np.where(nearer, a, b), np.where(nearer, fa, fb)

    def _off2(self, p: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
        """The squared distance of :meth:`at` of parameters ``u`` to the rows ``p``, per row:
        ``dist2(self.at(u), p)``, bit for bit (on a helix, each coordinate computed once)."""
        if not isinstance(self.move, Arc):
            return lambda u: dist2(self.at(u), p)
        first, second, centre, radius, a0, sweep, cw = self.circle
        turn, start, d = -sweep if cw else sweep, self.start, self.end - self.start
        columns = [p[:, axis].copy() for axis in range(p.shape[1])]
        return lambda u: arc_dist2(np.clip(u, 0.0, 1.0), columns, first, second, centre,
                                   radius, a0, turn, start, d)

    @cached_property
    def _grid_points(self) -> np.ndarray:
        """:meth:`at` of :attr:`_grid`."""
        return self.at(self._grid)

    @cached_property
    def _grid(self) -> np.ndarray:
        """:data:`GRID` + 1 parameters spaced evenly along the segment's length."""
        fine = np.linspace(0.0, 1.0, 8 * GRID + 1)
        q = self.at(fine)
        s = np.concatenate([[0.0], np.cumsum(np.sqrt(((q[1:] - q[:-1]) ** 2).sum(axis=1)))])
        if s[-1] == 0:
            return fine[::8]
        return np.interp(np.linspace(0.0, s[-1], GRID + 1), s, fine)


@dataclass(frozen=True)
class Foot:
    """The nearest points of a batch of positions: per row, its ``segment`` (index in the
    path), ``param`` (in [0, 1] along it), ``point`` and ``distance`` (LSB)."""

    segment: np.ndarray
    param: np.ndarray
    point: np.ndarray
    distance: np.ndarray


class Path:
    """The programmed path of ``moves`` on a machine of ``axes`` axes."""

    def __init__(self, moves: Sequence[Move], axes: int):
        self.moves = tuple(moves)
        self.axes = axes
        self.segments: Sequence[Segment] = _Segments(self.moves, axes)
        t = self.table = _Table(self.moves, axes)
        #: Each segment's length (:attr:`Segment.length`: a plane arc's is its radius times
        #: its sweep) and the arc length from the path's start to each segment's end (LSB).
        self.lengths = np.where(t.kind == LINE, np.sqrt(t.length2), t.radius * t.sweep)
        sampled = np.flatnonzero(t.kind == SAMPLED)
        self.lengths[sampled] = [self.segments[k].length for k in sampled]
        self.ends = np.cumsum(self.lengths)
        #: Each segment's length, or 1 where it has none (what a length is divided by).
        self.divisors = np.where(self.lengths == 0, 1.0, self.lengths)

    def foot(self, k: int, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Parameter and nearest point on segment ``k`` of each row of ``p``."""
        return self.segments[k].foot(np.asarray(p, dtype=float))

    def feet(self, k: np.ndarray, p: np.ndarray, top: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray]:
        """Parameter and nearest point of each row of ``p`` on its segment ``k`` (per row),
        up to parameter ``top`` (per row): :meth:`Segment.foot` of each row, lines and arcs
        all at once."""
        if len(k) and self.table.only is not None:  # one kind: no split
            return self._feet(self.table.only, k, p, top)
        kind = self.table.kind[k]
        if len(k) and (kind == kind[0]).all():  # one kind (one row): no split
            return self._feet(int(kind[0]), k, p, top)
        u, q = np.empty(len(p)), np.empty_like(p)
        for which in (LINE, ARC, SAMPLED):
            rows = np.flatnonzero(kind == which)
            if len(rows):
                u[rows], q[rows] = self._feet(which, k[rows], p[rows], top[rows])
        return u, q

    def _feet(self, kind: int, k: np.ndarray, p: np.ndarray, top: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`feet` on segments of one ``kind``."""
        t = self.table
        one: np.ndarray | int = k
        if (k == k[0]).all():  # one segment: its constants as one row, not one per row
            one = int(k[0])
        if kind == LINE:
            return line_foot(p, t.start[one], t.d[one], t.length2[one], top)
        if kind == ARC:
            first, second = t.plane or (t.first[one], t.second[one])
            if isinstance(one, int):
                first, second = int(first), int(second)
            centre, a0 = t.centre[one], t.a0[one]
            u = arc_param(p, first, second, centre, a0, t.sweep[one], t.cw[one], top)
            return u, arc_points(u, t.start[one], t.d[one], first, second, centre,
                                  t.radius[one], a0, t.turn[one])
        if isinstance(one, int):
            return self.segments[one].foot(p, top)
        u, q = np.empty(len(p)), np.empty_like(p)
        for segment in np.unique(k):
            on = np.flatnonzero(k == segment)
            u[on], q[on] = self.segments[segment].foot(p[on], top[on])
        return u, q

    def directions(self, k: np.ndarray, u: np.ndarray) -> np.ndarray:
        """The direction of travel of segment ``k`` at parameter ``u`` (per row; not of unit
        length): a line's own, an arc's tangent (a helix's with its rise), a curve's chord
        across a 1/256 of its parameter."""
        t = self.table
        out = t.d[k]
        arcs = np.flatnonzero(t.arc[k]) if t.arcs else ()
        if len(arcs):  # d/du of _arc_points: the rise d, the plane's turn r (-sin, cos)
            j = k[arcs]
            angle = t.a0[j] + t.turn[j] * u[arcs]
            out[arcs, t.first[j]] = -t.turn[j] * t.radius[j] * np.sin(angle)
            out[arcs, t.second[j]] = t.turn[j] * t.radius[j] * np.cos(angle)
        for segment in np.unique(k[t.sampled[k]]) if t.sampleds else ():
            on = np.flatnonzero(k == segment)
            ahead = self.segments[segment].at(np.minimum(u[on] + 1 / 256, 1.0))
            out[on] = ahead - self.segments[segment].at(np.maximum(u[on] - 1 / 256, 0.0))
        return out

    def nearest(self, p: np.ndarray, first: int, last: int) -> Foot:
        """The nearest point of each row of ``p`` on segments ``first`` to ``last``
        (inclusive); of equal distances the furthest segment's."""
        p = np.asarray(p, dtype=float)
        best: Foot | None = None
        for k in range(first, last + 1):
            u, q = self.segments[k].foot(p)
            d = np.sqrt(((q - p) ** 2).sum(axis=1))
            if best is None:
                best = Foot(np.full(len(p), k), u, q, d)
                continue
            take = d <= best.distance + TIE
            best = Foot(np.where(take, k, best.segment), np.where(take, u, best.param),
                        np.where(take[:, None], q, best.point), np.where(take, d, best.distance))
        assert best is not None
        return best



class _Segments(Sequence[Segment]):
    """The segments of ``moves``, each made when first asked for."""

    def __init__(self, moves: Sequence[Move], axes: int):
        self._moves, self._axes = moves, axes
        self._made: dict[int, Segment] = {}

    def __len__(self) -> int:
        return len(self._moves)

    @overload
    def __getitem__(self, k: int) -> Segment: ...

    @overload
    def __getitem__(self, k: slice) -> list[Segment]: ...

    def __getitem__(self, k: int | slice) -> Segment | list[Segment]:
        if isinstance(k, slice):
            return [self[j] for j in range(*k.indices(len(self)))]
        k = range(len(self))[k]  # negative indices, and IndexError past the end
        if k not in self._made:
            self._made[k] = Segment(self._moves[k], self._axes)
        return self._made[k]


def _kind(move: Move, axes: int) -> int:
    """A line, a plane arc (closed forms) or a segment searched along (:attr:`Segment.sampled`)."""
    if isinstance(move, Line):
        return SAMPLED if move.curve is not None else LINE
    if isinstance(move, Arc):
        normal = move.plane_axes[2]
        return SAMPLED if normal < axes and move.end[normal] != move.start[normal] else ARC
    return SAMPLED


class _Table:
    """The segments' constants as arrays (one row per segment; an arc's only on an arc), for
    :meth:`Path.feet`."""

    def __init__(self, moves: Sequence[Move], axes: int):
        n = len(moves)
        self.kind = np.array([_kind(m, axes) for m in moves], dtype=int)
        #: A curve: its points part of the way along it may lie farther from its start than
        #: that part of its length (a line's, an arc's and a helix's do not).
        self.curve = (self.kind == SAMPLED) & np.array([not isinstance(m, Arc) for m in moves],
                                                        dtype=bool)
        self.start = np.array([m.start[:axes] for m in moves], dtype=float).reshape(n, axes)
        self.d = np.array([m.end[:axes] for m in moves], dtype=float).reshape(n, axes) - self.start
        self.length2 = (self.d * self.d).sum(axis=1)
        #: Each segment's length as :meth:`Path.directions` gives a line's direction, summed
        #: axis by axis (a line's is its length).
        self.norm = np.sqrt(sum_axes(self.d * self.d))
        self.first, self.second = np.zeros(n, dtype=int), np.ones(n, dtype=int)
        self.centre = np.zeros((n, 2))
        self.radius, self.a0, self.sweep, self.turn = (np.ones(n) for _ in range(4))
        self.cw = np.zeros(n, dtype=bool)
        arcs = np.flatnonzero(self.kind == ARC)
        for k in arcs:
            m = moves[k]
            assert isinstance(m, Arc)
            (self.first[k], self.second[k], _), self.centre[k] = m.plane_axes, m.center
            self.radius[k], (self.a0[k], self.sweep[k]), self.cw[k] = m.radius, m.span, m.cw
            self.turn[k] = -self.sweep[k] if m.cw else self.sweep[k]
        #: Each segment a plane arc, or one searched along; whether any is.
        self.arc, self.sampled = self.kind == ARC, self.kind == SAMPLED
        self.arcs, self.sampleds = bool(self.arc.any()), bool(self.sampled.any())
        self.curves = bool(self.curve.any())
        #: The one kind of every segment, if they have one.
        self.only = int(self.kind[0]) if n and (self.kind == self.kind[0]).all() else None
        planes = {(int(self.first[k]), int(self.second[k])) for k in arcs}
        #: The plane axes of every arc when they share one (else each row's own).
        self.plane = planes.pop() if len(planes) == 1 else None
