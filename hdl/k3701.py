"""KM3701 interpolator gateware (SPEC section 3).

The reference model is :mod:`hdl.k3701_model`; this module is tested against it cycle by cycle.
"""

from amaranth.hdl import Cat, Const, Module, Mux, Signal, signed
from amaranth.lib import enum, wiring
from amaranth.lib.wiring import In, Out, connect, flipped

from hdl.hostbus import Access, Field, HostBus, Register, RegisterBank, RegisterMap
from hdl.k3701_model import (
    CIRCLE_SETUP_CYCLES,
    LATENCY_CIRCULAR,
    LATENCY_LINEAR,
    MAX_RADIUS_SQUARED,
)

__all__ = ["K3701", "K3701_MAP"]

_COORD = "24-bit two's complement, -(2^23-1)..2^23-1 LSB"

K3701_MAP = RegisterMap("K3701", 1, (
    Register("X", 0x00, 24, Access.RW,
             f"write: end point Xe relative to the start; read: remaining distance Xm "
             f"({_COORD})", signed=True),
    Register("Y", 0x03, 24, Access.RW,
             f"write: end point Ye relative to the start; read: remaining distance Ym "
             f"({_COORD})", signed=True),
    Register("I", 0x06, 24, Access.W,
             f"circular: centre X relative to the start ({_COORD})", signed=True),
    Register("J", 0x09, 24, Access.W,
             f"circular: centre Y relative to the start ({_COORD})", signed=True),
    Register("CTRL", 0x0C, 8, Access.RW, "control word of the next block (reads back)", fields=(
        Field("circular", 0, 1, "interpolation type: 0 linear, 1 circular"),
        Field("cw", 1, 1, "circular direction: 0 CCW, 1 CW"),
        Field("sqrt2", 2, 1, "sqrt(2) control: a diagonal step costs 1.5 FP"),
        Field("quadrant", 3, 2, "circular end-point quadrant minus 1 (0..3 = quadrant 1..4)"),
    )),
    Register("CMD", 0x0D, 8, Access.W, "commands, acted on in the cycle after the write",
             fields=(
                 Field("start", 0, 1, "start the block held in X, Y, I, J, CTRL "
                                      "(refused with ERROR while BUSY)"),
                 Field("ack", 1, 1, "acknowledge (clear) the data-request interrupt"),
                 Field("clear", 2, 1, "clear the ERROR and OVERRUN status bits"),
             )),
    Register("STATUS", 0x0E, 8, Access.R, "status", fields=(
        Field("busy", 0, 1, "a block is running"),
        Field("irq", 1, 1, "data request: the block ended (held until CMD.ack)"),
        Field("error", 2, 1, "invalid block data, an arc that left its end quadrant, or START "
                             "while BUSY (sticky until CMD.clear)"),
        Field("overrun", 3, 1, "an FP arrived while one was already held and was lost "
                               "(sticky until CMD.clear)"),
    )),
), doc="Interpolator: linear and circular interpolation of one block, step pulses out.")


class _Phase(enum.Enum, shape=2):
    IDLE = 0
    SETUP = 1
    RUN = 2


def _abs(v):
    return Mux(v < 0, -v, v)


def _quadrant(x, y, cw):
    """Quadrant code 0..3 (= quadrant 1..4) of (x, y) for the motion direction ``cw``."""
    xp, xz, yp, yz = x > 0, x == 0, y > 0, y == 0
    xn, yn = ~xp & ~xz, ~yp & ~yz
    ccw = Mux(xp & (yp | yz), 0, Mux((xn | xz) & yp, 1, Mux(xn & (yn | yz), 2, 3)))
    cwq = Mux((xp | xz) & yp, 0, Mux(xn & (yp | yz), 1, Mux((xn | xz) & yn, 2, 3)))
    return Mux(cw, cwq, ccw)


def _signs_negative(q, cw):
    """(x moves negative, y moves negative) inside quadrant code ``q``."""
    sx_neg = Mux(cw, q[1], ~q[1])            # CCW: Q1, Q2; CW: Q3, Q4
    sy_neg = Mux(cw, q[0] == q[1], q[0] != q[1])  # CCW: Q2, Q3; CW: Q1, Q4
    return sx_neg, sy_neg


