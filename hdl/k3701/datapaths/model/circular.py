"""Reference model of :mod:`k37.hdl.k3701.datapaths.circular`: an arc by sign-of-F stepping
(:class:`CircularPath`), and a helix's arc driving its third axis (:class:`HelicalPath`)."""

from __future__ import annotations

from k37.hdl.k3701.block import (
    MAX_RADIUS_SQUARED,
    QUADRANT_SIGNS,
    BlockError,
    Step,
    check_coord,
    quadrant_of,
)
from k37.hdl.k3701.datapaths.model.helix import HelixPath

__all__ = ["CircularPath", "HelicalPath"]

class CircularPath:
    """The incremental circle of ``docs/chips/k3701.md``, with D = x^2 + y^2 - R0^2 kept exactly.

    Each step moves the long axis (X where |y| >= |x|, Y where |x| > |y|) one LSB in the
    direction of motion and also the short axis when that makes |D| strictly smaller. The arc
    ends when, inside the armed end quadrant, the end point's long-axis coordinate is reached;
    leaving the armed quadrant without reaching it stops the arc with an error.
    """

    def __init__(self, xe: int, ye: int, i: int, j: int, cw: bool, quadrant: int):
        for name, v in (("Xe", xe), ("Ye", ye), ("I", i), ("J", j)):
            check_coord(name, v)
        if i == 0 and j == 0:
            raise BlockError("the centre equals the start point (radius 0)")
        if i * i + j * j > MAX_RADIUS_SQUARED:
            raise BlockError(f"the circle of radius {(i * i + j * j) ** 0.5:.1f} leaves the "
                             f"24-bit coordinate range")
        if quadrant not in (1, 2, 3, 4):
            raise BlockError(f"end-point quadrant must be 1..4, not {quadrant}")
        self.cw = cw
        self.x, self.y = -i, -j
        self.ex, self.ey = xe - i, ye - j
        if self.ex == 0 and self.ey == 0:
            raise BlockError("the end point is the centre")
        if quadrant_of(self.ex, self.ey, cw) != quadrant:
            raise BlockError(f"end point ({xe}, {ye}) is not in end-point quadrant {quadrant}")
        self.d = 0
        self.q = quadrant_of(self.x, self.y, cw)
        self.end_q = quadrant
        # The end check looks at the end point's long-axis coordinate.
        self.end_on_x = abs(self.ey) >= abs(self.ex)
        self.armed = self.q == self.end_q and self._ahead()
        self.done = False

    def _ahead(self) -> bool:
        sx, sy = QUADRANT_SIGNS[self.cw][self.q]
        if self.end_on_x:
            return (self.ex - self.x) * sx > 0
        return (self.ey - self.y) * sy > 0

    def _decide(self) -> tuple[Step, int]:
        """The next step and the D it leads to."""
        x, y, d = self.x, self.y, self.d
        sx, sy = QUADRANT_SIGNS[self.cw][self.q]
        if abs(y) >= abs(x):
            d1 = d + 2 * x * sx + 1
            d2 = d1 + 2 * y * sy + 1
            return (Step(sx, sy), d2) if abs(d2) < abs(d1) else (Step(sx, 0), d1)
        d1 = d + 2 * y * sy + 1
        d2 = d1 + 2 * x * sx + 1
        return (Step(sx, sy), d2) if abs(d2) < abs(d1) else (Step(0, sy), d1)

    def peek(self) -> Step:
        """The next step (the path must not be done)."""
        return self._decide()[0]

    def advance(self) -> tuple[Step, bool, bool]:
        """Take the next step; returns (step, final, error)."""
        step, self.d = self._decide()
        self.x += step.dx
        self.y += step.dy
        q = quadrant_of(self.x, self.y, self.cw)
        if not self.armed and q == self.end_q and q != self.q:
            self.armed = True
        self.q = q
        if self.armed:
            if q != self.end_q:
                self.done = True
                return step, True, True
            if (self.x == self.ex) if self.end_on_x else (self.y == self.ey):
                self.done = True
                return step, True, False
        return step, False, False


class HelicalPath:
    """An arc (:class:`CircularPath`) whose steps also drive a helix's third axis
    (:class:`HelixPath`, over ``block.helix_steps`` arc steps)."""

    def __init__(self, arc: CircularPath, helix: HelixPath):
        self.arc, self.helix = arc, helix

    @property
    def done(self) -> bool:
        return self.arc.done

    def peek(self) -> Step:
        step = self.arc.peek()
        return Step(step.dx, step.dy, self.helix.peek())

    def advance(self) -> tuple[Step, bool, bool]:
        step, final, error = self.arc.advance()
        return Step(step.dx, step.dy, self.helix.advance()), final, error
