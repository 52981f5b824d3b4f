"""K3701 circular interpolation datapath: the sign-of-D method with a serial radius check.

The reference model is :class:`k37.hdl.k3701.datapaths.model.circular.CircularPath`.
"""

from __future__ import annotations

from amaranth.hdl import Module, Mux, Signal, Value, signed

from k37.hdl.k3701.block import MAX_RADIUS_SQUARED
from k37.hdl.k3701.datapaths.base import Datapath, magnitude, moves, refused

__all__ = ["CircularDatapath"]


def _quadrant(x: Value, y: Value, cw: Value) -> Value:
    """Quadrant code 0..3 (= quadrant 1..4) of (x, y) for the motion direction ``cw``."""
    xp, xz, yp, yz = x > 0, x == 0, y > 0, y == 0
    xn, yn = ~xp & ~xz, ~yp & ~yz
    ccw = Mux(xp & (yp | yz), 0, Mux((xn | xz) & yp, 1, Mux(xn & (yn | yz), 2, 3)))
    cwq = Mux((xp | xz) & yp, 0, Mux(xn & (yp | yz), 1, Mux((xn | xz) & yn, 2, 3)))
    return Mux(cw, cwq, ccw)


def _signs_negative(q: Value, cw: Value) -> tuple[Value, Value]:
    """(x moves negative, y moves negative) inside quadrant code ``q``."""
    sx_neg = Mux(cw, q[1], ~q[1])            # CCW: Q1, Q2; CW: Q3, Q4
    sy_neg = Mux(cw, q[0] == q[1], q[0] != q[1])  # CCW: Q2, Q3; CW: Q1, Q4
    return sx_neg, sy_neg


