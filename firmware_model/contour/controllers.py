"""The host's contour controllers: each sample, a contour error vector and a PID on it.

All three controllers estimate, from the axes' reference and actual positions, the vector from
the tool P to the nearest point of the path, and differ only in that estimate (the
contour-error paper's point: its controller is better because its error model is):

* ``ccc``, Koren's cross-coupled controller: the nearest point of the path's tangent line at
  the reference point R, so the vector is the following error E = R - P less its tangential
  part (exact on a line: Koren's -Ex sin(theta) + Ey cos(theta) along the normal);
* ``vgccc``, Koren and Lo's variable-gain CCC: the nearest point of the osculating circle at R
  (its gains follow the direction theta and the radius of curvature rho there, every sample);
  on a straight piece, the CCC's;
* ``cec``, the contour-error paper's contour error controller: the nearest point of the
  programmed path itself (:meth:`k37.firmware_model.contour.geometry.Piece.nearest`), searched on
  the running move and its neighbours.

The vector then goes through a PID (gains ``kcp``, ``kci``, ``kcd``) taken component by
component, which is the PID of the contour error distributed along the error vector while its
direction holds; the result is the correction (LSB) the host adds to each axis's D/A word.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from k37.firmware_model.contour.geometry import Piece, piece
from k37.firmware_model.job import ContourConfig
from k37.firmware_model.motion.program import Move

__all__ = ["ContourController", "error_vector", "nearest_on"]


def nearest_on(pieces: Sequence[Piece], search: range, actual: np.ndarray
               ) -> tuple[int, np.ndarray]:
    """The piece among ``pieces[search]`` nearest to ``actual``, and its nearest point."""
    return min(((k, pieces[k].nearest(actual)[1]) for k in search),
               key=lambda found: float((found[1] - actual) @ (found[1] - actual)))


def error_vector(controller: str, pieces: Sequence[Piece], running: int, reference: np.ndarray,
                 actual: np.ndarray, search: range | None = None) -> np.ndarray:
    """The contour error vector (LSB) of ``controller``'s model: from ``actual`` to its
    estimate of the nearest point of the path. ``pieces[running]`` is the move the reference
    is on; the CEC searches ``pieces[search]`` (default: that move and its neighbours)."""
    if controller == "cec":
        if search is None:
            search = range(max(running - 1, 0), min(running + 2, len(pieces)))
        return nearest_on(pieces, search, actual)[1] - actual
    current = pieces[running]
    u, _ = current.nearest(reference)
    _, d1, d2 = current.derivatives(u)
    speed2 = float(d1 @ d1)
    if speed2 == 0:
        return reference - actual
    tangent = d1 / np.sqrt(speed2)
    curvature = (d2 - (d2 @ tangent) * tangent) / speed2  # towards the centre, 1/rho long
    bend = float(np.sqrt(curvature @ curvature))
    if controller == "ccc" or bend * float(np.abs(reference - actual).max()) < 1e-9:
        following = reference - actual
        return following - (following @ tangent) * tangent
    centre = reference + curvature / bend**2
    out = actual - centre
    distance = float(np.sqrt(out @ out))
    if distance == 0:
        return reference - actual
    return (1 / bend - distance) * out / distance


class ContourController:
    """One run's contour controller: the path of ``moves`` on ``axes`` axes, sampled every
    ``period_s``; :meth:`correction` is called once a sample."""

    def __init__(self, config: ContourConfig, moves: Sequence[Move], axes: int,
                 period_s: float):
        if not config.enabled:
            raise ValueError("a contour controller needs contour.controller other than 'none'")
        self.config = config
        self.period_s = period_s
        self.index = {move.index: k for k, move in enumerate(moves)}
        self.pieces = [piece(move, axes) for move in moves]
        self.integral = np.zeros(axes)
        self.last: np.ndarray | None = None
        #: The piece the CEC last found the tool's nearest point on.
        self.foot = 0

    def correction(self, move_index: int, reference: np.ndarray,
                   actual: np.ndarray) -> np.ndarray:
        """The correction (LSB per axis) for this sample, with the program's move
        ``move_index`` (its item index) running."""
        c = self.config
        running = self.index[move_index]
        actual = np.asarray(actual, dtype=float)
        search = None
        if c.controller == "cec":
            # The tool lags the reference by many short moves (a spline's chords): its foot is
            # tracked from sample to sample, never past the move after the running one.
            start = min(max(self.foot - 1, 0), running)
            search = range(start, min(max(self.foot + 3, start + 1), running + 2,
                                      len(self.pieces)))
            self.foot = nearest_on(self.pieces, search, actual)[0]
            search = range(self.foot, self.foot + 1)
        error = error_vector(c.controller, self.pieces, running,
                             np.asarray(reference, dtype=float), actual, search)
        self.integral += error * self.period_s
        change = np.zeros_like(error) if self.last is None else error - self.last
        self.last = error
        return c.kcp * error + c.kci * self.integral + c.kcd * change / self.period_s
