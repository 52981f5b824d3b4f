"""Splines (G05, G05.1, G05.2/G05.3) as the lines the K3701 runs, and their exact curves.

The K3701 has no spline interpolation: the host runs a spline as lines (chords) whose every
point is within the arc tolerance of the curve, found by halving the curve's parameter
interval, from the pieces between its knots, until seven points along each chord are within
it. Each chord keeps the exact curve between its ends (:class:`SplineSpan`), so that the
contour error is measured against the programmed curve, not against the chords.

All three forms are rational B-splines in the plane (:class:`Nurbs`), as LinuxCNC runs them:

* G05, a cubic Bezier: the start, the start + (I, J), the end + (P, Q), the end;
* G05.1, a quadratic B-spline: the start, the start + (I, J), the end;
* G05.2 ... G05.3, a NURBS of order L (default 3): the start and the control points of the
  lines between, each with its weight P (default 1), on a clamped uniform knot vector.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

__all__ = ["MAX_CHORDS", "Nurbs", "SplineSpan", "bezier", "chords"]

#: The most chords one spline becomes; a finer spline is refused.
MAX_CHORDS = 100_000
#: Points of the exact curve a span keeps for its distance to a sample (per chord).
_SPAN_POINTS = 33


@dataclass(frozen=True)
class Nurbs:
    """A rational B-spline in the plane: control points (LSB), their weights and the order
    (degree + 1), on the clamped uniform knot vector of the parameter range [0, 1]."""

    points: tuple[tuple[float, float], ...]
    weights: tuple[float, ...]
    order: int
    knots: tuple[float, ...] = field(init=False)

    def __post_init__(self) -> None:
        n, k = len(self.points), self.order
        if not 2 <= k <= n:
            raise ValueError(f"a spline of order {k} needs at least {k} control points, not {n}")
        if len(self.weights) != n or min(self.weights) <= 0:
            raise ValueError("every control point needs a positive weight")
        inner = [i / (n - k + 1) for i in range(1, n - k + 1)]
        object.__setattr__(self, "knots", (0.0,) * k + tuple(inner) + (1.0,) * k)

    def at(self, t: np.ndarray) -> np.ndarray:
        """The curve's points at parameters ``t`` (rows of x, y), by de Boor's algorithm in
        homogeneous coordinates."""
        t = np.clip(np.asarray(t, dtype=float), 0.0, 1.0)
        k, knots = self.order, np.array(self.knots)
        w = np.array(self.weights, dtype=float)
        ctrl = np.column_stack([np.array(self.points, dtype=float) * w[:, None], w])  # (n, 3)
        span = np.clip(np.searchsorted(knots, t, side="right") - 1, k - 1, len(self.points) - 1)
        d = np.stack([ctrl[span - k + 1 + j] for j in range(k)], axis=1)  # (m, k, 3)
        for r in range(1, k):
            for j in range(k - 1, r - 1, -1):
                i = span - k + 1 + j
                left, right = knots[i], knots[i + k - r]
                alpha = np.where(right > left, (t - left) / np.where(right > left,
                                                                     right - left, 1), 0.0)
                d[:, j] = (1 - alpha)[:, None] * d[:, j - 1] + alpha[:, None] * d[:, j]
        top = d[:, k - 1]
        return top[:, :2] / top[:, 2:3]


@dataclass(frozen=True)
class SplineSpan:
    """The exact curve between a chord's ends: ``curve`` over [``t0``, ``t1``], in the plane of
    the machine's first two axes."""

    curve: Nurbs
    t0: float
    t1: float
    #: The third axis's position (a spline stays in its plane).
    z: float = 0.0

    def distances(self, p: np.ndarray) -> np.ndarray:
        """Distance of each row of ``p`` (machine axes) to this part of the curve (LSB)."""
        curve = self.curve.at(np.linspace(self.t0, self.t1, _SPAN_POINTS))
        a, b = curve[:-1], curve[1:]
        d = b - a
        length2 = np.maximum((d * d).sum(axis=1), 1e-12)
        rel = p[:, None, :2] - a[None]
        s = np.clip((rel * d[None]).sum(axis=2) / length2, 0.0, 1.0)
        nearest = np.hypot(*(rel - s[..., None] * d[None]).transpose(2, 0, 1)).min(axis=1)
        if p.shape[1] > 2:  # a spline keeps the third axis where it is
            nearest = np.hypot(nearest, p[:, 2] - self.z)
        return nearest


def chords(curve: Nurbs, tolerance: float) -> list[tuple[float, float]]:
    """The parameter intervals of chords within ``tolerance`` (LSB) of ``curve``, in order: each
    piece between two knots halved until seven points inside each chord's interval are within
    it (the chord ends are the curve's).
    Raises ValueError past :data:`MAX_CHORDS`."""
    done: list[tuple[float, float]] = []
    breaks = sorted(set(curve.knots))  # the curve is smooth between its knots
    todo = [(t0, t1) for t0, t1 in zip(breaks[-2::-1], breaks[:0:-1], strict=True)]
    while todo:
        t0, t1 = todo.pop()
        probe = np.linspace(t0, t1, 9)
        pts = curve.at(probe)
        a, b = pts[0], pts[-1]
        chord = b - a
        length2 = float(chord @ chord)
        rel = pts[1:-1] - a
        s = np.zeros(len(rel)) if length2 == 0 else np.clip(rel @ chord / length2, 0.0, 1.0)
        off = np.hypot(*(rel - s[:, None] * chord).T)  # to the chord, its ends included
        if off.max() <= tolerance or t1 - t0 < 1e-9:
            done.append((t0, t1))
            if len(done) > MAX_CHORDS:
                raise ValueError(f"the spline would take more than {MAX_CHORDS} lines within the "
                                 f"arc tolerance ({tolerance:g} LSB)")
        else:
            mid = (t0 + t1) / 2
            todo += [(mid, t1), (t0, mid)]
    return done


def bezier(start: Sequence[float], c1: Sequence[float], c2: Sequence[float],
           end: Sequence[float]) -> Nurbs:
    """G05's cubic Bezier as a NURBS."""
    return Nurbs((tuple(start), tuple(c1), tuple(c2), tuple(end)), (1.0,) * 4, 4)
