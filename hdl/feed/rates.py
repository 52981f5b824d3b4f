"""The feed chain's numbers that its gateware, reference models and register maps share: the
phase divider's frequency arithmetic (:func:`increment_for`, :func:`frequency_of`, the paper's
addition clock :data:`FA_INCREMENT`), the width of one rate multiplier stage and of the decel
control's FP budget.
"""

from __future__ import annotations

from k37.hdl.common.constants import CHIP_HZ
from k37.hdl.common.params import Limit, positive_int

__all__ = ["BUDGET_WIDTH", "FA_INCREMENT", "STAGE_BITS", "frequency_of", "increment_for",
           "rate_limit"]

#: Width of the decel control's budget and remaining-count registers.
BUDGET_WIDTH = 24

#: Counter and rate-input width of one 7497.
STAGE_BITS = 6


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