class K3701(wiring.Component):
    """The KM3701 two-axis interpolator.

    The host loads a block through :data:`K3701_MAP` and writes ``CMD.start``; each feed pulse
    earns step credit and each step emits one-cycle pulses on the axes it moves. Timing is
    that of :class:`hdl.k3701_model.K3701Model` (S is the cycle after the host's write of the
    start command):

    * linear: BUSY and FP intake from S+1; circular: BUSY from S+1, a serial radius check
      until S+``circle_setup``, FP intake from S+1+``circle_setup``;
    * a step's pulses appear exactly ``latency_*`` cycles after the FP that completes its
      credit (2 half-FP per FP; a step costs 2, a diagonal one 3 with sqrt(2) control);
      one FP arriving meanwhile is held, a further one sets OVERRUN and is lost;
    * BUSY falls and ``irq`` rises in the cycle of the final step's pulses.

    Parameters
    ----------
    latency_linear, latency_circular : int
        Cycles from the credit-completing FP to the step pulses (paper: 11 and 21 at 1 MHz).
    circle_setup : int
        Cycles of the circular radius check; must equal 25 (24 squarer cycles plus the check).

    Members
    -------
    bus : In(HostBus(K3701_MAP.addr_width))
        Host interface (see :mod:`hdl.hostbus` for its cycle timing).
    fp : In(1)
        Feed pulse, sampled every cycle; each cycle it is high counts as one FP.
    x_pos, x_neg, y_pos, y_neg : Out(1)
        One-cycle step pulses; a diagonal step pulses both axes in the same cycle.
    busy : Out(1)
        A block is running (STATUS.busy).
    irq : Out(1)
        Data-request interrupt; rises when a block ends (also with ERROR), held until CMD.ack.
    error, overrun : Out(1)
        The sticky STATUS bits.
    """

    bus: In(HostBus(K3701_MAP.addr_width))
    fp: In(1)
    x_pos: Out(1)
    x_neg: Out(1)
    y_pos: Out(1)
    y_neg: Out(1)
    busy: Out(1)
    irq: Out(1)
    error: Out(1)
    overrun: Out(1)

    def __init__(self, *, latency_linear: int = LATENCY_LINEAR,
                 latency_circular: int = LATENCY_CIRCULAR,
                 circle_setup: int = CIRCLE_SETUP_CYCLES):
        for name, value in (("latency_linear", latency_linear),
                            ("latency_circular", latency_circular)):
            if not isinstance(value, int) or not 2 <= value <= 32:
                raise ValueError(f"{name} must be an integer in 2..32, not {value!r}")
        if circle_setup != CIRCLE_SETUP_CYCLES:
            raise ValueError(f"circle_setup must be {CIRCLE_SETUP_CYCLES} (24 squarer cycles "
                             f"and the check), not {circle_setup!r}")
        self.latency_linear = latency_linear
        self.latency_circular = latency_circular
        self.circle_setup = circle_setup
        super().__init__()

    def elaborate(self, platform) -> Module:
        m = Module()
        m.submodules.regs = regs = RegisterBank(K3701_MAP)
        connect(m, flipped(self.bus), regs.bus)
        ctrl = K3701_MAP["CTRL"]
        cmd = K3701_MAP["CMD"]

        phase = Signal(_Phase)
        circular = Signal()
        cw = Signal()
        sqrt2 = Signal()
        end_q = Signal(2)
        xm = Signal(signed(24))
        ym = Signal(signed(24))
        bad = Signal()          # a coordinate of the block was -2^23
        # Linear working registers.
        long_is_x = Signal()
        n_long = Signal(24)
        n_short = Signal(24)
        acc = Signal(25)
        left = Signal(24)
        lx_neg = Signal()
        ly_neg = Signal()
        # Circular working registers (position and end point relative to the centre).
        x = Signal(signed(25))
        y = Signal(signed(25))
        ex = Signal(signed(26))
        ey = Signal(signed(26))
        d = Signal(signed(28))
        q = Signal(2)
        armed = Signal()
        end_on_x = Signal()
        sq = Signal(48)
        sq_k = Signal(range(25))
        # Feed intake.
        count = Signal(range(max(self.latency_linear, self.latency_circular)))
        held = Signal()
        credit = Signal(3)

        m.d.comb += [
            regs.x.r_data.eq(xm),
            regs.y.r_data.eq(ym),
            regs.ctrl.r_data.eq(regs.ctrl.w_data),
            regs.status.r_data.eq(Cat(self.busy, self.irq, self.error, self.overrun)),
        ]

        # --- the next step, decided combinationally from the working registers ---
        lin_diag = (acc + n_short) >= n_long
        lin_x_move = long_is_x | lin_diag
        lin_y_move = ~long_is_x | lin_diag

        sx_neg, sy_neg = _signs_negative(q, cw)
        circ_long_x = _abs(y) >= _abs(x)
        two_x = Mux(sx_neg, -(x << 1), x << 1)
        two_y = Mux(sy_neg, -(y << 1), y << 1)
        d1 = Signal(signed(28))
        d2 = Signal(signed(28))
        m.d.comb += [d1.eq(d + Mux(circ_long_x, two_x, two_y) + 1),
                     d2.eq(d1 + Mux(circ_long_x, two_y, two_x) + 1)]
        circ_diag = _abs(d2) < _abs(d1)
        circ_x_move = circ_long_x | circ_diag
        circ_y_move = ~circ_long_x | circ_diag

        step_diag = Mux(circular, circ_diag, lin_diag)
        x_move = Mux(circular, circ_x_move, lin_x_move)
        y_move = Mux(circular, circ_y_move, lin_y_move)
        x_neg = Mux(circular, sx_neg, lx_neg)
        y_neg = Mux(circular, sy_neg, ly_neg)
        dx = Mux(x_move, Mux(x_neg, -1, 1), 0)
        dy = Mux(y_move, Mux(y_neg, -1, 1), 0)

        x_next = Signal(signed(25))
        y_next = Signal(signed(25))
        q_next = Signal(2)
        m.d.comb += [x_next.eq(x + dx), y_next.eq(y + dy), q_next.eq(_quadrant(x_next, y_next, cw))]
        arming = armed | ((q_next == end_q) & (q_next != q))
        circ_left = arming & (q_next != end_q)
        circ_reached = arming & (q_next == end_q) & Mux(end_on_x, x_next == ex, y_next == ey)
        final = Mux(circular, circ_left | circ_reached, left == 1)
        final_error = circular & circ_left

        # --- feed intake: hold one FP while the engine is busy, lose (and flag) a second ---
        latency_m1 = Mux(circular, self.latency_circular - 1, self.latency_linear - 1)
        engine_busy = (phase == _Phase.SETUP) | ((phase == _Phase.RUN) & (count != 0))

        m.d.sync += [self.x_pos.eq(0), self.x_neg.eq(0), self.y_pos.eq(0), self.y_neg.eq(0)]
        start = regs.cmd.w_stb & cmd.field("start").decode(regs.cmd.w_data)
        with m.If(regs.cmd.w_stb & regs.cmd.w_data[cmd.field("ack").offset]):
            m.d.sync += self.irq.eq(0)
        with m.If(regs.cmd.w_stb & regs.cmd.w_data[cmd.field("clear").offset]):
            m.d.sync += [self.error.eq(0), self.overrun.eq(0)]
        with m.If(engine_busy & self.fp):
            with m.If(held):
                m.d.sync += self.overrun.eq(1)
            with m.Else():
                m.d.sync += held.eq(1)

        def finish(error):
            m.d.sync += [phase.eq(_Phase.IDLE), self.busy.eq(0), self.irq.eq(1), held.eq(0),
                         count.eq(0)]
            with m.If(error):
                m.d.sync += self.error.eq(1)

        with m.Switch(phase):
            with m.Case(_Phase.IDLE):
                with m.If(start):
                    # Latch the block: the registers may be rewritten while it runs.
                    xe, ye = regs.x.w_data.as_signed(), regs.y.w_data.as_signed()
                    i, j = regs.i.w_data.as_signed(), regs.j.w_data.as_signed()
                    word = regs.ctrl.w_data
                    is_circ = ctrl.field("circular").decode(word)
                    min_coord = -(1 << 23)
                    lin_bad = (xe == min_coord) | (ye == min_coord)
                    axe, aye = _abs(xe), _abs(ye)
                    x_long = axe >= aye
                    nl = Mux(x_long, axe, aye)
                    m.d.sync += [
                        circular.eq(is_circ),
                        cw.eq(word[ctrl.field("cw").offset]),
                        sqrt2.eq(word[ctrl.field("sqrt2").offset]),
                        end_q.eq(ctrl.field("quadrant").decode(word)),
                        xm.eq(xe), ym.eq(ye),
                        credit.eq(0), held.eq(0), count.eq(0),
                        # linear
                        long_is_x.eq(x_long), n_long.eq(nl),
                        n_short.eq(Mux(x_long, aye, axe)), acc.eq(nl >> 1),
                        left.eq(nl), lx_neg.eq(xe < 0), ly_neg.eq(ye < 0),
                        # circular
                        x.eq(-i), y.eq(-j), ex.eq(xe - i), ey.eq(ye - j), d.eq(0),
                        end_on_x.eq(_abs(ye - j) >= _abs(xe - i)),
                        bad.eq(lin_bad | (i == min_coord) | (j == min_coord)),
                        sq.eq(0), sq_k.eq(0),
                    ]
                    with m.If(is_circ):
                        m.d.sync += [phase.eq(_Phase.SETUP), self.busy.eq(1)]
                    with m.Elif(lin_bad):
                        m.d.sync += [self.error.eq(1), self.irq.eq(1)]
                    with m.Elif(nl == 0):
                        m.d.sync += self.irq.eq(1)
                    with m.Else():
                        m.d.sync += [phase.eq(_Phase.RUN), self.busy.eq(1)]
            with m.Case(_Phase.SETUP):
                ax, ay = _abs(x), _abs(y)
                bit = (23 - sq_k).as_unsigned()
                with m.If(sq_k != 24):
                    m.d.sync += [
                        sq.eq((sq << 1) + Mux(ax.bit_select(bit, 1), ax, 0)
                              + Mux(ay.bit_select(bit, 1), ay, 0)),
                        sq_k.eq(sq_k + 1),
                    ]
                with m.Else():
                    q0 = _quadrant(x, y, cw)
                    sx0_neg, sy0_neg = _signs_negative(q0, cw)
                    ahead = Mux(end_on_x, Mux(sx0_neg, ex < x, ex > x),
                                Mux(sy0_neg, ey < y, ey > y))
                    invalid = (bad | (sq == 0) | (sq > MAX_RADIUS_SQUARED)
                               | ((ex == 0) & (ey == 0)) | (_quadrant(ex, ey, cw) != end_q))
                    with m.If(invalid):
                        finish(Const(1))
                    with m.Else():
                        m.d.sync += [phase.eq(_Phase.RUN), q.eq(q0),
                                     armed.eq((q0 == end_q) & ahead)]
            with m.Case(_Phase.RUN):
                with m.If(count == 0):
                    take = held | self.fp
                    m.d.sync += held.eq(held & self.fp)
                    credit2 = credit + 2
                    cost = Mux(sqrt2 & step_diag, 3, 2)
                    with m.If(take):
                        with m.If(credit2 >= cost):
                            m.d.sync += [credit.eq(credit2 - cost), count.eq(latency_m1)]
                        with m.Else():
                            m.d.sync += credit.eq(credit2)
                with m.Else():
                    m.d.sync += count.eq(count - 1)
                    with m.If(count == 1):
                        m.d.sync += [
                            self.x_pos.eq(x_move & ~x_neg), self.x_neg.eq(x_move & x_neg),
                            self.y_pos.eq(y_move & ~y_neg), self.y_neg.eq(y_move & y_neg),
                            xm.eq(xm - dx), ym.eq(ym - dy),
                            # linear
                            acc.eq(Mux(lin_diag, acc + n_short - n_long, acc + n_short)),
                            left.eq(left - 1),
                            # circular
                            x.eq(x_next), y.eq(y_next), q.eq(q_next), armed.eq(arming),
                            d.eq(Mux(circ_diag, d2, d1)),
                        ]
                        with m.If(final):
                            finish(final_error)

        # START while a block runs is refused (and flagged), never obeyed.
        with m.If(start & (phase != _Phase.IDLE)):
            m.d.sync += self.error.eq(1)
        return m

