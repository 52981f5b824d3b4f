"""K3701 exponential (and, with the abscissa Y, logarithmic) interpolation datapath: a self-fed
DDA whose integrand u = Q + R / k + R2 / k^2 carries its own fraction.

The reference model is :class:`hdl.k3701_model.ExponentialPath`.
"""

from __future__ import annotations

from amaranth.hdl import Module, Mux, Signal, signed

from hdl.k3701_datapath import Datapath, frame_step, magnitude, refused, shorter
from hdl.k3701_model import EXPONENTIAL_SETUP_CYCLES

__all__ = ["ExponentialDatapath"]

#: F and its candidates, signed: |F| stays below |k| + Q < 2^25 and a candidate below
#: |F| + Q + |k| < 2^26.
_F_BITS = 28
#: R2, signed: a p step adds sign(k) R (|R| < 2^26), each step carries |k| out of it.
_R2_BITS = 28
#: Q, signed: c - |ve| - 1 <= Q <= c + |ve| + 1 < 2^24 + 1.
_Q_BITS = 26


class ExponentialDatapath(Datapath):
    """Exponential interpolation in the curve's own frame (abscissa p, X or Y with ``swap``;
    ordinate v), the model's self-fed DDA: the integrand's integer part Q (from J), its digits
    R (kept as F = sign(k) (R - E), the curve's height above the point in 1/|k| LSB) and R2
    in base |k| = ``|I|``. A p step adds Q to F and sign(k) R to R2, a v step takes |k| from
    F and moves Q by sign(k); after each step two carries, one at a time, move between R2 and
    F while R2 is outside 0..|k|-1. The long axis is p where Q <= |k|, else v; the short
    axis moves too if that makes |F| smaller; v moves in the sign of the end's v; the block
    ends on the end point, or with an error if p or v passes the end's.

    Timing (the ports are those of :class:`hdl.k3701_datapath.DatapathSignature`; S is the
    start cycle, C the cycle a step's credit completes, L the latency):

    * setup, S+1 to S+4: the first step is decided in S+1 to S+3 as the stages decide the
      others. In S+4 ``end`` (with ``error``) is high for refused data (a coordinate of
      -2^23, pe = 0, |I| < 2, J < 0, E outside 0..|I|-1), else ``ready``; the first step is
      in ``step`` from S+5;
    * four stages, C+1 to C+4: the position and Q move by the current step, and the first
      carry; the second carry, whether the current step ends the block (``final``,
      ``error``) and the next step's long axis; the two candidate F values (and sign(k) R);
      the choice, which ``advance`` (in C+L-1, L >= 6) puts in ``step`` from C+L, adding
      sign(k) R to R2 if it moves p.
    """

    SETUP = True
    STAGES = 4

    def elaborate(self, platform) -> Module:
        m = Module()
        block = self.block
        swap = Signal()
        su_neg = Signal()           # p runs towards negative X (Y with swap)
        sv_neg = Signal()           # v runs towards negative Y (X with swap)
        decays = Signal()           # k < 0: Q falls with each v step
        pe = Signal(24)
        ve = Signal(24)             # |the end's v|
        kk = Signal(24)             # |k|
        frac = Signal(signed(25))   # sign(k) E
        bad = Signal()
        n = Signal(range(EXPONENTIAL_SETUP_CYCLES))
        p = Signal(25)
        v = Signal(25)              # |v|
        q = Signal(signed(_Q_BITS))
        r2 = Signal(signed(_R2_BITS))
        # The current step: long axis p, diagonal, whether it ends the block (and with an
        # error), F after it (after its carries from stage 1); sign(k) R before the next.
        long_p = Signal()
        diag = Signal()
        final = Signal()
        final_error = Signal()
        f = Signal(signed(_F_BITS))
        sr = Signal(signed(_F_BITS))
        # The next step, decided in the stages.
        next_long_p = Signal()
        next_diag = Signal()
        d1 = Signal(signed(_F_BITS))  # F after the next step: first if on the long axis only
        d2 = Signal(signed(_F_BITS))  # F after the next step if diagonal

        last = self.setup & (n == EXPONENTIAL_SETUP_CYCLES - 1)
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
            k_s = magnitude(block.i)
            m.d.sync += [
                swap.eq(block.swap), su_neg.eq(pe_s < 0), sv_neg.eq(ve_s < 0),
                decays.eq(block.i < 0), pe.eq(magnitude(pe_s)), ve.eq(magnitude(ve_s)),
                kk.eq(k_s), frac.eq(Mux(block.i < 0, -block.e, block.e)),
                n.eq(0), p.eq(0), v.eq(0), q.eq(block.j), r2.eq(0), f.eq(0),
                bad.eq(refused(block, "xe", "ye", "i", "j", "e") | (pe_s == 0) | (k_s < 2)
                       | (block.j < 0) | (block.e < 0) | (block.e >= k_s)),
            ]
        with m.Elif(self.setup):
            m.d.sync += n.eq(n + 1)

        # The current step becomes the next one: at the setup's end (the block's first step)
        # and with each advance; its p move adds sign(k) R to R2.
        with m.If(last | self.advance):
            m.d.sync += [long_p.eq(next_long_p), diag.eq(next_diag), f.eq(d1)]
            with m.If(next_long_p | next_diag):
                m.d.sync += r2.eq(r2 + sr)

        # The stages, each from registers. For the block's first step the last three run in
        # the setup's first cycles (from the start point, F = 0).
        stage = self.stage
        p_moves = long_p | diag
        v_moves = ~long_p | diag
        with m.If(stage[0]):
            m.d.sync += [p.eq(p + p_moves), v.eq(v + v_moves),
                         q.eq(Mux(v_moves, Mux(decays, q - 1, q + 1), q))]
        with m.If(stage[0] | stage[1]):  # the two carries
            with m.If(r2 >= kk):
                m.d.sync += [r2.eq(r2 - kk), f.eq(Mux(decays, f - 1, f + 1))]
            with m.Elif(r2 < 0):
                m.d.sync += [r2.eq(r2 + kk), f.eq(Mux(decays, f + 1, f - 1))]
        with m.If((self.setup & (n == 0)) | stage[1]):
            m.d.sync += next_long_p.eq(q <= kk)
        with m.If(stage[1]):
            passed = (p > pe) | (v > ve)
            m.d.sync += [final.eq(((p == pe) & (v == ve)) | passed), final_error.eq(passed)]
        with m.If((self.setup & (n == 1)) | stage[2]):
            fq = f + q
            m.d.sync += [d1.eq(Mux(next_long_p, fq, f - kk)), d2.eq(fq - kk),
                         sr.eq(f + frac)]
        with m.If((self.setup & (n == 2)) | stage[3]):
            # The short axis moves too if that makes |F| smaller: d2 = d1 + t with t = -|k| on
            # the long axis p, +Q on v.
            smaller = shorter(d1, d2, ~next_long_p)
            m.d.sync += [next_diag.eq(smaller), d1.eq(Mux(smaller, d2, d1))]
        return m
