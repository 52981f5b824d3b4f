"""The K3701's curves on the host side: the checks the host makes before loading a parabola
(G06), and the distance to its true curve (the program item is
:class:`firmware_model.program.Parabola`).

A G06 block gives the end point and the point P of the parabola whose tangent is parallel to
the chord from the start to the end (DIN 66025). The K3701 draws parabolas whose axis is
parallel to X or to Y (:class:`hdl.k3701_model.ParabolicPath`): P must then lie half way along
the chord on the abscissa (within the LSB rounding of an odd extent), and the chip takes from
P only its ordinate. The programmed curve is the chip's parabola: through the start, the end
and (the chord's middle abscissa, P's ordinate).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from hdl.k3701_model import COORD_MAX, Block, BlockError, ParabolicPath, Plan, make_path, plan

__all__ = ["MIN_VERTEX_RADIUS", "CurveError", "frame_distances", "parabola_block"]

#: The sharpest parabola the host loads: its radius of curvature at the vertex, A / (2 |B|),
#: in LSB. The visited points stay within 0.5 LSB of the parabola from there on (the sign-of-F
#: choice drifts from the nearest point where the curve bends within a few LSB, as the
#: circle's does below a radius of 3).
MIN_VERTEX_RADIUS = 8


class CurveError(ValueError):
    """A curve the host refuses to load; the message says why (one line)."""


def curve_distances(f: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]],
                    pv: np.ndarray, span: tuple[float, float] | None = None) -> np.ndarray:
    """Distance of each (p, v) row to the curve v = f(p) (within ``span`` of p, if given);
    ``f`` gives the function, its slope and its second derivative at an array of p. Newton on
    d/dq [(q - p)^2 + (f(q) - v)^2] / 2 from starts around p, the nearest foot kept."""
    best = np.full(len(pv), np.inf)
    for offset in np.linspace(-2.0, 2.0, 41):
        q = pv[:, 0] + offset
        for _ in range(8):
            value, slope, bend = f(q)
            miss = value - pv[:, 1]
            q = q - ((q - pv[:, 0]) + miss * slope) / (1 + slope * slope + bend * miss)
        if span is not None:
            q = np.clip(q, *span)
        best = np.minimum(best, np.hypot(q - pv[:, 0], f(q)[0] - pv[:, 1]))
    return best


def frame_distances(qa: float, qb: float, pv: np.ndarray,
                    span: tuple[float, float] | None = None) -> np.ndarray:
    """Distance of each (p, v) row to the parabola v = qa p^2 + qb p (within ``span`` of p,
    if given)."""
    return curve_distances(lambda q: (qa * q * q + qb * q, 2 * qa * q + qb, 2 * qa + 0 * q),
                           pv, span)


def parabola_block(start: tuple[int, int], xe: int, ye: int, i: int, j: int,
                   sqrt2: bool) -> tuple[Block, Plan]:
    """The K3701 block of a G06 from ``start`` (absolute) to (xe, ye) through the tangent
    point (i, j) (both relative to the start), and its plan.

    Raises :class:`CurveError` when the parabola's axis is parallel to neither X nor Y, it is
    sharper than :data:`MIN_VERTEX_RADIUS`, the chip refuses it, or it leaves the coordinate
    range between its ends.
    """
    along_x = xe != 0 and abs(2 * i - xe) <= 1
    along_y = ye != 0 and abs(2 * j - ye) <= 1
    if not along_x and not along_y:
        raise CurveError(
            f"the K3701 draws parabolas whose axis is parallel to X or Y: the tangent point "
            f"({i}, {j}) must lie half way along the chord in X ({xe / 2:g}) or in Y "
            f"({ye / 2:g}) LSB")
    swap = not along_x or (along_y and abs(ye) > abs(xe))
    block = Block.parabola(xe, ye, i, j, swap=swap, sqrt2=sqrt2)
    try:
        path = make_path(block)
    except BlockError as e:
        raise CurveError(f"the K3701 refuses this parabola: {e}") from None
    assert isinstance(path, ParabolicPath)
    if path.b and path.a < 2 * MIN_VERTEX_RADIUS * abs(path.b):
        raise CurveError(f"the parabola is too sharp for the K3701: radius of curvature "
                         f"{path.a / (2 * abs(path.b)):.2f} LSB at its vertex, below "
                         f"{MIN_VERTEX_RADIUS} LSB")
    if path.b and 0 < -path.c / (2 * path.b) < path.pe:
        vertex = start[0 if swap else 1] - path.c * path.c / (4 * path.a * path.b)
        if math.ceil(abs(vertex) - 1e-9) > COORD_MAX:
            raise CurveError(f"the parabola leaves the coordinate range on "
                             f"{'X' if swap else 'Y'}: its vertex is at {vertex:.0f} LSB, "
                             f"beyond +-(2^23-1) LSB")
    result = plan(block)
    if result.error or result.end != (xe, ye):
        raise CurveError("the K3701 would not reach this parabola's end point")
    return block, result
