"""K3701 parabolic and exponential (logarithmic) interpolation datapath: the sign-of-F method
on F = A v - B p^2 - C p, and on the height of an exponential above the point.

The reference models are :class:`k37.hdl.k3701.datapaths.model.parabolic.ParabolicPath` and
:class:`k37.hdl.k3701.datapaths.model.parabolic.ExponentialPath`.
"""

from __future__ import annotations

from amaranth.hdl import Module, Mux, Signal, signed

from k37.hdl.k3701.block import (
    EXPONENTIAL_R2_BITS,
    EXPONENTIAL_SETUP_CYCLES,
    PARABOLA_SETUP_CYCLES,
)
from k37.hdl.k3701.datapaths.base import Datapath, frame_step, magnitude, refused, shorter

__all__ = ["ParabolicDatapath"]

#: Setup cycles of the serial multipliers (one per bit of pe).
_MULTIPLY = 24
#: F, G and the candidate F values, signed: |B| < 6 * 2^23, p <= 2^23, |C| < 5 * 2^46, so
#: |G| = |B (2p + 1) + C| < 2^51; F after a step is within max(A, |G|) and a candidate within
#: |F| + |G| + A < 2^52.
_F_BITS = 53
#: An exponential's F, signed: |F| < 2 (|k| + |Q|) < 2^26; the bits above sign-extend.
_F_EXP_BITS = 28


