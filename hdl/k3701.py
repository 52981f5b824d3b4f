"""KM3701 interpolator gateware (SPEC section 3).

The reference model is :mod:`hdl.k3701_model`; this module is tested against it cycle by cycle.
"""

from collections.abc import Sequence
from types import SimpleNamespace

from amaranth.hdl import Cat, Const, Module, Mux, Signal, Value, ValueLike, signed
from amaranth.lib import enum, wiring
from amaranth.lib.wiring import In, Out, connect, flipped

from hdl.hostbus import Access, Field, HostBus, Register, RegisterBank, RegisterMap
from hdl.k3701_circular import CircularDatapath
from hdl.k3701_datapath import Datapath, StepSignature, moves
from hdl.k3701_linear import LinearDatapath
from hdl.k3701_model import (
    CIRCLE_SETUP_CYCLES,
    LATENCY_CIRCULAR,
    LATENCY_LINEAR,
    Block,
    Kind,
)
from hdl.k3701_parabolic import ParabolicDatapath
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
             f"circular: centre X relative to the start; parabolic: X of the point whose "
             f"tangent is parallel to the chord, relative to the start ({_COORD})", signed=True),
    Register("J", 0x09, 24, Access.W,
             f"circular: centre Y relative to the start; parabolic: Y of that point "
             f"({_COORD})", signed=True),
    Register("CTRL", 0x0C, 8, Access.RW, "control word of the next block (reads back)", fields=(
        Field("circular", 0, 1, "interpolation type: 0 linear, 1 circular"),
        Field("cw", 1, 1, "circular direction: 0 CCW, 1 CW"),
        Field("sqrt2", 2, 1, "sqrt(2) control: a diagonal step costs 1.5 FP"),
        Field("quadrant", 3, 2, "circular end-point quadrant minus 1 (0..3 = quadrant 1..4)"),
        Field("parabolic", 5, 1, "interpolation type parabolic (``circular`` is then ignored)"),
        Field("swap", 6, 1, "parabolic: the abscissa is Y, the parabola's axis parallel to X "
                            "(else the abscissa is X, the axis parallel to Y)"),
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
        Field("error", 2, 1, "invalid block data, an arc that left its end quadrant, a "
                             "parabola that passed its end, or START while BUSY (sticky until "
                             "CMD.clear)"),
        Field("overrun", 3, 1, "an FP arrived while one was already held and was lost "
                               "(sticky until CMD.clear)"),
    )),
), doc="Interpolator: linear, circular and parabolic interpolation of one block, step pulses "
       "out.")


def block_registers(block: Block) -> dict[str, int]:
    """The registers that load ``block``, in the order the host writes them (CTRL last; the
    block then runs on CMD.start). Lines leave I and J as they are."""
    values = {"X": block.xe, "Y": block.ye}
    if block.kind is not Kind.LINEAR:
        values |= {"I": block.i, "J": block.j}
    values["CTRL"] = K3701_MAP["CTRL"].encode(
        circular=int(block.kind is Kind.CIRCULAR), cw=int(block.cw), sqrt2=int(block.sqrt2),
        quadrant=block.quadrant - 1, parabolic=int(block.kind is Kind.PARABOLIC),
        swap=int(block.swap))
    return values


class _Phase(enum.Enum, shape=2):
    IDLE = 0
    SETUP = 1
    RUN = 2


#: The datapath of each interpolation type (the type is CTRL.parabolic, else CTRL.circular).
_DATAPATHS: dict[Kind, type[Datapath]] = {Kind.LINEAR: LinearDatapath,
                                          Kind.CIRCULAR: CircularDatapath,
                                          Kind.PARABOLIC: ParabolicDatapath}


def _field(word: Value, field: Field) -> Value:
    """The bits of ``field`` in ``word`` (a slice: cheaper to simulate than Field.decode)."""
    return word[field.offset:field.offset + field.width]


def _select(kind: Value, values: Sequence[ValueLike]) -> Value:
    """``values[kind]``, a fresh expression at each call (see ``K3701.elaborate``)."""
    result = values[0]
    for k, value in enumerate(values[1:], 1):
        result = Mux(kind == k, value, result)
    return result


