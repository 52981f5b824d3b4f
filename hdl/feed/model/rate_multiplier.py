"""Reference model of :class:`k37.hdl.feed.rate_multiplier.RateMultiplier` (``docs/chips/feed.md``).

One SN7497 holds a 6-bit counter that advances on each input clock; its six decoding gates
pass the clock for disjoint counter states (the datasheet's logic, QA = counter bit 0):

====== ======== ================================ ==================
rate   weight   counter states gated              pulses per 64
====== ======== ================================ ==================
F      32       QA = 0                            32
E      16       QA = 1, QB = 0                    16
D      8        QA = QB = 1, QC = 0               8
C      4        QA..QC = 1, QD = 0                4
B      2        QA..QD = 1, QE = 0                2
A      1        QA..QE = 1, QF = 0 (state 31)     1
====== ======== ================================ ==================

State 63 gates nothing; it is the state in which the enable output is active. In the
datasheet's cascade the next package counts once per 64 clocks (its enable input is the
previous package's enable output) and its gates pass only while the previous one sits in
state 63, when that one is silent; so the stages' counters are the base-64 digits of one
counter, and the outputs are disjoint and simply ORed. The first package (the free-running
one) carries the most significant six bits of the feed word.

The counter advances at the input clock's edge and the output pulse of that clock is gated by
the new state (the 7497 gates the low half of the clock that advanced it). After reset the
counter is 0, so input clock number k (1, 2, ...) gives a pulse if the base-64 digits of k
select one.

This decoding (:func:`gate`, :func:`selected_bit`) is the rule every other form follows: the
gateware's and the compiled backend's closed forms (a state with t trailing ones selects word
bit ``6 * stages - 1 - t``) are tested against it.
"""

from __future__ import annotations

from k37.hdl.common.params import positive_int
from k37.hdl.feed.rates import STAGE_BITS

__all__ = ["RateMultiplierModel", "gate", "selected_bit", "stage_gate"]



def stage_gate(state, rate):
    """Whether one 7497 with rate inputs ``rate`` (6 bits) passes the clock in ``state``.

    Works on ints or on NumPy integer arrays (elementwise).
    """
    hit = 0
    for bit in range(STAGE_BITS):
        ones = STAGE_BITS - 1 - bit  # rate bit b needs the low 5-b bits set, the next clear
        hit = hit | (((state & ((2 << ones) - 1)) == (1 << ones) - 1) & ((rate >> bit) & 1 == 1))
    return hit


def gate(count, word, stages: int):
    """Whether a ``stages``-deep cascade with feed ``word`` outputs in counter state ``count``."""
    hit = 0
    upstream_at_63 = 1
    top = (1 << STAGE_BITS) - 1
    for s in range(stages):
        digit = (count >> (STAGE_BITS * s)) & top
        rate = (word >> (STAGE_BITS * (stages - 1 - s))) & top
        hit = hit | (upstream_at_63 & stage_gate(digit, rate))
        upstream_at_63 = upstream_at_63 & (digit == top)
    return hit


def selected_bit(count: int, stages: int) -> int:
    """The word bit whose gate passes the clock in counter state ``count`` (the gates are
    disjoint: one at most), or ``STAGE_BITS * stages`` for none (the all-ones state)."""
    bits = STAGE_BITS * stages
    return next((bit for bit in range(bits) if gate(count, 1 << bit, stages)), bits)


class RateMultiplierModel:
    """Cycle model: :meth:`step` gives ``(out, enable_out)`` of the current cycle, then clocks."""

    def __init__(self, stages: int = 3):
        self.stages = positive_int("stages", stages)
        self.bits = STAGE_BITS * stages
        self.count = 0

    def step(self, word: int, clk_en: bool) -> tuple[bool, bool]:
        """One cycle; ``word`` is the feed word, ``clk_en`` the input clock."""
        if not 0 <= word < (1 << self.bits):
            raise ValueError(f"word must be in 0..2**{self.bits}-1, not {word!r}")
        if not clk_en:
            return False, False
        self.count = (self.count + 1) & ((1 << self.bits) - 1)
        return bool(gate(self.count, word, self.stages)), self.count == (1 << self.bits) - 1
