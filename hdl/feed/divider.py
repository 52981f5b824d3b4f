"""Phase-accumulator clock-enable divider (``docs/chips/feed.md``).

The reference model is :class:`k37.hdl.feed.model.divider.PhaseDividerModel`.
"""

from __future__ import annotations

from amaranth.hdl import Module, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from k37.hdl.common.params import positive_int

__all__ = ["PhaseDivider"]


class PhaseDivider(wiring.Component):
    """A fractional clock enable: ``f = f_clk * increment / 2**width`` on average.

    A ``width``-bit phase accumulator adds ``increment`` at every clock edge; the carry out of
    that addition is registered as ``stb``. Over cycles 1..T exactly
    ``floor(T * increment / 2**width)`` strobes occur (accumulator cleared at reset), so the
    rate has no long-term error and its jitter is under one cycle. It drives the accel/decel
    addition clock fa (``k37.hdl.feed.rates.FA_INCREMENT`` gives the paper's 109.227 kHz
    from 1 MHz) and the rate multiplier's input clock.

    Parameters
    ----------
    width : int
        Accumulator width in bits (default 24: 0.06 Hz steps at 1 MHz).

    Members
    -------
    increment : In(width)
        Phase step per cycle, host-programmable; sampled at every clock edge. 0 stops the
        strobe; the fastest rate is ``(2**width - 1) / 2**width`` of the clock.
    stb : Out(1)
        One-cycle clock enable, high in cycle *t* + 1 when the addition at the edge ending
        cycle *t* carried out (registered: no combinational path from ``increment``).
    """

    def __init__(self, width: int = 24):
        self.width = positive_int("width", width)
        super().__init__({"increment": In(width), "stb": Out(1)})

    def elaborate(self, platform) -> Module:
        m = Module()
        phase = Signal(self.width)
        m.d.sync += [phase.eq(phase + self.increment),
                     self.stb.eq((phase + self.increment)[self.width])]
        return m
