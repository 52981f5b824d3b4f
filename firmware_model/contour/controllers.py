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
  programmed path itself, on the stretch the tool is on
  (:class:`k37.firmware_model.contour.tracker.Tracker`, the report's contour error's).

The vector then goes through a PID (gains ``kcp``, ``kci``, ``kcd``) taken component by
component, which is the PID of the contour error distributed along the error vector while its
direction holds; the integral keeps only its part across the path's tangent (at the tool's
nearest point for the CEC, at the reference for the others), so it turns with the path. The
result is the correction (LSB) the host adds to each axis's D/A word. Every controller lets
go at a corner (:data:`CORNER_DEG`), the CCC also where the path turns too far between the
tool and the reference (:data:`CCC_TURN_DEG`).
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import pairwise

import numpy as np

from k37.firmware_model.contour.path import Path, Segment
from k37.firmware_model.contour.tracker import Tracker
from k37.firmware_model.job import ContourConfig
from k37.firmware_model.motion.program import Move

__all__ = ["CCC_TURN_DEG", "CORNER_DEG", "ContourController", "derivatives", "error_vector"]

#: A junction whose tangent turns by more than this (degrees) is a corner: every controller
#: lets go of the tool from when the reference passes it until the tool's nearest point does.
CORNER_DEG = 30.0
#: The CCC also lets go while the tangent at the reference is more than this (degrees) off the
#: tangent at the tool's nearest point: its tangent line is then off the path at the tool by
#: |E| sin(7.5 degrees), an eighth of the following error, or more.
CCC_TURN_DEG = 15.0


def derivatives(segment: Segment, u: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Q, Q' and Q'' of ``segment`` at ``u`` (central differences, kept inside it)."""
    h = 1e-4
    c = min(max(u, h), 1 - h)
    before, q, after = segment.at(np.array([c - h, c, c + h]))
    q = segment.at(np.array([u]))[0] if c != u else q
    return q, (after - before) / (2 * h), (after - 2 * q + before) / (h * h)


def error_vector(controller: str, path: Path, running: int, reference: np.ndarray,
                 actual: np.ndarray, tracker: Tracker | None = None) -> np.ndarray:
    """The contour error vector (LSB) of ``controller``'s model: from ``actual`` to its
    estimate of the nearest point of the path. ``running`` is the segment the reference is
    on; the CEC's nearest point is ``tracker``'s (default: a fresh one, from the path's
    start), never past the segment after ``running``."""
    if controller == "cec":
        tracker = tracker or Tracker(path)
        foot = tracker.track(actual[None], np.array([min(running + 1, len(path.moves) - 1)]))
        return foot.point[0] - actual
    segment = path.segments[running]
    u = float(segment.foot(reference[None])[0][0])
    _, d1, d2 = derivatives(segment, u)
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
        self.path = Path(moves, axes)
        #: The tool's progress along the path (the CEC's nearest point).
        self.tracker = Tracker(self.path)
        #: The segments that end in a corner.
        self.corners = np.flatnonzero([_turn(a, b) > CORNER_DEG
                                       for a, b in pairwise(self.path.segments)])
        self.integral = np.zeros(axes)
        self.last: np.ndarray | None = None

    def correction(self, move_index: int, reference: np.ndarray,
                   actual: np.ndarray) -> np.ndarray:
        """The correction (LSB per axis) for this sample, with the program's move
        ``move_index`` (its item index) running."""
        c = self.config
        running = self.index[move_index]
        actual = np.asarray(actual, dtype=float)
        foot = self.tracker.track(actual[None],
                                  np.array([min(running + 1, len(self.path.moves) - 1)]))
        # The path's unit tangent at the tool's nearest point (the CEC's, the CCC's) and at
        # the reference (the VGCCC's, the CCC's).
        at_tool = at_reference = np.zeros_like(actual)
        if c.controller != "vgccc":
            at_tool = _unit_tangent(self.path.segments[int(foot.segment[0])],
                                    float(foot.param[0]))
        if c.controller != "cec":
            segment = self.path.segments[running]
            at_reference = _unit_tangent(segment, float(segment.foot(np.asarray(
                reference, dtype=float)[None])[0][0]))
        if (((self.corners >= self.tracker.segment) & (self.corners < running)).any()
                or (c.controller == "ccc" and _angle(at_tool, at_reference) > CCC_TURN_DEG)):
            # The reference has turned a corner the tool has not (or, for the CCC, whose
            # path is the tangent line at the reference, the path turns too far between
            # them): the controller lets go (the position loops turn the corner) and starts
            # afresh once the tool's nearest point is past it (no derivative kick, no
            # integral of the stretch before).
            self.integral[:] = 0
            self.last = None
            return np.zeros_like(actual)
        error = (foot.point[0] - actual if c.controller == "cec" else
                 error_vector(c.controller, self.path, running,
                              np.asarray(reference, dtype=float), actual))
        # The integral keeps only its part across the path (the contour error's part): as
        # the path turns, its part along the new tangent is dropped, and the rest turns with
        # the path (a component-wise integral of an error that turns with the path, round a
        # circle, would keep a constant part that pushes the whole circle off centre).
        along = at_tool if c.controller == "cec" else at_reference
        self.integral -= (self.integral @ along) * along
        self.integral += error * self.period_s
        change = np.zeros_like(error) if self.last is None else error - self.last
        self.last = error
        return c.kcp * error + c.kci * self.integral + c.kcd * change / self.period_s


def _unit_tangent(segment: Segment, u: float) -> np.ndarray:
    """The unit tangent of ``segment`` at ``u`` (zero where it has none)."""
    d1 = derivatives(segment, u)[1]
    size = float(np.sqrt(d1 @ d1))
    return d1 / size if size else d1


def _turn(before: Segment, after: Segment) -> float:
    """How far the tangent turns (degrees) from the end of ``before`` to the start of
    ``after``."""
    return _angle(derivatives(before, 1.0)[1], derivatives(after, 0.0)[1])


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    """The angle (degrees) between directions ``a`` and ``b`` (none if either is zero)."""
    size = float(np.sqrt((a @ a) * (b @ b)))
    if size == 0:
        return 0.0
    return float(np.degrees(np.arccos(np.clip(a @ b / size, -1.0, 1.0))))
