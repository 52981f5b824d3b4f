"""K3701 linear interpolation datapaths: DDA stepping on the long axis, for the two-axis chip
and the three-axis one.

The reference model is :class:`k37.hdl.k3701.datapaths.model.linear.LinearPath`.
"""

from __future__ import annotations

from amaranth.hdl import Module, Mux, Signal

from k37.hdl.common.constants import ALL_AXES
from k37.hdl.k3701.datapaths.base import Datapath, magnitude, refused

__all__ = ["LinearDatapath", "LinearDatapath3"]


class LinearDatapath(Datapath):
    """Linear interpolation: the long axis (the larger |component|, ties to X) moves every
    step, the short one too when the accumulator, started at half the long count, reaches
    the long count.

    Timing (the ports are those of :class:`k37.hdl.k3701.datapaths.base.DatapathSignature`; S is the
    start cycle): no setup and no stages. ``end`` (with ``error`` when Xe or Ye is -2^23)
    is high in S for a refused or zero-length line; the first step is in ``step`` from S+1;
    each ``advance`` decides the next step at its edge, so that it is in ``step`` from the
    following cycle. A line never ends with an error step.
    """

    def elaborate(self, platform) -> Module:
        # ``end`` and ``error`` each have an expression of their own, so that the compiled
        # simulation evaluates each only where the core reads it (see k37.hdl.k3701.chip.K3701).
        m = Module()
        block = self.block
        long_x = Signal()       # the long axis is X
        diag = Signal()         # the next step moves the short axis too
        final = Signal()        # the next step is the last
        n_long = Signal(24)
        n_short = Signal(24)
        acc = Signal(25)
        left = Signal(24)       # steps still to take
        x_neg = Signal()
        y_neg = Signal()

        m.d.comb += [
            self.end.eq(refused(block, "xe", "ye") | ((block.xe == 0) & (block.ye == 0))),
            self.error.eq(refused(block, "xe", "ye")),
            self.step.x.eq(long_x | diag), self.step.x_neg.eq(x_neg),
            self.step.y.eq(~long_x | diag), self.step.y_neg.eq(y_neg),
            self.step.diag.eq(diag), self.step.final.eq(final),
        ]

        with m.If(self.start):
            axe, aye = magnitude(block.xe).as_unsigned(), magnitude(block.ye).as_unsigned()
            x_long = axe >= aye
            nl = Mux(x_long, axe, aye)
            ns = Mux(x_long, aye, axe)
            m.d.sync += [
                long_x.eq(x_long), n_long.eq(nl), n_short.eq(ns), acc.eq(nl[1:]),
                diag.eq(nl[1:] + ns >= nl), final.eq(nl == 1), left.eq(nl),
                x_neg.eq(block.xe < 0), y_neg.eq(block.ye < 0),
            ]
        with m.If(self.advance):
            acc_next = Mux(diag, acc + n_short - n_long, acc + n_short)
            m.d.sync += [acc.eq(acc_next), left.eq(left - 1),
                         diag.eq(acc_next + n_short >= n_long), final.eq(left == 2)]
        return m


class LinearDatapath3(Datapath):
    """Three-axis linear interpolation (the K3701's long-axis stepping extended to X, Y, Z):
    every axis runs the same DDA over N steps, N the largest |component|. An axis of n moves
    moves when its accumulator, started at N / 2, reaches N (and then loses N): the long axis
    (n = N) moves every step, each other one where the true line crosses a half-LSB, and the
    block ends exactly at (xe, ye, ze). The same steps as :class:`LinearDatapath` for ze = 0.

    Timing as :class:`LinearDatapath` (``error`` when Xe, Ye or Ze is -2^23). ``diag`` is
    high for a step moving two or more axes, ``diag3`` for all three.
    """

    def __init__(self) -> None:
        super().__init__(axes=3)

    def elaborate(self, platform) -> Module:
        m = Module()
        block = self.block
        names = ("xe", "ye", "ze")
        n_long = Signal(24)
        final = Signal()
        left = Signal(24)
        m.d.comb += [
            self.end.eq(refused(block, *names)
                        | ((block.xe == 0) & (block.ye == 0) & (block.ze == 0))),
            self.error.eq(refused(block, *names)),
            self.step.final.eq(final),
        ]
        mags = [magnitude(getattr(block, name)).as_unsigned() for name in names]
        nl = Mux((mags[0] >= mags[1]) & (mags[0] >= mags[2]), mags[0],
                 Mux(mags[1] >= mags[2], mags[1], mags[2]))
        moving = []
        for axis, name, mag in zip(ALL_AXES, names, mags, strict=True):
            n = Signal(24, name=f"n_{axis}")
            acc = Signal(25, name=f"acc_{axis}")
            move = getattr(self.step, axis)
            neg = getattr(self.step, f"{axis}_neg")
            move_reg = Signal(name=f"move_{axis}")
            neg_reg = Signal(name=f"neg_{axis}")
            m.d.comb += [move.eq(move_reg), neg.eq(neg_reg)]
            moving.append(move_reg)
            with m.If(self.start):
                m.d.sync += [n.eq(mag), acc.eq(nl[1:]), move_reg.eq(nl[1:] + mag >= nl),
                             neg_reg.eq(getattr(block, name) < 0)]
            with m.If(self.advance):
                acc_next = Mux(move_reg, acc + n - n_long, acc + n)
                m.d.sync += [acc.eq(acc_next), move_reg.eq(acc_next + n >= n_long)]
        x, y, z = moving
        m.d.comb += [self.step.diag.eq((x & y) | (x & z) | (y & z)),
                     self.step.diag3.eq(x & y & z)]
        with m.If(self.start):
            m.d.sync += [n_long.eq(nl), final.eq(nl == 1), left.eq(nl)]
        with m.If(self.advance):
            m.d.sync += [left.eq(left - 1), final.eq(left == 2)]
        return m
