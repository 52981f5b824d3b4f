"""Reference model of :class:`k37.hdl.feed.divider.PhaseDivider` (its frequency arithmetic is
:mod:`k37.hdl.feed.rates`).

A phase accumulator of ``width`` bits adds ``increment`` every cycle; each carry out is one
strobe, one cycle later. Over cycles 1..T there are exactly ``floor(T * increment / 2**width)``
strobes, so the mean rate is ``f_clk * increment / 2**width`` with no long-term error.
"""

from __future__ import annotations

import numpy as np

from k37.hdl.common.params import positive_int

__all__ = ["PhaseDividerModel"]


class PhaseDividerModel:
    """Cycle model: :meth:`step` returns the strobe of the current cycle, then clocks."""

    def __init__(self, width: int = 24):
        self.width = positive_int("width", width)
        self.phase = 0
        self.stb = False

    def _check_increment(self, increment: int) -> None:
        if not 0 <= increment < (1 << self.width):
            raise ValueError(f"increment must be in 0..2**{self.width}-1, not {increment!r}")

    def step(self, increment: int) -> bool:
        """One cycle with ``increment`` on the port; returns ``stb`` of this cycle."""
        self._check_increment(increment)
        stb = self.stb
        total = self.phase + increment
        self.phase = total & ((1 << self.width) - 1)
        self.stb = bool(total >> self.width)
        return stb

    def run(self, increment: int, cycles: int) -> np.ndarray:
        """``cycles`` calls of :meth:`step` with a constant increment, as a bool array."""
        self._check_increment(increment)
        if self.width + cycles.bit_length() > 62:
            raise ValueError(f"run() needs width + log2(cycles) <= 62, not {cycles!r} cycles")
        # carries[k]: carries out of the first k additions; the strobe lags its carry a cycle.
        carries = (self.phase + np.arange(cycles + 1, dtype=np.int64) * increment) >> self.width
        stb = np.diff(carries) > 0
        out = np.concatenate(([self.stb], stb[:-1])) if cycles else stb
        if cycles:
            self.stb = bool(stb[-1])
        self.phase = (self.phase + cycles * increment) & ((1 << self.width) - 1)
        return out
