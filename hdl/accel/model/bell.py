"""Reference model of :class:`k37.hdl.accel.bell.AccelBell`: bell-shaped accel/decel, the linear
circuit followed by the exponential one (the filters paper's eq. (40)), both on the same addition
clock.

A step of the input rate comes out as an S-shaped rise: the moving average's ramp over T,
smoothed by the exponential's lag tau (both ``2**n / fa``), so the acceleration itself rises
and falls without a jump. Each stage conserves pulses, so the cascade does:
``inputs = outputs + (pulses held in the linear stage) + x + pending`` of the exponential.
"""

from __future__ import annotations

from k37.hdl.accel.model.exponential import AccelDecelModel
from k37.hdl.accel.model.linear import AccelLinearModel

__all__ = ["AccelBellModel"]


class AccelBellModel:
    """Cycle model: the two stages' models, the linear one's output into the exponential."""

    def __init__(self, n: int = 15, counter_width: int = 24, bidirectional: bool = False,
                 bins_bits: int = 4):
        self.linear = AccelLinearModel(n, counter_width, bidirectional, bins_bits)
        self.exponential = AccelDecelModel(n, counter_width, bidirectional)

    @property
    def idle(self) -> bool:
        """Both stages drained."""
        return self.linear.idle and self.exponential.idle

    def step(self, inp: int, add: bool) -> int:
        """One cycle with input pulse ``inp`` and addition clock ``add``; returns the output."""
        return self.exponential.step(self.linear.step(inp, add), add)
