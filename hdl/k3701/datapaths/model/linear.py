"""Reference model of :mod:`k37.hdl.k3701.datapaths.linear`: a line by DDA long-axis stepping, on
two or three axes (:class:`LinearPath`), and the DDA of one short axis (:class:`Dda`)."""

from __future__ import annotations

from k37.hdl.k3701.block import Step, check_coord

__all__ = ["Dda", "LinearPath"]

class Dda:
    """One short axis of a DDA: ``n`` moves spread over ``total`` steps. It moves when its
    accumulator, started at half the total, reaches the total: the moves fall where the true
    line crosses a half-LSB, and exactly ``n`` of them come in ``total`` steps."""

    def __init__(self, n: int, total: int):
        self.n, self.total, self.acc = n, total, total // 2

    def peek(self) -> bool:
        return self.acc + self.n >= self.total

    def advance(self) -> bool:
        move = self.peek()
        self.acc += self.n - (self.total if move else 0)
        return move


class LinearPath:
    """Bresenham/DDA on the long axis (the largest |component|, ties to X, then Y).

    Each short axis moves when its accumulator, started at half the long count, reaches the
    long count: the short moves fall where the true line crosses a half-LSB, and the block
    ends exactly at (xe, ye, ze). A two-axis block has ze = 0.
    """

    def __init__(self, xe: int, ye: int, ze: int = 0):
        check_coord("Xe", xe)
        check_coord("Ye", ye)
        check_coord("Ze", ze)
        ends = (xe, ye, ze)
        mags = [abs(e) for e in ends]
        self.long = mags.index(max(mags))
        self.long_is_x = self.long == 0
        self.n_long = mags[self.long]
        self.signs = [(e > 0) - (e < 0) for e in ends]
        self.shorts = {k: Dda(mags[k], self.n_long) for k in range(3) if k != self.long}
        self.left = self.n_long

    @property
    def n_short(self) -> int:
        """The moves of the longer short axis (a two-axis line's short count)."""
        return max(d.n for d in self.shorts.values())

    @property
    def done(self) -> bool:
        return self.left == 0

    def _step(self, moves: dict[int, bool]) -> Step:
        return Step(*(self.signs[k] if k == self.long or moves[k] else 0 for k in range(3)))

    def peek(self) -> Step:
        """The next step (the path must not be done)."""
        return self._step({k: d.peek() for k, d in self.shorts.items()})

    def advance(self) -> tuple[Step, bool, bool]:
        """Take the next step; returns (step, final, error)."""
        step = self._step({k: d.advance() for k, d in self.shorts.items()})
        self.left -= 1
        return step, self.left == 0, False
