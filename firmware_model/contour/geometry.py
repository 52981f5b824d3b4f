"""The programmed path as the host's contour controllers see it.

Each move is a parametric piece Q(u) over [lo, hi] in machine coordinates (LSB): a line, an
arc or helix, the K3701's parabola or exponential in its own frame, or the exact curve of a G5
spline's chord. :meth:`Piece.nearest` finds the nearest point of a piece to a position by the
contour-error paper's method: the root of (Q(u) - P) . Q'(u) = 0 (its eq. (4)) by
Newton-Raphson safeguarded with bisection, from a bracket found on a coarse grid.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from k37.firmware_model.motion.program import Arc, Line, Move

__all__ = ["GRID", "Piece", "piece"]

#: Points of the coarse grid that brackets the nearest point.
GRID = 64
#: Newton-Raphson (or bisection) steps at most; the bracket shrinks at every one.
MAX_STEPS = 40


@dataclass(frozen=True)
class Piece:
    """One move's path: ``point`` maps an array of parameters in [``lo``, ``hi``] to rows of
    machine coordinates (LSB)."""

    point: Callable[[np.ndarray], np.ndarray]
    lo: float
    hi: float

    def derivatives(self, u: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Q, Q' and Q'' at ``u`` (central differences, kept inside the piece)."""
        h = 1e-4 * (self.hi - self.lo)
        c = min(max(u, self.lo + h), self.hi - h)
        before, q, after = self.point(np.array([c - h, c, c + h]))
        q = self.point(np.array([u]))[0] if c != u else q
        return q, (after - before) / (2 * h), (after - 2 * q + before) / (h * h)

    def nearest(self, p: np.ndarray) -> tuple[float, np.ndarray]:
        """The parameter of the nearest point of the piece to ``p``, and that point."""
        grid = np.linspace(self.lo, self.hi, GRID + 1)
        k = int(np.argmin(np.sum((self.point(grid) - p) ** 2, axis=1)))
        a, b = grid[max(k - 1, 0)], grid[min(k + 1, GRID)]

        def f(u: float) -> tuple[float, float]:
            q, d1, d2 = self.derivatives(u)
            return float((q - p) @ d1), float(d1 @ d1 + (q - p) @ d2)

        fa, fb = f(a)[0], f(b)[0]
        if fa > 0 or fb < 0:  # no root in the bracket: the nearest point is a grid end
            u = a if fa > 0 else b
            return u, self.point(np.array([u]))[0]
        u = float(grid[k])
        for _ in range(MAX_STEPS):
            value, slope = f(u)
            if value == 0:
                break
            if value < 0:
                a = u
            else:
                b = u
            step = u - value / slope if slope > 0 else math.nan
            new = step if a < step < b else (a + b) / 2
            if abs(new - u) <= 1e-12 * (self.hi - self.lo):
                u = new
                break
            u = new
        return u, self.point(np.array([u]))[0]


def _line(item: Line, axes: int) -> Piece:
    start = np.array(item.start[:axes], dtype=float)
    end = np.array(item.end[:axes], dtype=float)
    if item.curve is None:
        return Piece(lambda u: start + np.outer(u, end - start), 0.0, 1.0)
    span = item.curve

    def spline(t: np.ndarray) -> np.ndarray:
        plane = span.curve.at(t)
        return plane if axes == 2 else np.column_stack([plane, np.full(len(plane), span.z)])

    return Piece(spline, span.t0, span.t1)


def _arc(item: Arc, axes: int) -> Piece:
    first, second, _ = item.plane_axes
    a0, sweep = item.span
    turn = -sweep if item.cw else sweep
    centre, radius = item.center, item.radius
    start = np.array(item.start[:axes], dtype=float)
    end = np.array(item.end[:axes], dtype=float)

    def arc(u: np.ndarray) -> np.ndarray:
        rows = start + np.outer(u, end - start)  # a helix's normal axis rises in proportion
        angle = a0 + turn * u
        rows[:, first] = centre[0] + radius * np.cos(angle)
        rows[:, second] = centre[1] + radius * np.sin(angle)
        return rows

    return Piece(arc, 0.0, 1.0)


def piece(item: Move, axes: int) -> Piece:
    """The path of move ``item`` on a machine of ``axes`` axes."""
    if isinstance(item, Line):
        return _line(item, axes)
    if isinstance(item, Arc):
        return _arc(item, axes)
    return Piece(item.at, 0.0, item.extent)  # the K3701's parabola or exponential (two axes)
