"""The three-axis K3701's helix axis: a DDA on an arc's steps that moves the plane's normal.

The reference model is :class:`k37.hdl.k3701.datapaths.model.helix.HelixPath`.
"""

from amaranth.hdl import Module, Mux, Signal, signed
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from k37.hdl.k3701.block import COORD_INVALID
from k37.hdl.k3701.datapaths.base import magnitude

__all__ = ["HelixAxis"]


class HelixAxis(wiring.Component):
    """|Ze| moves of the third axis spread over the N steps of an arc: the axis moves with an
    arc step when its accumulator, started at N / 2, reaches N (and then loses N), so exactly
    |Ze| moves come with the N steps and the helix ends with the arc. Needs |Ze| <= N.

    Members
    -------
    start : In(1)
        High in the start cycle S of a circular block: ``ze`` and ``n`` are latched.
    ze : In(signed(24))
        The third axis's travel (the Z register); 0: a plain arc, the axis never moves.
    n : In(24)
        The arc's step count N (the H register).
    advance : In(1)
        High in the cycle the core takes an arc step (see
        :class:`k37.hdl.k3701.datapaths.base.DatapathSignature`); ``move`` holds the next step's
        move from the following cycle.
    move, neg : Out(1)
        The third axis moves with the next arc step, in the negative direction; from S+1.
    error : Out(1)
        |Ze| > N or Ze = -2^23: the chip refuses the block; from S+1, read at the end of the
        radius check.
    """

    start: In(1)
    ze: In(signed(24))
    n: In(24)
    advance: In(1)
    move: Out(1)
    neg: Out(1)
    error: Out(1)

    def elaborate(self, platform) -> Module:
        m = Module()
        nz = Signal(24)
        total = Signal(24)
        acc = Signal(25)
        mag = magnitude(self.ze).as_unsigned()
        with m.If(self.start):
            half = self.n[1:]
            m.d.sync += [
                nz.eq(mag), total.eq(self.n), acc.eq(half), self.neg.eq(self.ze < 0),
                self.move.eq((mag != 0) & (half + mag >= self.n)),
                self.error.eq((mag > self.n) | (self.ze == COORD_INVALID)),
            ]
        with m.If(self.advance):
            acc_next = Mux(self.move, acc + nz - total, acc + nz)
            m.d.sync += [acc.eq(acc_next), self.move.eq((nz != 0) & (acc_next + nz >= total))]
        return m