class ParabolicDatapath(Datapath):
    """Parabolic and exponential interpolation in the curve's own frame (abscissa p, X or Y
    with ``swap``; ordinate v).

    Parabolic: F = A v - B p^2 - C p with A = pe^2, B = 2 ve - 4 vp, C = pe (4 vp - ve)
    (pe = |end's p|, ve the end's v, vp the tangent point's v). A p step adds -G to F and 2B
    to G; a v step adds +-A. The long axis is p where |G| <= A, else v; v moves in the sign
    of G; the short axis moves too if that makes |F| smaller; the block ends on the end
    point, or with an error if p passes pe.

    Exponential (``block.exponential``): the same registers and adders run the model's
    self-fed DDA with A = 2|k| (|k| = I, k < 0 with ``cw``), G = 2Q (Q from J), B = sign(k)
    and F = -2 F_model: a p step adds -G, a v step +A and moves G by 2B; v moves in the sign
    of ve. r2 (from 0) takes F / 2 + E on each p step; after each step two carries, one per
    stage, move |k| between r2 and F (2 sign(k)) while r2 is outside 0..|k|-1. The block
    also ends with an error if v passes ve.

    Timing (the ports are those of :class:`k37.hdl.k3701.datapaths.base.DatapathSignature`; S is the
    start cycle, C the cycle a step's credit completes, L the latency):

    * setup, S+1 to S+29: two serial multipliers form A = pe * pe and C = pe * (4 vp - ve)
      in S+1 to S+24 (one bit of pe per cycle, the most significant first), G = B + C in
      S+25, then the first step is decided in S+26 to S+28 as the stages decide the others.
      In S+29 ``end`` (with ``error``) is high for refused data (a coordinate of -2^23, or
      pe = 0), else ``ready``; the first step is in ``step`` from S+30. An exponential skips
      the multipliers: S+1 to S+4 (its first step decided in S+1 to S+3, ``ready`` or
      ``end`` in S+4: refused also for I < 2 or J < 0);
    * four stages, C+1 to C+4: the position (and G, on a p step; on a v step for an
      exponential) moves by the current step, an exponential's first carry; whether the
      current step ends the block (``final``, ``error``), and the next step's long axis and v
      direction, the second carry; the two candidate F values; the choice, which ``advance``
      (in C+L-1, L >= 6) puts in ``step`` from C+L.
    """

    SETUP = True
    STAGES = 4

    def elaborate(self, platform) -> Module:
        m = Module()
        block = self.block
        exp = Signal()              # the block is an exponential
        swap = Signal()
        su_neg = Signal()           # p runs towards negative X (Y with swap)
        pe = Signal(24)
        ve = Signal(signed(24))
        b = Signal(signed(27))
        m2 = Signal(signed(27))     # the multiplicand of C: 4 vp - ve; an exponential's addend
        a = Signal(46)
        g = Signal(signed(_F_BITS))  # C while it is multiplied, then G
        bad = Signal()
        k = Signal(range(PARABOLA_SETUP_CYCLES))
        p = Signal(25)
        v = Signal(signed(27))
        # An exponential's own: k < 0, E, r2, and whether v was at ve.
        decays = Signal()
        e = Signal(signed(24))
        r2 = Signal(signed(EXPONENTIAL_R2_BITS))
        at_ve = Signal()
        # The current step: long axis p, diagonal, v direction, whether it ends the block
        # (and with an error), and F after it.
        long_p = Signal()
        diag = Signal()
        sv_neg = Signal()
        final = Signal()
        final_error = Signal()
        f_after = Signal(signed(_F_BITS))
        # The next step, decided in the stages.
        next_long_p = Signal()
        next_diag = Signal()
        next_sv_neg = Signal()      # v's direction: F's change on a v step is then -A
        d1 = Signal(signed(_F_BITS))  # F after the next step: first if on the long axis only
        d2 = Signal(signed(_F_BITS))  # F after the next step if diagonal

        last = self.setup & (k == PARABOLA_SETUP_CYCLES - 1)
        p_moves = long_p | diag
        v_moves = ~long_p | diag
        m.d.comb += [
            self.ready.eq(last & ~bad),
            self.end.eq(last & bad),
            self.error.eq(1),
            *frame_step(self.step, swap=swap, su_neg=su_neg, sv_neg=sv_neg, long_p=long_p,
                        diag=diag, final=final, error=final_error),
        ]

        with m.If(self.start):
            pe_s = Mux(block.swap, block.ye, block.xe)
            ve_s = Mux(block.swap, block.xe, block.ye)
            vp_s = Mux(block.swap, block.i, block.j)
            m.d.sync += [
                exp.eq(block.exponential), swap.eq(block.swap), su_neg.eq(pe_s < 0),
                pe.eq(magnitude(pe_s)), ve.eq(ve_s), m2.eq((vp_s << 2) - ve_s),
                decays.eq(block.cw), e.eq(block.e),
                k.eq(Mux(block.exponential, PARABOLA_SETUP_CYCLES - EXPONENTIAL_SETUP_CYCLES, 0)),
                p.eq(0), v.eq(0), f_after.eq(0), r2.eq(0), at_ve.eq(ve_s == 0),
                bad.eq(refused(block, "xe", "ye", "i", "j") | (pe_s == 0)
                       | (block.exponential & ((block.i < 2) | (block.j < 0)))),
            ]
            with m.If(block.exponential):
                m.d.sync += [b.eq(Mux(block.cw, -1, 1)), a.eq(block.i << 1),
                             g.eq(block.j << 1)]
            with m.Else():
                m.d.sync += [b.eq((ve_s << 1) - (vp_s << 2)), a.eq(0), g.eq(0)]
        with m.Elif(self.setup):
            m.d.sync += k.eq(k + 1)
            with m.If(k < _MULTIPLY):
                bit = pe.bit_select((_MULTIPLY - 1 - k).as_unsigned(), 1)
                m.d.sync += [a.eq((a << 1) + Mux(bit, pe, 0)), g.eq((g << 1) + Mux(bit, m2, 0))]
            with m.Elif(k == _MULTIPLY):
                m.d.sync += g.eq(g + b)

        # The current step becomes the next one: at the setup's end (the block's first step)
        # and with each advance; an exponential's p move adds F / 2 + E to r2 (F before it).
        with m.If(last | self.advance):
            m.d.sync += [long_p.eq(next_long_p), diag.eq(next_diag),
                         sv_neg.eq(Mux(exp, ve < 0, next_sv_neg)), f_after.eq(d1)]
            with m.If(exp & (next_long_p | next_diag)):
                m.d.sync += r2.eq(r2 + (f_after >> 1) + e)

        # The stages, each from registers. For the block's first step the last three run in
        # the setup's last cycles (from the start point, F = 0).
        stage = self.stage
        with m.If(stage[0]):
            m.d.sync += [p.eq(p + p_moves), v.eq(Mux(v_moves, Mux(sv_neg, v - 1, v + 1), v))]
            with m.If(Mux(exp, v_moves, p_moves)):
                m.d.sync += g.eq(g + (b << 1))
        with m.If(exp & (stage[0] | stage[1])):  # an exponential's two carries
            kk = a[1:25]
            less = r2 - kk
            up = less >= 0
            with m.If(up | (r2 < 0)):
                low = f_after[:_F_EXP_BITS] + Mux(up ^ decays, 2, -2)
                m.d.sync += [r2.eq(Mux(up, less, r2 + kk)),
                             f_after.eq(low[:_F_EXP_BITS].as_signed())]
        with m.If((self.setup & (k == _MULTIPLY + 1)) | stage[1]):
            m.d.sync += [next_long_p.eq(magnitude(g) <= a), next_sv_neg.eq(~exp & (g < 0))]
        with m.If(stage[1]):
            passed = (p > pe) | (exp & at_ve & v_moves)
            m.d.sync += [final.eq(((p == pe) & (v == ve)) | passed), final_error.eq(passed),
                         at_ve.eq(v == ve)]
        with m.If((self.setup & (k == _MULTIPLY + 2)) | stage[2]):
            sa = Mux(next_sv_neg, -a, a)
            m.d.sync += [d1.eq(Mux(next_long_p, f_after - g, f_after + sa)),
                         d2.eq(f_after - g + sa)]
        with m.If((self.setup & (k == _MULTIPLY + 3)) | stage[3]):
            # The short axis moves too if that makes |F| smaller: d2 = d1 + t with t = +-A on
            # the long axis p, -G on v (never 0); t > 0: v moves up on p, G < 0 on v.
            smaller = shorter(d1, d2, Mux(next_long_p, ~next_sv_neg, next_sv_neg))
            m.d.sync += [next_diag.eq(smaller), d1.eq(Mux(smaller, d2, d1))]
        return m
