"""First-order sigma-delta D/A: a 16-bit D/A word as a one-bit stream on one pin.

The reference model is :class:`k37.hdl.board.model.sigma_delta.SigmaDeltaModel`.
"""

from __future__ import annotations

from amaranth.hdl import Module, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from k37.hdl.common.params import positive_int

__all__ = ["SigmaDelta"]


class SigmaDelta(wiring.Component):
    """A one-bit D/A whose mean output is ``word / 2**width`` of the I/O supply.

    A ``width``-bit accumulator adds ``word`` at every clock edge; the carry out of that
    addition is registered as ``out``. Over cycles 1..T ``out`` is high exactly
    ``floor(sum(word) / 2**width)`` times. An RC low pass on the pin turns the stream into the
    analogue voltage (``docs/guide/fpga.md`` gives the filter).

    Parameters
    ----------
    width : int
        Word width in bits (default 16: the K3702's D/A word).

    Members
    -------
    word : In(width)
        Offset-binary D/A word, sampled at every clock edge.
    out : Out(1)
        The bit stream: high in cycle *t* + 1 when the addition at the edge ending cycle *t*
        carried out (registered: it drives a pin without a combinational path).
    """

    def __init__(self, width: int = 16):
        self.width = positive_int("width", width)
        super().__init__({"word": In(width), "out": Out(1)})

    def elaborate(self, platform) -> Module:
        m = Module()
        acc = Signal(self.width)
        total = acc + self.word
        m.d.sync += [acc.eq(total[:self.width]), self.out.eq(total[self.width])]
        return m
