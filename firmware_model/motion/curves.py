"""The K3701's curves on the host side: the checks the host makes before loading a parabola
(G06) or an exponential (G06.1, G06.2), and the distance to their true curves (the program
items are :class:`k37.firmware_model.motion.program.Parabola` and
:class:`k37.firmware_model.motion.program.Exponential`).

A G06 block gives the end point and the point P of the parabola whose tangent is parallel to
the chord from the start to the end (DIN 66025). The K3701 draws parabolas whose axis is
parallel to X or to Y (:class:`k37.hdl.k3701.datapaths.model.parabolic.ParabolicPath`): P must then
lie half way along the chord on the abscissa (within the LSB rounding of an odd extent), and the
chip takes from P only its ordinate. The programmed curve is the chip's parabola: through the start,
the end and (the chord's middle abscissa, P's ordinate).

An exponential block gives the end point and the curve's constant K along its abscissa (X; Y
for the logarithm, which is an exponential of Y): the curve through the start and the end,
v = ve (e^(p / K) - 1) / (e^(pe / K) - 1). The chip draws c (r^p - 1) with r = 1 + 1/k, k an
integer (:class:`k37.hdl.k3701.datapaths.model.parabolic.ExponentialPath`): the host takes the k
whose r is nearest e^(1 / K), and the offset c the model shows to end on the end point. The
programmed curve is the chip's exponential: through the start and the end, of constant 1 / ln(1 +
1/k). """

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from k37.hdl.k3701.block import COORD_MAX, Block, BlockError
from k37.hdl.k3701.datapaths.model.parabolic import ExponentialPath, ParabolicPath
from k37.hdl.k3701.model.chip import Plan, make_path, plan

__all__ = ["MAX_GROWTH", "MIN_CONSTANT", "MIN_VERTEX_RADIUS", "CurveError", "curve_distances",
           "exponential_block", "exponential_frame", "frame_distances", "parabola_block"]

#: The sharpest parabola the host loads: its radius of curvature at the vertex, A / (2 |B|),
#: in LSB. The visited points stay within 0.5 LSB of the parabola from there on (the sign-of-F
#: choice drifts from the nearest point where the curve bends within a few LSB, as the
#: circle's does below a radius of 3).
MIN_VERTEX_RADIUS = 8
#: The sharpest exponential the host loads: |K| in LSB (its radius of curvature is at least
#: 2.6 |K|).
MIN_CONSTANT = 8
#: How much a growing exponential may grow over its length, (r^pe - 1) / k: its offset c is
#: loaded in steps of 1/k LSB, which move its end by that much, and the DDA's rounding
#: (fractions of 1/k^2 LSB per step) grows with the curve as much.
MAX_GROWTH = 1 / 4


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


def exponential_frame(path: ExponentialPath) -> Callable[[np.ndarray], tuple[np.ndarray, ...]]:
    """The chip's exponential in its frame (p, v): through the start and the end, of the
    path's ratio r = 1 + 1/k; for :func:`curve_distances`."""
    k = path.sk * path.k
    rate = math.log1p(1 / k)
    scale = path.ve / math.expm1(rate * path.pe) if path.ve else 0.0

    def f(q: np.ndarray) -> tuple[np.ndarray, ...]:
        grown = np.exp(rate * q)
        return scale * (grown - 1), scale * rate * grown, scale * rate * rate * grown
    return f


def exponential_block(xe: int, ye: int, constant: float, *, log: bool,
                      sqrt2: bool) -> tuple[Block, Plan]:
    """The K3701 block of an exponential (``log``: a logarithm, the exponential of Y) to
    (xe, ye) (relative to its start) of constant ``constant`` LSB along its abscissa (X, or Y
    with ``log``; negative: the curve flattens towards the end), and its plan.

    Raises :class:`CurveError` when the abscissa has no extent, the constant is below
    :data:`MIN_CONSTANT`, the curve grows faster than :data:`MAX_GROWTH` allows or is so
    nearly straight that its offset leaves the chip's range, or the chip refuses it.
    """
    pe, ve = (ye, xe) if log else (xe, ye)
    axis = "Y" if log else "X"
    if pe == 0:
        raise CurveError(f"{'a logarithm' if log else 'an exponential'} needs a non-zero "
                         f"{axis} extent")
    if not abs(constant) >= MIN_CONSTANT:
        raise CurveError(f"the curve's constant {constant:g} LSB is below the K3701's "
                         f"{MIN_CONSTANT} LSB")
    # The chip's k, in the curve's frame (p towards the end): r = 1 + 1/k nearest e^(1/K).
    k = round(1 / math.expm1((1 if pe > 0 else -1) / constant))
    growth = math.expm1(abs(pe) * math.log1p(1 / k))
    if k > 0 and growth > MAX_GROWTH * k:
        raise CurveError(f"the curve grows too fast for the K3701: by {growth + 1:.4g} times "
                         f"over {abs(pe)} LSB of {axis} with a constant of {constant:g} LSB "
                         f"(at most {MAX_GROWTH * k + 1:.4g}); use a larger constant or a "
                         f"shorter block")
    target = abs(ve) / abs(growth) * abs(k)  # c |k|, in 1/|k| LSB
    if target >= (COORD_MAX + 1) * abs(k):
        raise CurveError(f"the curve is too nearly straight for the K3701 (its offset "
                         f"{target / abs(k):.4g} LSB exceeds 2^23 - 1): use a smaller "
                         f"constant, or G01")
    offset = round(target)
    tried: set[int] = set()
    while offset not in tried:
        tried.add(offset)
        block = Block.exponential(xe, ye, k, *divmod(offset, abs(k)), swap=log, sqrt2=sqrt2)
        try:
            result = plan(block)
        except BlockError as e:
            raise CurveError(f"the K3701 refuses this curve: {e}") from None
        if not result.error:
            return block, result
        # Ended early: v passed its end (the offset is too large); else p passed its end.
        path = make_path(block)
        assert isinstance(path, ExponentialPath)
        short = result.end[1 if log else 0] * path.su > path.pe
        offset += 1 if short else -1
    raise CurveError("the K3701 would not reach this curve's end point")