class K3701(wiring.Component):
    """The KM3701 two-axis interpolator.

    The host loads a block through :data:`K3701_MAP` and writes ``CMD.start``; each feed pulse
    earns step credit and each step emits one-cycle pulses on the axes it moves. Timing is
    that of :class:`hdl.k3701_model.K3701Model` (S is the cycle after the host's write of the
    start command):

    * linear: BUSY and FP intake from S+1; circular: BUSY from S+1, a serial radius check
      until S+``circle_setup``, FP intake from S+1+``circle_setup``; parabolic: the same
      with its setup of ``PARABOLA_SETUP_CYCLES`` (29) cycles and the circular latency;
    * a step's pulses appear exactly ``latency_*`` cycles after the FP that completes its
      credit (2 half-FP per FP; a step costs 2, a diagonal one 3 with sqrt(2) control);
      one FP arriving meanwhile is held, a further one sets OVERRUN and is lost;
    * BUSY falls and ``irq`` rises in the cycle of the final step's pulses.

    Inside, this core runs the block (registers, commands and status, FP intake and credit,
    the step latency and the pulses) and one datapath per interpolation type decides its
    steps (:mod:`hdl.k3701_linear`, :mod:`hdl.k3701_circular`, :mod:`hdl.k3701_parabolic`,
    through the interface of :mod:`hdl.k3701_datapath`). Each step is decided before its FP
    can come: a line's next step in the cycle the current one is output, a circle's first step
    during the radius check and each following one in four pipelined cycles of the current
    step's latency.
    The logic thus works only when there is something to decide, which keeps compiled
    simulation fast; it needs a circular latency of at least 6 cycles.

    Parameters
    ----------
    latency_linear, latency_circular : int
        Cycles from the credit-completing FP to the step pulses (paper: 11 and 21 at 1 MHz);
        2..32 linear, 6..32 circular (also the parabolic latency).
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
        2 and past the running datapath's decision stages; combinational.
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
        for name, value, kind in (("latency_linear", latency_linear, Kind.LINEAR),
                                  ("latency_circular", latency_circular, Kind.CIRCULAR)):
            low = 2 + _DATAPATHS[kind].STAGES
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
        latency = {Kind.LINEAR: self.latency_linear, Kind.CIRCULAR: self.latency_circular,
                   Kind.PARABOLIC: self.latency_circular}
        datapaths = [_DATAPATHS[k]() for k in Kind]
        for k, datapath in zip(Kind, datapaths, strict=True):
            m.submodules[k.name.lower()] = datapath

        phase = Signal(_Phase)
        kind = Signal(range(len(Kind)))  # the running block's type
        sqrt2 = Signal()
        xm = Signal(signed(24))
        ym = Signal(signed(24))
        count = Signal(range(max(latency.values())))
        held = Signal()
        credit = Signal(3)

        word = regs.ctrl.w_data
        # The type of a block starting now.
        new_kind = Mux(word[ctrl.field("parabolic").offset], Kind.PARABOLIC,
                       word[ctrl.field("circular").offset])
        start = regs.cmd.w_stb & regs.cmd.w_data[cmd.field("start").offset]
        m.d.comb += [
            regs.x.r_data.eq(xm),
            regs.y.r_data.eq(ym),
            regs.ctrl.r_data.eq(word),
            regs.status.r_data.eq(Cat(self.busy, self.irq, self.error, self.overrun)),
        ]
        for k, datapath in zip(Kind, datapaths, strict=True):
            running = (phase == _Phase.RUN) & (kind == k)
            block = datapath.block
            m.d.comb += [
                block.xe.eq(regs.x.w_data), block.ye.eq(regs.y.w_data),
                block.i.eq(regs.i.w_data), block.j.eq(regs.j.w_data),
                block.cw.eq(word[ctrl.field("cw").offset]),
                block.quadrant.eq(_field(word, ctrl.field("quadrant"))),
                block.swap.eq(word[ctrl.field("swap").offset]),
                datapath.start.eq(start & (phase == _Phase.IDLE) & (new_kind == k)),
                datapath.advance.eq(running & (count == 1)),
                *(datapath.stage[s].eq(running & (count == latency[k] - 1 - s))
                  for s in range(datapath.STAGES)),
            ]
            if datapath.SETUP:
                m.d.comb += datapath.setup.eq((phase == _Phase.SETUP) & (kind == k))

        def running_step() -> SimpleNamespace:
            """The running block's next step: its datapath's ``step`` members, as fresh
            expressions (see ``answer``)."""
            return SimpleNamespace(**{name: _select(kind, [getattr(d.step, name)
                                                           for d in datapaths])
                                      for name in StepSignature().members})

        def answer(which: Value, port: str, setup: bool) -> Value:
            """A datapath's answer on ``port``, from datapaths with ``SETUP`` == ``setup``
            (else 0), for the type ``which``: a fresh expression at each call, so that it is
            evaluated only where it is used."""
            return _select(which, [getattr(d, port) if d.SETUP is setup else Const(0)
                                   for d in datapaths])

        # --- feed intake: hold one FP while the engine is busy, lose (and flag) a second ---
        engine_busy = (phase == _Phase.SETUP) | ((phase == _Phase.RUN) & (count != 0))

        m.d.sync += [self.x_pos.eq(0), self.x_neg.eq(0), self.y_pos.eq(0), self.y_neg.eq(0)]
        with m.If(regs.cmd.w_stb & regs.cmd.w_data[cmd.field("ack").offset]):
            m.d.sync += self.irq.eq(0)
        with m.If(regs.cmd.w_stb & regs.cmd.w_data[cmd.field("clear").offset]):
            m.d.sync += [self.error.eq(0), self.overrun.eq(0)]
        with m.If(engine_busy & self.fp):
            with m.If(held):
                m.d.sync += self.overrun.eq(1)
            with m.Else():
                m.d.sync += held.eq(1)

        def finish(error: Value) -> None:
            m.d.sync += [phase.eq(_Phase.IDLE), self.busy.eq(0), self.irq.eq(1), held.eq(0),
                         count.eq(0)]
            with m.If(error):
                m.d.sync += self.error.eq(1)

        with m.Switch(phase):
            with m.Case(_Phase.IDLE):
                with m.If(start):
                    # Latch the block (the registers may be rewritten while it runs); the
                    # datapath of its type latches its own part.
                    m.d.sync += [
                        kind.eq(new_kind),
                        sqrt2.eq(word[ctrl.field("sqrt2").offset]),
                        xm.eq(regs.x.w_data), ym.eq(regs.y.w_data),
                        credit.eq(0), held.eq(0), count.eq(0),
                        phase.eq(_select(new_kind, [_Phase.SETUP if d.SETUP else _Phase.RUN
                                                    for d in datapaths])),
                        self.busy.eq(1),
                    ]
                    with m.If(answer(new_kind, "end", setup=False)):
                        finish(answer(new_kind, "error", setup=False))
            with m.Case(_Phase.SETUP):
                with m.If(answer(kind, "end", setup=True)):
                    finish(answer(kind, "error", setup=True))
                with m.Elif(answer(kind, "ready", setup=True)):
                    m.d.sync += phase.eq(_Phase.RUN)
            with m.Case(_Phase.RUN):
                with m.If(count == 0):
                    take = held | self.fp
                    m.d.sync += held.eq(held & self.fp)
                    credit2 = credit + 2
                    cost = Mux(sqrt2 & running_step().diag, 3, 2)
                    with m.If(take):
                        with m.If(credit2 >= cost):
                            m.d.sync += [credit.eq(credit2 - cost),
                                         count.eq(_select(kind, [latency[k] - 1 for k in Kind]))]
                        with m.Else():
                            m.d.sync += credit.eq(credit2)
                with m.Else():
                    m.d.sync += count.eq(count - 1)
                    with m.If(count == 1):
                        step = running_step()
                        dx, dy = moves(step)
                        m.d.sync += [
                            self.x_pos.eq(step.x & ~step.x_neg), self.x_neg.eq(step.x & step.x_neg),
                            self.y_pos.eq(step.y & ~step.y_neg), self.y_neg.eq(step.y & step.y_neg),
                            xm.eq(xm - dx), ym.eq(ym - dy),
                        ]
                        with m.If(step.final):
                            finish(step.error)

        # Idle skipping may run while the count is 0 or at least 2 and past the stages.
        past_stages = _select(kind, [count <= latency[k] - 1 - d.STAGES if d.STAGES else Const(1)
                                     for k, d in zip(Kind, datapaths, strict=True)])
        m.d.comb += self.quiet.eq(~self.fp & ((count == 0) | ((count >= 2) & past_stages)))

        # START while a block runs is refused (and flagged), never obeyed.
        with m.If(start & (phase != _Phase.IDLE)):
            m.d.sync += self.error.eq(1)
        return m
