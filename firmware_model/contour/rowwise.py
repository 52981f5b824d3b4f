"""Row-wise geometry for :mod:`k37.firmware_model.contour.path`: batches of positions (rows
of machine coordinates) against one line or arc, or one each.

numpy's sum over rows of two or three floats, and its broadcasting of one row over many or
of ``u[:, None]`` over such rows, cost several times the arithmetic itself; these functions
work axis by axis instead, with the operations of those plain expressions
(``((a - b) ** 2).sum(axis=-1)``, ``start + u[:, None] * d``) in the same order, so that
every result is theirs, bit for bit."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["along", "arc_dist2", "arc_param", "arc_points", "column", "dist2", "line_foot",
           "sum_axes"]


def sum_axes(terms: np.ndarray) -> np.ndarray:
    """The sums of the rows (last axis) of ``terms``, axis after axis as numpy's
    ``terms.sum(axis=-1)`` sums two or three, without its reduction's cost on rows this
    short."""
    total = terms[..., 0] + terms[..., 1]
    for axis in range(2, terms.shape[-1]):
        total += terms[..., axis]
    return total


def dist2(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The squared distances of the rows (last axis) of ``a`` and ``b``: ``((a - b) ** 2)``
    summed as :func:`sum_axes` sums. Rows of one shape are taken whole; else axis by axis
    (numpy broadcasts one row over many at several times the arithmetic's cost)."""
    if a.shape == b.shape:
        diff = a - b
        diff *= diff
        return sum_axes(diff)
    diff = a[..., 0] - b[..., 0]
    total = diff * diff
    for axis in range(1, a.shape[-1]):
        diff = a[..., axis] - b[..., axis]
        diff *= diff
        total += diff
    return total


def along(start: np.ndarray, u: np.ndarray, d: np.ndarray) -> np.ndarray:
    """The rows ``start`` + u ``d`` at parameters ``u`` (``start`` and ``d`` one row, or one
    per row), axis after axis: numpy broadcasts ``u[:, None] * d`` over rows this short at
    several times the arithmetic's cost."""
    points = np.empty((len(u), start.shape[-1]))
    for axis in range(points.shape[1]):
        out = points[:, axis]
        np.multiply(u, d[..., axis], out=out)
        out += start[..., axis]
    return points


def line_foot(p: np.ndarray, start: np.ndarray, d: np.ndarray, length2: np.ndarray | float,
              end: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Parameter and point of each row of ``p``'s nearest point of the line ``start`` +
    u ``d`` (its squared length ``length2``), u in [0, ``end``]; one line, or one per row."""
    dot = p[:, 0] - start[..., 0]  # ((p - start) * d) summed axis by axis
    dot *= d[..., 0]
    for axis in range(1, p.shape[1]):
        term = p[:, axis] - start[..., axis]
        term *= d[..., axis]
        dot += term
    dot /= np.where(length2 == 0, 1.0, length2)  # none: its start
    return np.clip(dot, 0.0, end, out=dot), along(start, dot, d)


def column(a: np.ndarray, axis: np.ndarray | int) -> np.ndarray:
    """Column ``axis`` of the rows ``a``: one for all rows, or one per row."""
    return a[:, axis] if isinstance(axis, int) else a[np.arange(len(a)), axis]


def arc_param(p: np.ndarray, first: np.ndarray | int, second: np.ndarray | int,
              centre: np.ndarray, a0: np.ndarray | float, sweep: np.ndarray | float,
              cw: np.ndarray | bool, end: np.ndarray) -> np.ndarray:
    """Parameter of each row of ``p``'s nearest point of a plane arc, in [0, ``end``]; one
    arc, or one per row (its plane axes ``first`` and ``second``: one pair for all rows, or
    one per row)."""
    angle = np.arctan2(column(p, second) - centre[..., 1], column(p, first) - centre[..., 0])
    off = np.where(cw, a0 - angle, angle - a0) % math.tau
    # Past the sweep: the nearer end (the angle half way round the rest splits them).
    swept = sweep * end
    return np.where(off <= swept, off / sweep,
                    np.where(off - swept < (math.tau - swept) / 2, end, 0.0))


def arc_points(u: np.ndarray, start: np.ndarray, d: np.ndarray, first: np.ndarray | int,
               second: np.ndarray | int, centre: np.ndarray, radius: np.ndarray | float,
               a0: np.ndarray | float, turn: np.ndarray | float) -> np.ndarray:
    """Points of an arc or helix (``turn``: its signed sweep) at parameters ``u``; one arc,
    or one per row (its plane axes as :func:`arc_param`'s)."""
    angle = a0 + turn * u
    points = along(start, u, d)  # a helix rises evenly
    x, y = centre[..., 0] + radius * np.cos(angle), centre[..., 1] + radius * np.sin(angle)
    if isinstance(first, int):
        points[:, first], points[:, second] = x, y
    else:
        rows = np.arange(len(u))
        points[rows, first], points[rows, second] = x, y
    return points


def arc_dist2(u: np.ndarray, columns: list[np.ndarray], first: int, second: int,
              centre: np.ndarray, radius: float, a0: float, turn: float, start: np.ndarray,
              d: np.ndarray) -> np.ndarray:
    """The squared distances of one arc's or helix's points at parameters ``u`` (as
    :func:`arc_points`, its plane axes ``first`` and ``second``) to rows given by their
    ``columns``: :func:`dist2` of those points and rows, bit for bit, each coordinate
    computed once."""
    angle = a0 + turn * u
    total = None
    for axis, column in enumerate(columns):
        if axis == first:
            diff = centre[..., 0] + radius * np.cos(angle)
        elif axis == second:
            diff = centre[..., 1] + radius * np.sin(angle)
        else:  # a helix rises evenly
            diff = u * d[axis]
            diff += start[axis]
        diff -= column
        diff *= diff
        if total is None:
            total = diff
        else:
            total += diff
    assert total is not None
    return total
