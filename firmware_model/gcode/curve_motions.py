"""G06 (parabola), G06.1 and G06.2 (exponential and logarithm) as the interpreter reads them
(a mixin of :class:`k37.firmware_model.gcode.interpreter.Interpreter`); the curves themselves
are :mod:`k37.firmware_model.motion.curves`."""

from __future__ import annotations

from k37.firmware_model.gcode.block_words import BlockError, BlockWords, g_name
from k37.firmware_model.gcode.lex import Word

__all__ = ["CurveMotions"]


class CurveMotions:
    """The parabola and exponential words of the interpreter."""

    def parabola(self, b: BlockWords, anchor: Word) -> None:
        """G06: the tangent point relative to the start, as an arc's centre (absolute under
        G90.1)."""
        if self.plane != 17:
            raise BlockError(anchor.col, f"G06 in G{self.plane}: parabolas are in the XY "
                                          f"plane (G17)")
        if b.word("I") is None and b.word("J") is None:
            raise BlockError(anchor.col, "G06 needs I and/or J (the tangent point)")
        target = self.target(b)
        start = self.pos
        tangent = []
        for axis in (0, 1):  # the point as an arc's centre is, from the machine's position
            w = b.word("IJ"[axis])
            if self.arc_absolute:
                point = self.offset(axis) + (self.lsb(w.value) if w else 0)
            else:
                point = start[axis] + (self.lsb(w.value) if w else 0)
            if w is not None:
                self.check_range(w, point - start[axis], "the tangent point")
            tangent.append(point - self.planner.position[axis])
        self.plan(anchor.col, self.planner.parabola, target, (tangent[0], tangent[1]),
                  self.feed, feed_source=self.feed_source)

    def exponential(self, b: BlockWords, anchor: Word) -> None:
        """G06.1 (exponential of X) and G06.2 (logarithm: exponential of Y): K the curve's
        constant, a length along the abscissa (negative: the curve flattens)."""
        name = g_name(self.motion)
        if self.plane != 17:
            raise BlockError(anchor.col, f"{name} in G{self.plane}: exponentials are in the "
                                          f"XY plane (G17)")
        k = b.word("K")
        if k is None:
            raise BlockError(anchor.col, f"{name} needs K (the curve's constant)")
        constant = self.lsb(k.value)
        self.check_range(k, constant, "the curve's constant")
        self.plan(anchor.col, self.planner.exponential, self.target(b), constant,
                  self.motion == 62, self.feed, feed_source=self.feed_source)
