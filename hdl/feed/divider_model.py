"""Reference model of :class:`k37.hdl.feed.divider.PhaseDivider`, and its frequency arithmetic.

A phase accumulator of ``width`` bits adds ``increment`` every cycle; each carry out is one
strobe, one cycle later. Over cycles 1..T there are exactly ``floor(T * increment / 2**width)``
strobes, so the mean rate is ``f_clk * increment / 2**width`` with no long-term error.
"""

from __future__ import annotations

import numpy as np

from k37.hdl.common.constants import CHIP_HZ
from k37.hdl.common.params import Limit, positive_int

__all__ = ["FA_INCREMENT", "PhaseDividerModel", "frequency_of", "increment_for", "rate_limit"]


def rate_limit(*, width: int = 24, f_clk: float = CHIP_HZ) -> Limit:
    """The strobe rates (Hz) a running divider makes: from increment 1, ``f_clk / 2**width``,
    up to (not including) ``f_clk``."""
    positive_int("width", width)
    return Limit(f_clk / (1 << width), f_clk, high_open=True, unit="Hz",
                 note=f"{width}-bit divider at clock_hz")


def increment_for(freq: float, *, width: int = 24, f_clk: float = CHIP_HZ) -> int:
    """The increment whose strobe rate is nearest to ``freq`` (Hz) at ``f_clk``: 0 stops the
    strobe, any other rate must be in :func:`rate_limit` (so that it never rounds to 0)."""
    limit = rate_limit(width=width, f_clk=f_clk)
    if freq != 0:
        limit.check("frequency", freq)
    return min(round(freq / f_clk * (1 << width)), (1 << width) - 1)


def frequency_of(increment: int, *, width: int = 24, f_clk: float = CHIP_HZ) -> float:
    """The mean strobe rate (Hz) that ``increment`` gives at ``f_clk``."""
    positive_int("width", width)
    return f_clk * increment / (1 << width)


#: The paper's addition clock: tau = 2**15 / fa = 300 ms, i.e. fa = 109226.67 Hz; with a 24-bit
#: divider at 1 MHz this is 1832519, fa = 109226.644 Hz and tau = 300.00006 ms.
FA_INCREMENT = increment_for(2**15 / 0.3)


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