class CircularDatapath(Datapath):
    """Circular interpolation: D = x^2 + y^2 - R0^2 kept exactly from the centre; each step
    moves the long axis (X where |y| >= |x|) and the short one too if that makes |D| smaller;
    the arc ends on the end point's long-axis coordinate in the armed end quadrant, or with an
    error on leaving that quadrant.

    Timing (the ports are those of :class:`k37.hdl.k3701.datapaths.base.DatapathSignature`; S is the
    start cycle, C the cycle a step's credit completes, L the latency):

    * setup, S+1 to S+25: a serial squarer checks I^2 + J^2 (24 cycles and the check), and
      meanwhile the end point and the first step are decided from the start point (D = 0) in
      S+1 to S+3. In S+25 ``end`` (with ``error``) is high for invalid data, else ``ready``;
      the first step is in ``step`` from S+26;
    * four stages, C+1 to C+4: the position moves by the current step, then its quadrant and
      long axis are found, then the two candidate D values and whether the current step ends
      the arc (``final``, ``error``), then the choice of the next step, which ``advance``
      (in C+L-1, L >= 6) puts in ``step`` from C+L.

    Each stage works from registers only, so that the logic runs only when there is
    something to decide.
    """

    SETUP = True
    STAGES = 4

    def elaborate(self, platform) -> Module:
        m = Module()
        block = self.block
        cw = Signal()
        end_q = Signal(2)
        # Position and end point relative to the centre.
        x = Signal(signed(25))
        y = Signal(signed(25))
        ex = Signal(signed(25))
        ey = Signal(signed(25))
        end_on_x = Signal()     # the end check looks at X (else Y)
        bad = Signal()          # the circle is invalid (complete at the end of the check)
        sq = Signal(48)
        sq_k = Signal(range(25))
        # The current step: its quadrant, long axis and diagonal move, whether it ends the
        # arc (and with an error), and D after it.
        q = Signal(2)
        armed = Signal()        # inside the end quadrant with the end point ahead
        long_x = Signal()
        diag = Signal()
        final = Signal()
        final_error = Signal()
        d_after = Signal(signed(28))
        # The next step, decided in the stages.
        next_q = Signal(2)
        next_long_x = Signal()
        next_diag = Signal()
        next_armed = Signal()
        d1 = Signal(signed(28))  # D after the next step: first if single-axis, then chosen
        d2 = Signal(signed(28))  # D after the next step if diagonal

        sx_neg, sy_neg = _signs_negative(q, cw)
        checked = self.setup & (sq_k == 24)
        m.d.comb += [
            self.ready.eq(checked & ~bad),
            self.end.eq(checked & bad),
            self.error.eq(1),
            self.step.x.eq(long_x | diag), self.step.x_neg.eq(sx_neg),
            self.step.y.eq(~long_x | diag), self.step.y_neg.eq(sy_neg),
            self.step.diag.eq(diag), self.step.final.eq(final), self.step.error.eq(final_error),
        ]

        with m.If(self.start):
            m.d.sync += [
                cw.eq(block.cw), end_q.eq(block.quadrant),
                x.eq(-block.i), y.eq(-block.j),
                ex.eq(block.xe - block.i), ey.eq(block.ye - block.j), d_after.eq(0),
                bad.eq(refused(block, "xe", "ye", "i", "j")),
                sq.eq(0), sq_k.eq(0),
            ]
        with m.Elif(self.setup):
            ax, ay = magnitude(x), magnitude(y)
            bit = (23 - sq_k).as_unsigned()
            with m.If(sq_k != 24):
                m.d.sync += [
                    sq.eq((sq << 1) + Mux(ax.bit_select(bit, 1), ax, 0)
                          + Mux(ay.bit_select(bit, 1), ay, 0)),
                    sq_k.eq(sq_k + 1),
                ]
                # Meanwhile, the checks that need no radius.
                with m.Switch(sq_k):
                    with m.Case(0):
                        m.d.sync += [
                            end_on_x.eq(magnitude(ey) >= magnitude(ex)),
                            bad.eq(bad | ((ex == 0) & (ey == 0))
                                   | (_quadrant(ex, ey, cw) != end_q)),
                        ]
                    with m.Case(23):
                        sq_final = (sq << 1) + Mux(ax[0], ax, 0) + Mux(ay[0], ay, 0)
                        m.d.sync += bad.eq(bad | (sq_final == 0)
                                           | (sq_final > MAX_RADIUS_SQUARED))
            with m.Elif(~bad):
                # The first step, decided from the start point.
                sx0_neg, sy0_neg = _signs_negative(next_q, cw)
                ahead = Mux(end_on_x, Mux(sx0_neg, ex < x, ex > x),
                            Mux(sy0_neg, ey < y, ey > y))
                m.d.sync += [q.eq(next_q), armed.eq((next_q == end_q) & ahead),
                             long_x.eq(next_long_x), diag.eq(next_diag), d_after.eq(d1)]
        with m.Elif(self.advance):
            m.d.sync += [q.eq(next_q), armed.eq(next_armed), d_after.eq(d1),
                         long_x.eq(next_long_x), diag.eq(next_diag)]

        # The stages, each from registers: the position moves, then its quadrant and long
        # axis, then the two candidate D values (and whether the step ends the arc), then the
        # choice. For a block's first step the last three run in the radius check's first
        # cycles (from the start point, D = 0).
        stage = self.stage
        with m.If(stage[0]):
            dx, dy = moves(self.step)
            m.d.sync += [x.eq(x + dx), y.eq(y + dy)]
        with m.If((self.setup & (sq_k == 0)) | stage[1]):
            m.d.sync += [next_q.eq(_quadrant(x, y, cw)),
                         next_long_x.eq(magnitude(y) >= magnitude(x))]
        with m.If((self.setup & (sq_k == 1)) | stage[2]):
            nx_neg, ny_neg = _signs_negative(next_q, cw)
            two_x = Mux(nx_neg, -x, x) << 1
            two_y = Mux(ny_neg, -y, y) << 1
            m.d.sync += [d1.eq(d_after + Mux(next_long_x, two_x, two_y) + 1),
                         d2.eq(d_after + two_x + two_y + 2)]
        with m.If(stage[2]):
            arming = armed | ((next_q == end_q) & (next_q != q))
            m.d.sync += [next_armed.eq(arming),
                         final.eq(arming & ((next_q != end_q) | Mux(end_on_x, x == ex, y == ey))),
                         final_error.eq(arming & (next_q != end_q))]
        with m.If((self.setup & (sq_k == 2)) | stage[3]):
            # The short axis moves too if that makes |D| smaller.
            m.d.sync += [next_diag.eq(magnitude(d2) < magnitude(d1)),
                         d1.eq(Mux(magnitude(d2) < magnitude(d1), d2, d1))]
        return m
