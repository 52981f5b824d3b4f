"""The programmed path as one geometry: every consumer of the contour error measures with it
(the report and its plots, the sweeps, the host's contour controllers).

A :class:`Path` holds each move of a program as a parametric segment Q(u), u in [0, 1], in
machine coordinates (LSB): a line (a correction move is one), an arc or helix, the K3701's
parabola or exponential in its own frame, or the exact curve of a G5 spline's chord. For a
batch of positions, :meth:`Path.foot` gives each one's nearest point of a segment and its
parameter: in closed form on a line and a plane arc (a helix that does not rise is one); on a
rising helix and the curves, the nearest of points spaced evenly along the segment's length
brackets the minimum, which a golden-section search then closes in on (never a step outside
the bracket). No numerical warning comes out: the curves are only evaluated between their ends.

A :class:`Tracker` follows the tool along the path, sample after sample: each sample's nearest
point is searched from the segment the previous sample was matched on (the tool's progress
is monotone, so an earlier pass of the path is never a candidate) forward over the path that
lies within the previous sample's contour error, twice the tool's travel since then and
:data:`REACH` of that segment's end (the segments after it only that far along them), and
never past the block after the one the interpolator runs at its cycle (the tool is not ahead
of the interpolator). Of equal distances the furthest segment wins (a retraced stretch hands
over to its next segment).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from k37.firmware_model.motion.program import Arc, Line, Move

__all__ = ["REACH", "Foot", "Path", "Segment", "Tracker"]

#: Arc length (LSB) a tracker's window reaches past the end of the last matched segment, on
#: top of the tool's distance to it and twice its travel since the previous sample.
REACH = 16.0

#: Points spaced evenly along a curve or helix that bracket its nearest point.
GRID = 64
#: Golden-section steps on the bracket: it shrinks to 0.618^40 (1e-8) of two grid spacings.
GOLDEN_STEPS = 40
#: Distances this close (LSB) count as equal: the furthest segment is taken.
TIE = 1e-6
_GOLD = (math.sqrt(5) - 1) / 2


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
    def _circle(self) -> tuple[int, int, np.ndarray, float, float, float, bool]:
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
                return self.start + np.outer(u, self.end - self.start)
            span = m.curve
            plane = span.curve.at(span.t0 + (span.t1 - span.t0) * u)
            return plane if self.axes == 2 else np.column_stack([plane, np.full(len(u), span.z)])
        if isinstance(m, Arc):
            first, second, centre, radius, a0, sweep, cw = self._circle
            angle = a0 + (-sweep if cw else sweep) * u
            rows = self.start + np.outer(u, self.end - self.start)  # a helix rises evenly
            rows[:, first] = centre[0] + radius * np.cos(angle)
            rows[:, second] = centre[1] + radius * np.sin(angle)
            return rows
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
            return float(np.sqrt((self.end - self.start) @ (self.end - self.start)))
        q = self.at(np.linspace(0.0, 1.0, 257))
        return float(np.sqrt(((q[1:] - q[:-1]) ** 2).sum(axis=1)).sum())

    @cached_property
    def _sampled(self) -> bool:
        """No closed form: a spline's chord, a curve, a rising helix."""
        m = self.move
        if isinstance(m, Line):
            return m.curve is not None
        if isinstance(m, Arc):
            normal = m.plane_axes[2]
            return normal < self.axes and m.end[normal] != m.start[normal]
        return True

    def foot(self, p: np.ndarray, top: np.ndarray | None = None
             ) -> tuple[np.ndarray, np.ndarray]:
        """The parameter of each row of ``p``'s nearest point of the segment, and that point;
        with ``top``, of the part of it up to that parameter (per row; on a curve, the
        nearest point beyond it is drawn back to it)."""
        if self._sampled:
            u, q = self._search(p)
            if top is None or not (u > top).any():
                return u, q
            u = np.minimum(u, top)
            return u, self.at(u)
        end = 1.0 if top is None else top
        if isinstance(self.move, Line):
            d = self.end - self.start
            length2 = float(d @ d)
            u = (np.zeros(len(p)) if length2 == 0
                 else np.clip((p - self.start) @ d / length2, 0.0, end))
            return u, self.start + np.outer(u, d)
        first, second, centre, _, a0, sweep, cw = self._circle
        angle = np.arctan2(p[:, second] - centre[1], p[:, first] - centre[0])
        off = ((a0 - angle) if cw else (angle - a0)) % math.tau
        # Past the sweep: the nearer end (the angle half way round the rest splits them).
        swept = sweep * end
        u = np.where(off <= swept, off / sweep,
                     np.where(off - swept < (math.tau - swept) / 2, end, 0.0))
        return u, self.at(u)

    def _search(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        grid = self._grid
        q = self.at(grid)
        k = np.argmin(((p[:, None, :] - q[None]) ** 2).sum(axis=2), axis=1)
        lo, hi = grid[np.maximum(k - 1, 0)], grid[np.minimum(k + 1, len(grid) - 1)]

        def dist2(u: np.ndarray) -> np.ndarray:
            return ((self.at(u) - p) ** 2).sum(axis=1)

        a, b = hi - _GOLD * (hi - lo), lo + _GOLD * (hi - lo)
        fa, fb = dist2(a), dist2(b)
        for _ in range(GOLDEN_STEPS):
            left = fa <= fb  # the minimum is in [lo, b]
            hi, lo = np.where(left, b, hi), np.where(left, lo, a)
            b, fb = np.where(left, a, b), np.where(left, fa, fb)
            a = np.where(left, hi - _GOLD * (hi - lo), b)
            b = np.where(left, b, lo + _GOLD * (hi - lo))
            fresh = dist2(np.where(left, a, b))
            fa, fb = np.where(left, fresh, fb), np.where(left, fb, fresh)
        u = np.where(fa <= fb, a, b)
        # The ends and the grid's nearest point stand too (the minimum may sit on an end).
        cands = np.column_stack([u, np.zeros(len(p)), np.ones(len(p)), grid[k]])
        d2 = np.column_stack([dist2(c) for c in cands.T])
        u = cands[np.arange(len(p)), np.argmin(d2, axis=1)]
        return u, self.at(u)

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
        self.segments = [Segment(m, axes) for m in self.moves]
        #: Arc length from the path's start to each segment's end (LSB).
        self.ends = np.cumsum([s.length for s in self.segments])

    def foot(self, k: int, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Parameter and nearest point on segment ``k`` of each row of ``p``."""
        return self.segments[k].foot(np.asarray(p, dtype=float))

    def nearest(self, p: np.ndarray, first: int, last: int | np.ndarray,
                on_first: Foot | None = None, reach: np.ndarray | None = None) -> Foot:
        """The nearest point of each row of ``p`` on segments ``first`` to ``last``
        (inclusive; one for all rows or one per row, at least ``first``); of equal distances
        the furthest segment's. ``on_first``: the rows' nearest points on ``first``, if
        known; ``reach``: how far along the path (LSB from its start, per row) the segments
        after ``first`` are candidates."""
        p = np.asarray(p, dtype=float)
        last = np.broadcast_to(last, len(p))
        best = on_first
        for k in range(first if best is None else first + 1, int(last.max(initial=first)) + 1):
            top = None
            if reach is not None and k > first:
                length = self.segments[k].length
                top = np.clip((reach - self.ends[k - 1]) / length, 0.0, 1.0) if length else None
            u, q = self.segments[k].foot(p, top)
            d = np.sqrt(((q - p) ** 2).sum(axis=1))
            if best is None:
                best = Foot(np.full(len(p), k), u, q, d)
                continue
            take = (d <= best.distance + TIE) & (k <= last)
            best = Foot(np.where(take, k, best.segment), np.where(take, u, best.param),
                        np.where(take[:, None], q, best.point), np.where(take, d, best.distance))
        assert best is not None
        return best


class Tracker:
    """The tool's progress along ``path``: :meth:`track` takes the samples in order, in as
    many calls as wanted (the matched segment carries over)."""

    def __init__(self, path: Path):
        self.path = path
        self.segment = 0
        #: The last sample's position and its distance to the path (none yet).
        self.last: np.ndarray | None = None
        self.error = 0.0

    def track(self, p: np.ndarray, limit: np.ndarray) -> Foot:
        """The nearest points of positions ``p`` (rows, in sample order), each searched in
        its window from the previous sample's segment, never past ``limit`` (per row: the
        last segment the tool may be on)."""
        p = np.asarray(p, dtype=float)
        n = len(p)
        out = Foot(np.zeros(n, dtype=int), np.zeros(n), np.zeros_like(p), np.zeros(n))
        i, batch = 0, 64
        while i < n:
            # Rows from i on, each as if the previous one were on the current segment: right
            # up to the first that moves on (it is right too).
            rows = slice(i, min(n, i + batch))
            found = self._window(p[rows], limit[rows])
            moved = np.flatnonzero(found.segment != self.segment)
            done = rows.stop - i if not len(moved) else int(moved[0]) + 1
            part = slice(i, i + done)
            out.segment[part], out.param[part] = found.segment[:done], found.param[:done]
            out.point[part], out.distance[part] = found.point[:done], found.distance[:done]
            self.segment = int(found.segment[done - 1])
            self.last, self.error = p[i + done - 1].copy(), float(found.distance[done - 1])
            i += done
            batch = 2 * batch if not len(moved) else max(16, 2 * done)
        return out

    def _window(self, p: np.ndarray, limit: np.ndarray) -> Foot:
        """The nearest points of rows ``p`` in their windows, each as if the row before were
        on the current segment."""
        c = self.segment
        u, q = self.path.foot(c, p)
        here = Foot(np.full(len(p), c), u, q, np.sqrt(((q - p) ** 2).sum(axis=1)))
        before = np.vstack([p[:1] if self.last is None else self.last[None], p[:-1]])
        travel = np.sqrt(((p - before) ** 2).sum(axis=1))
        error = np.concatenate([[self.error], here.distance[:-1]])
        reach = self.path.ends[c] + error + 2 * travel + REACH
        last = np.minimum(np.searchsorted(self.path.ends, reach), len(self.path.ends) - 1)
        return self.path.nearest(p, c, np.maximum(np.minimum(last, limit), c), here, reach)
