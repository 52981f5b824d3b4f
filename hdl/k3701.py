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
    Block,
    Kind,
)
from hdl.observation import Countdown, FreeRunning

__all__ = ["K3701", "K3701_MAP", "block_registers"]

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


def block_registers(block: Block) -> dict[str, int]:
    """The registers that load ``block``, in the order the host writes them (CTRL last; the
    block then runs on CMD.start). Lines leave I and J as they are."""
    values = {"X": block.xe, "Y": block.ye}
    if block.kind is Kind.CIRCULAR:
        values |= {"I": block.i, "J": block.j}
    values["CTRL"] = K3701_MAP["CTRL"].encode(
        circular=int(block.kind), cw=int(block.cw), sqrt2=int(block.sqrt2),
        quadrant=block.quadrant - 1)
    return values


class _Phase(enum.Enum, shape=2):
    IDLE = 0
    SETUP = 1
    RUN = 2


#: Cycles of a circular step's latency in which its successor is decided (see ``K3701``).
_CIRCLE_STAGES = 4


def _field(word, field):
    """The bits of ``field`` in ``word`` (a slice: cheaper to simulate than Field.decode)."""
    return word[field.offset:field.offset + field.width]


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

    Inside, each step is decided before its FP can come: a line's next step in the cycle the
    current one is output, a circle's first step during the radius check and each following
    one in four pipelined cycles of the current step's latency. The logic thus works only
    when there is something to decide, which keeps compiled simulation fast; it needs a
    circular latency of at least 6 cycles.

    Parameters
    ----------
    latency_linear, latency_circular : int
        Cycles from the credit-completing FP to the step pulses (paper: 11 and 21 at 1 MHz);
        2..32 linear, 6..32 circular.
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

    Simulation only (attributes, not pins: see :mod:`hdl.observation`)
    ----------------------------------------------------------------
    quiet : Signal(1)
        While no FP comes, the step latency count affects nothing but its own decrement each
        cycle until it reaches 1: FP is low, and the count is 0 (waiting for FP) or at least
        2 and, in a circle, past the decision stages; combinational.
    FREE_RUNNING : FreeRunning
        The latency count, a :class:`hdl.observation.Countdown` that stops before 1.
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

    #: See "Simulation only" above (names local to the K3701).
    FREE_RUNNING = FreeRunning(countdowns=(Countdown("count", stop=1),), quiet="quiet")

    def __init__(self, *, latency_linear: int = LATENCY_LINEAR,
                 latency_circular: int = LATENCY_CIRCULAR,
                 circle_setup: int = CIRCLE_SETUP_CYCLES):
        for name, value, low in (("latency_linear", latency_linear, 2),
                                 ("latency_circular", latency_circular, 2 + _CIRCLE_STAGES)):
            if not isinstance(value, int) or not low <= value <= 32:
                raise ValueError(f"{name} must be an integer in {low}..32, not {value!r}")
        if circle_setup != CIRCLE_SETUP_CYCLES:
            raise ValueError(f"circle_setup must be {CIRCLE_SETUP_CYCLES} (24 squarer cycles "
                             f"and the check), not {circle_setup!r}")
        self.latency_linear = latency_linear
        self.latency_circular = latency_circular
        self.circle_setup = circle_setup
        super().__init__()
        self.quiet = Signal()

    def elaborate(self, platform) -> Module:
        # Written for compiled simulation (CXXRTL evaluates an expression only when the
        # conditions around it select it, if it feeds one register and no intermediate value
        # is used twice or sign-extended): the heavy logic sits under rare conditions, and
        # multi-use values are registers.
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
        # The current step, decided before its FP can come: it moves the long axis (X if
        # long_x), and the other one too if diag; final (and final_error) by its output.
        long_x = Signal()
        diag = Signal()
        final = Signal()
        final_error = Signal()
        # Linear working registers.
        n_long = Signal(24)
        n_short = Signal(24)
        acc = Signal(25)
        left = Signal(24)
        lx_neg = Signal()
        ly_neg = Signal()
        # Circular working registers (position and end point relative to the centre).
        x = Signal(signed(25))
        y = Signal(signed(25))
        ex = Signal(signed(25))
        ey = Signal(signed(25))
        q = Signal(2)
        armed = Signal()
        d_after = Signal(signed(28))  # D = x^2 + y^2 - R0^2 after the current step
        end_on_x = Signal()
        bad = Signal()          # the circle is invalid (complete at the end of the check)
        sq = Signal(48)
        sq_k = Signal(range(25))
        # The circle's next step, decided in stages (see below).
        next_q = Signal(2)
        next_long_x = Signal()
        next_diag = Signal()
        next_armed = Signal()
        d1 = Signal(signed(28))  # D after the next step: first if single-axis, then chosen
        d2 = Signal(signed(28))  # D after the next step if diagonal
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

        # The current step's moves.
        sx_neg, sy_neg = _signs_negative(q, cw)
        x_move = long_x | diag
        y_move = ~long_x | diag
        x_neg = Mux(circular, sx_neg, lx_neg)
        y_neg = Mux(circular, sy_neg, ly_neg)
        dx = Mux(x_move, Mux(x_neg, -1, 1), 0)
        dy = Mux(y_move, Mux(y_neg, -1, 1), 0)

        # --- feed intake: hold one FP while the engine is busy, lose (and flag) a second ---
        latency_m1 = Mux(circular, self.latency_circular - 1, self.latency_linear - 1)
        engine_busy = (phase == _Phase.SETUP) | ((phase == _Phase.RUN) & (count != 0))

        m.d.sync += [self.x_pos.eq(0), self.x_neg.eq(0), self.y_pos.eq(0), self.y_neg.eq(0)]
        start = regs.cmd.w_stb & regs.cmd.w_data[cmd.field("start").offset]
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
                    is_circ = word[ctrl.field("circular").offset]
                    min_coord = -(1 << 23)

                    # Fresh expressions for each use, so that each is evaluated only here.
                    def line_refused():
                        return (xe == min_coord) | (ye == min_coord)

                    def line_stops():
                        return line_refused() | ((xe == 0) & (ye == 0))

                    axe, aye = _abs(xe).as_unsigned(), _abs(ye).as_unsigned()
                    x_long = axe >= aye
                    nl = Mux(x_long, axe, aye)
                    ns = Mux(x_long, aye, axe)
                    m.d.sync += [
                        circular.eq(is_circ),
                        cw.eq(word[ctrl.field("cw").offset]),
                        sqrt2.eq(word[ctrl.field("sqrt2").offset]),
                        end_q.eq(_field(word, ctrl.field("quadrant"))),
                        xm.eq(xe), ym.eq(ye),
                        credit.eq(0), held.eq(0), count.eq(0),
                        # linear, and its first step (a circle decides its own in SETUP)
                        long_x.eq(x_long), n_long.eq(nl), n_short.eq(ns), acc.eq(nl[1:]),
                        diag.eq(nl[1:] + ns >= nl), final.eq(nl == 1), final_error.eq(0),
                        left.eq(nl), lx_neg.eq(xe < 0), ly_neg.eq(ye < 0),
                        # circular
                        x.eq(-i), y.eq(-j), ex.eq(xe - i), ey.eq(ye - j), d_after.eq(0),
                        bad.eq(line_refused() | (i == min_coord) | (j == min_coord)),
                        sq.eq(0), sq_k.eq(0),
                        phase.eq(Mux(is_circ, _Phase.SETUP,
                                     Mux(line_stops(), _Phase.IDLE, _Phase.RUN))),
                        self.busy.eq(is_circ | ~line_stops()),
                    ]
                    with m.If(~is_circ & line_refused()):
                        m.d.sync += self.error.eq(1)
                    with m.If(~is_circ & line_stops()):
                        m.d.sync += self.irq.eq(1)
            with m.Case(_Phase.SETUP):
                ax, ay = _abs(x), _abs(y)
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
                                end_on_x.eq(_abs(ey) >= _abs(ex)),
                                bad.eq(bad | ((ex == 0) & (ey == 0))
                                       | (_quadrant(ex, ey, cw) != end_q)),
                            ]
                        with m.Case(23):
                            sq_final = (sq << 1) + Mux(ax[0], ax, 0) + Mux(ay[0], ay, 0)
                            m.d.sync += bad.eq(bad | (sq_final == 0)
                                               | (sq_final > MAX_RADIUS_SQUARED))
                with m.Elif(bad):
                    finish(Const(1))
                with m.Else():
                    sx0_neg, sy0_neg = _signs_negative(next_q, cw)
                    ahead = Mux(end_on_x, Mux(sx0_neg, ex < x, ex > x),
                                Mux(sy0_neg, ey < y, ey > y))
                    m.d.sync += [phase.eq(_Phase.RUN), q.eq(next_q),
                                 armed.eq((next_q == end_q) & ahead),
                                 long_x.eq(next_long_x), diag.eq(next_diag), d_after.eq(d1)]
            with m.Case(_Phase.RUN):
                with m.If(count == 0):
                    take = held | self.fp
                    m.d.sync += held.eq(held & self.fp)
                    credit2 = credit + 2
                    cost = Mux(sqrt2 & diag, 3, 2)
                    with m.If(take):
                        with m.If(credit2 >= cost):
                            m.d.sync += [credit.eq(credit2 - cost), count.eq(latency_m1)]
                        with m.Else():
                            m.d.sync += credit.eq(credit2)
                with m.Else():
                    m.d.sync += count.eq(count - 1)
                    with m.If(count == 1):
                        acc_next = Mux(diag, acc + n_short - n_long, acc + n_short)
                        m.d.sync += [
                            self.x_pos.eq(x_move & ~x_neg), self.x_neg.eq(x_move & x_neg),
                            self.y_pos.eq(y_move & ~y_neg), self.y_neg.eq(y_move & y_neg),
                            xm.eq(xm - dx), ym.eq(ym - dy),
                            # linear: the next step
                            acc.eq(acc_next), left.eq(left - 1),
                            # circular: the next step, as the stages decided it
                            q.eq(next_q), armed.eq(next_armed), d_after.eq(d1),
                            long_x.eq(Mux(circular, next_long_x, long_x)),
                            diag.eq(Mux(circular, next_diag, acc_next + n_short >= n_long)),
                        ]
                        with m.If(~circular):
                            m.d.sync += final.eq(left == 2)
                        with m.If(final):
                            finish(final_error)

        # A circle's step is decided in four stages, each from registers: the position moves,
        # then its quadrant and long axis, then the two candidate D values (and whether the
        # step ends the arc), then the choice. For a block's first step the last three run in
        # the radius check's first cycles (from the start point, D = 0); for each next step
        # all four run in the current step's latency, so that it is decided before the
        # current step's output, when the next FP may already come. (Written after the
        # phase switch, so that no register's hold value is shared between its branches.)
        in_setup = phase == _Phase.SETUP
        in_circle_run = (phase == _Phase.RUN) & circular
        stage = [in_circle_run & (count == self.latency_circular - k)
                 for k in range(1, _CIRCLE_STAGES + 1)]
        with m.If(stage[0]):
            m.d.sync += [x.eq(x + dx), y.eq(y + dy)]
        with m.If((in_setup & (sq_k == 0)) | stage[1]):
            m.d.sync += [next_q.eq(_quadrant(x, y, cw)), next_long_x.eq(_abs(y) >= _abs(x))]
        with m.If((in_setup & (sq_k == 1)) | stage[2]):
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
        with m.If((in_setup & (sq_k == 2)) | stage[3]):
            # The short axis moves too if that makes |D| smaller.
            m.d.sync += [next_diag.eq(_abs(d2) < _abs(d1)),
                         d1.eq(Mux(_abs(d2) < _abs(d1), d2, d1))]

        m.d.comb += self.quiet.eq(~self.fp & ((count == 0) | ((count >= 2) & (
            ~circular | (count <= self.latency_circular - 1 - _CIRCLE_STAGES)))))

        # START while a block runs is refused (and flagged), never obeyed.
        with m.If(start & (phase != _Phase.IDLE)):
            m.d.sync += self.error.eq(1)
        return m
