"""The paper's numbers, each with where in the paper it comes from.

The paper is "System design for simultaneous 2-axis control using custom LSI";
the experiments compare the emulator with these figures, never with numbers written into a
report row.
"""

from __future__ import annotations

import math

__all__ = ["FEED_HIGH", "FEED_LOW", "PAPER_RATE_CIRCULAR", "PAPER_RATE_LINEAR", "PAPER_TAU_S",
           "table1"]

#: The feed words of the paper's path-error photos 3 and 4 (0xF0FF and 0x00FF; see
#: ``docs/chips/feed.md``).
FEED_HIGH, FEED_LOW = 61695, 255
#: The paper's accel/decel time constant, 2^15 / 109.227 kHz, read off Photo 1
#: (``docs/chips/accel.md``).
PAPER_TAU_S = 0.300
#: The paper's maximum feed (step) rates at CP = 1 MHz (section 2 (1)).
PAPER_RATE_LINEAR, PAPER_RATE_CIRCULAR = 90.0e3, 47.6e3


def table1(r: float, theta: float, sqrt2: bool) -> float:
    """The corrected Table 1 (``docs/chips/k3701.md``): FP for an arc from the x axis through
    ``theta``.

    The paper's Table 1 prints garbled formulas; the K3701's datasheet gives these corrected ones.
    """
    deg = math.degrees(theta)
    s2 = math.sqrt(2)
    if math.isclose(deg, 45):
        return r * (0.5 + s2 / 4) if sqrt2 else r * s2 / 2
    if math.isclose(deg, 90):
        return r * (1 + s2 / 2) if sqrt2 else r * s2
    if deg < 45:
        return r * (math.sin(theta) + (1 - math.cos(theta)) / 2) if sqrt2 else r * math.sin(theta)
    if sqrt2:
        return r * (0.5 + s2 / 2 + math.sin(theta) / 2 - math.cos(theta))
    return r * (s2 - math.cos(theta))
