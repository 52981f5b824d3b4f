"""G05, G05.1 and G05.2/G05.3 as the interpreter reads them (a mixin of
:class:`k37.firmware_model.gcode.interpreter.Interpreter`); the curves themselves are
:mod:`k37.firmware_model.motion.splines`."""

from __future__ import annotations

from k37.firmware_model.gcode.block_words import BlockError, BlockWords
from k37.firmware_model.gcode.lex import Word
from k37.firmware_model.gcode.units import INCH_MM
from k37.firmware_model.motion.splines import Nurbs, bezier

__all__ = ["SplineMotions"]


class SplineMotions:
    """The spline words of the interpreter (its state: ``nurbs``, ``g05_pq``)."""

    def offset_lsb(self, w: Word | None) -> float:
        """A control point offset word in LSB, unrounded (0 if absent)."""
        if w is None:
            return 0.0
        return float((w.value * INCH_MM if self.inch else w.value) / self.lsb_size)

    def spline_start(self, anchor: Word, b: BlockWords) -> tuple[float, float]:
        """Where a spline starts (LSB), after checking its plane and that Z stays."""
        if self.plane != 17:
            raise BlockError(anchor.col, f"{anchor.text} is for the XY plane (G17)")
        z = b.word("Z")
        if z is not None and self.target(b)[2] != self.pos[2]:
            raise BlockError(z.col, f"{z.text}: a spline stays in the XY plane")
        return float(self.pos[0]), float(self.pos[1])

    def spline(self, b: BlockWords, anchor: Word) -> None:
        """G05 (cubic) and G05.1 (quadratic) from the position to the block's X/Y."""
        start = self.spline_start(anchor, b)
        target = self.target(b)
        end = self.exact_target()[:2]
        i, j = b.word("I"), b.word("J")
        if self.motion == 50:
            p, q = b.word("P"), b.word("Q")
            if p is None or q is None:
                raise BlockError(anchor.col, "G05 needs P and Q (the second control point, "
                                              "from the end)")
            if i is None and j is None:
                if self.g05_pq is None:
                    raise BlockError(anchor.col, "G05 needs I and J (the first control point, "
                                                  "from the start) unless it follows a G05")
                first = (start[0] - self.g05_pq[0], start[1] - self.g05_pq[1])
            else:
                first = (start[0] + self.offset_lsb(i), start[1] + self.offset_lsb(j))
            pq = (self.offset_lsb(p), self.offset_lsb(q))
            curve = bezier(start, first, (end[0] + pq[0], end[1] + pq[1]), end)
        else:
            if i is None and j is None:
                raise BlockError(anchor.col, "G05.1 needs I and/or J (the control point, from "
                                              "the start)")
            control = (start[0] + self.offset_lsb(i), start[1] + self.offset_lsb(j))
            curve = Nurbs((start, control, end), (1.0, 1.0, 1.0), 3)
            pq = None
        self.plan(anchor.col, self.planner.spline, curve, target, self.feed,
                  tolerance=self.arc_tolerance(), feed_source=self.feed_source)
        self.g05_pq = pq

    def nurbs_block(self, b: BlockWords, g: tuple[int, Word] | None) -> None:
        """A line of a G05.2 ... G05.3 NURBS block: its opening, a control point, its end."""
        code = None if g is None else g[0]
        if self.nurbs is None:
            if code == 53:
                raise BlockError(g[1].col, "G05.3 without a G05.2 NURBS before it")
            anchor = g[1]
            start = self.spline_start(anchor, b)
            if self.feed is None:
                raise BlockError(anchor.col, "G05.2 without a feed rate: program F first")
            order_word = b.word("L")
            order = 3 if order_word is None else int(order_word.value)
            if order_word is not None and (order != order_word.value or order < 2):
                raise BlockError(order_word.col, f"{order_word.text}: the order must be an "
                                                  f"integer of at least 2")
            weight = self.weight(b)
            has_point = b.word("X") is not None or b.word("Y") is not None
            self.nurbs = ([start], [1.0 if has_point else weight], order, anchor, self.line_no)
            if has_point:
                self.nurbs_point(b, weight)
            self.motion = None
            return
        if code == 53:
            self.nurbs_end(g[1])
        elif code is not None:
            raise BlockError(g[1].col, f"{g[1].text} inside a G05.2 NURBS block: it ends with "
                                        f"G05.3")
        else:
            self.nurbs_point(b, self.weight(b))

    def weight(self, b: BlockWords) -> float:
        p = b.word("P")
        if p is not None and p.value <= 0:
            raise BlockError(p.col, f"{p.text}: a weight must be positive")
        return 1.0 if p is None else float(p.value)

    def nurbs_point(self, b: BlockWords, weight: float) -> None:
        assert self.nurbs is not None
        self.spline_start(self.nurbs[3], b)
        target = self.target(b)
        self.nurbs[0].append(self.exact_target()[:2])
        self.nurbs[1].append(weight)
        self.planner.programmed = (target[0], target[1], self.pos[2])

    def nurbs_end(self, anchor: Word) -> None:
        assert self.nurbs is not None
        points, weights, order, _, opening_line = self.nurbs
        self.nurbs = None
        self.planner.programmed = self.planner.position
        if len(points) < order:
            raise BlockError(anchor.col, f"the G05.2 NURBS of order {order} needs at least "
                                          f"{order} control points, the start included, not "
                                          f"{len(points)}")
        end = points[-1]
        target = (round(end[0]), round(end[1]), self.pos[2])
        self.line_no, line = opening_line, self.line_no
        try:
            self.plan(anchor.col, self.planner.spline, Nurbs(tuple(points), tuple(weights), order),
                      target, self.feed, tolerance=self.arc_tolerance(),
                      feed_source=self.feed_source)
        finally:
            self.line_no = line
