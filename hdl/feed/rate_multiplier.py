"""Cascaded SN7497-style binary rate multiplier: the feedrate generator (``docs/chips/feed.md``).

The reference model (and the 7497's decoding table) is :mod:`k37.hdl.feed.model.rate_multiplier`.
"""

from __future__ import annotations

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from k37.hdl.common.observation import Observed
from k37.hdl.common.params import positive_int
from k37.hdl.feed.model.rate_multiplier import selected_bit
from k37.hdl.feed.rates import STAGE_BITS

__all__ = ["RateMultiplier"]


class RateMultiplier(Observed, wiring.Component):
    """``stages`` cascaded 6-bit binary rate multipliers: ``W`` pulses per ``64**stages`` clocks.

    Each stage behaves like an SN7497: a 6-bit counter advanced by its enable, and six
    decoding gates that pass the input clock in disjoint counter states (rate bit 5 in 32 of
    the 64 states, bit 4 in 16, ..., bit 0 in one, state 63 in none). Stage 0 runs on every
    input clock and takes the most significant six bits of ``word``; stage *s* + 1 is enabled
    once per 64 of stage *s*'s clocks, in the input clock in which stage *s* sits in its
    silent state 63, as the datasheet's cascade wires enable-out to the next enable-in and
    strobe. The stages' outputs are therefore disjoint and ORed, and over any
    ``64**stages`` consecutive input clocks there are exactly ``word`` pulses. Equivalently
    the stages' counters are the base-64 digits of one ``6 * stages``-bit counter.

    Parameters
    ----------
    stages : int
        Number of 7497 stages (default 3: an 18-bit feed word; 2 gives 12 bits).

    Members
    -------
    word : In(6 * stages)
        Feed word ``W``; sampled in every input clock (the 7497's rate inputs are live).
    clk_en : In(1)
        Input clock: each cycle it is high is one input clock pulse (e.g. a
        :class:`k37.hdl.feed.divider.PhaseDivider` strobe).
    out : Out(1)
        Output pulse, combinational: high in the same cycle as the ``clk_en`` it gates, when
        the counter state reached by that input clock selects it. Input clock *k* after reset
        (*k* = 1, 2, ...) pulses iff the base-64 digits of ``k mod 64**stages`` select it.
    enable_out : Out(1)
        High in the input clock in which every stage sits in state 63 (the last stage's
        enable output): once per ``64**stages`` input clocks, in a clock with no ``out``.
    count : Out(6 * stages)
        Probe: the cascade's counter (stage *s* in bits ``6s .. 6s+5``), i.e. the number of
        input clocks since reset modulo ``64**stages``.
    """

    @property
    def probes(self) -> tuple[str, ...]:
        """Observation outputs, not pins of the chip (the Verilog export keeps them inside)."""
        return ("count",)

    def __init__(self, stages: int = 3):
        self.stages = positive_int("stages", stages)
        bits = STAGE_BITS * stages
        super().__init__({"word": In(bits), "clk_en": In(1), "out": Out(1),
                          "enable_out": Out(1), "count": Out(bits)})

    def elaborate(self, platform) -> Module:
        m = Module()
        bits = STAGE_BITS * self.stages
        # The gates pass the clock in state k iff the word bit they select is set
        # (:func:`k37.hdl.feed.model.rate_multiplier.selected_bit`): bit (bits - 1 - t) where t is
        # the number of trailing ones of k (stage s = t // 6 is the first one not in state 63, and
        # its gate for rate bit 5 - t % 6 is open); no bit when k is all ones. ``select`` holds that
        # bit index for the state the next input clock reaches (the sentinel ``bits`` for none),
        # updated only when the counter moves, so each cycle costs one shift.
        select = Signal(range(bits + 1), init=selected_bit(1, self.stages))
        with m.If(self.clk_en):
            m.d.sync += [self.count.eq(self.count + 1),
                         select.eq(_select_expr(self.count + 2, bits))]
        m.d.comb += [self.out.eq(self.clk_en & (self.word >> select)[0]),
                     self.enable_out.eq(self.clk_en & (select == bits))]
        return m


def _select_expr(state, bits: int):
    """:func:`k37.hdl.feed.model.rate_multiplier.selected_bit` of the Amaranth value ``state``
    (taken modulo ``2**bits``), as a chain of multiplexers on its trailing ones."""
    result = bits
    for t in reversed(range(bits)):
        result = Mux(state[t], result, bits - 1 - t)
    return result
