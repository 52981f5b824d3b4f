"""KM3701 interpolator gateware (SPEC section 3).

The reference model is :mod:`hdl.k3701_model`; this module is tested against it cycle by cycle.
"""

from collections.abc import Sequence
from types import SimpleNamespace

from amaranth.hdl import Cat, Const, Module, Mux, Signal, Value, ValueLike, signed
from amaranth.lib import enum, wiring
from amaranth.lib.wiring import In, Out, connect, flipped

from hdl.hostbus import HostBus, RegisterBank
from hdl.k3701_circular import CircularDatapath
from hdl.k3701_datapath import Datapath, StepSignature, moves
from hdl.k3701_datapath_model import (
    CIRCLE_SETUP_CYCLES,
    LATENCY_CIRCULAR,
    LATENCY_LINEAR,
    PLANES,
    Kind,
)
from hdl.k3701_helix import HelixAxis
from hdl.k3701_latency import StepLatency
from hdl.k3701_linear import LinearDatapath, LinearDatapath3
from hdl.k3701_map import k3701_map
from hdl.k3701_parabolic import ParabolicDatapath
from hdl.observation import Countdown, FreeRunning
from hdl.registers import Field

__all__ = ["K3701"]

class _Phase(enum.Enum, shape=2):
    IDLE = 0
    SETUP = 1
    RUN = 2


#: The datapath of each interpolation type (the type is CTRL.parabolic or CTRL.exponential,
#: else CTRL.circular): the parabolic datapath also runs exponentials (CTRL.exponential).
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
      exponential: likewise with ``EXPONENTIAL_SETUP_CYCLES`` (4);
    * a step's pulses appear exactly ``latency_*`` cycles after the FP that completes its
      credit (2 half-FP per FP; a step costs 2, a diagonal one 3 with sqrt(2) control);
      one FP arriving meanwhile is held, a further one sets OVERRUN and is lost;
    * BUSY falls and ``irq`` rises in the cycle of the final step's pulses.

    Inside, this core runs the block (registers, commands and status, FP intake and credit,
    the pulses), its step latency count times the steps and the datapaths' stages
    (:mod:`hdl.k3701_latency`), and one datapath per interpolation type decides its
    steps (:mod:`hdl.k3701_linear`, :mod:`hdl.k3701_circular`, :mod:`hdl.k3701_parabolic`
    (parabolas and exponentials),
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
        2..32 linear, 6..32 circular (also the parabolic and exponential latency).
    circle_setup : int
        Cycles of the circular radius check; must equal 25 (24 squarer cycles plus the check).
    axes : int
        2 (the paper's chip) or 3: the three-axis build (:data:`K3701_MAP_3`) steps lines in
        X, Y and Z (:class:`hdl.k3701_linear.LinearDatapath3`), routes a block's axes to the
        machine's by CTRL.plane (an arc runs in the plane's two axes) and moves a helix's third
        axis with the arc's steps (:class:`hdl.k3701_helix.HelixAxis`); its FP credit is in
        quarter-FP units (a step moving 1, 2, 3 axes costs 1, 1.5, 1.75 FP with sqrt(2)
        control), the same timing as the two-axis chip for blocks without a third axis.

    Members
    -------
    bus : In(HostBus(k3701_map(axes).addr_width))
        Host interface (see :mod:`hdl.hostbus` for its cycle timing).
    fp : In(1)
        Feed pulse, sampled every cycle; each cycle it is high counts as one FP.
    x_pos, x_neg, y_pos, y_neg : Out(1)
        One-cycle step pulses; a diagonal step pulses both axes in the same cycle.
    z_pos, z_neg : Out(1)
        Three-axis chip only: the Z axis's step pulses, likewise.
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
        The latency count (``latency.count``, of :class:`hdl.k3701_latency.StepLatency`), a
        :class:`hdl.observation.Countdown` that stops before 1.
    """

    #: See "Simulation only" above (names local to the K3701).
    FREE_RUNNING = FreeRunning(countdowns=(Countdown("latency.count", stop=1),), quiet="quiet")

    def __init__(self, *, latency_linear: int = LATENCY_LINEAR,
                 latency_circular: int = LATENCY_CIRCULAR,
                 circle_setup: int = CIRCLE_SETUP_CYCLES, axes: int = 2):
        if axes not in (2, 3):
            raise ValueError(f"axes must be 2 or 3, not {axes!r}")
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
        self.axes = axes
        self.regmap = k3701_map(axes)
        super().__init__({
            "bus": In(HostBus(self.regmap.addr_width)), "fp": In(1),
            **{f"{a}_{d}": Out(1) for a in "xyz"[:axes] for d in ("pos", "neg")},
            "busy": Out(1), "irq": Out(1), "error": Out(1), "overrun": Out(1),
        })
        self.quiet = Signal()

    def elaborate(self, platform) -> Module:
        # Written for compiled simulation (CXXRTL evaluates an expression only when the
        # conditions around it select it, if it feeds one register and no intermediate value
        # is used twice or sign-extended): the heavy logic sits under rare conditions, and
        # multi-use values are registers.
        m = Module()
        m.submodules.regs = regs = RegisterBank(self.regmap)
        connect(m, flipped(self.bus), regs.bus)
        ctrl = self.regmap["CTRL"]
        cmd = self.regmap["CMD"]
        three = self.axes == 3
        # the three-axis build has no parabolic or exponential datapath (see K3701_MAP_3)
        kinds = (Kind.LINEAR, Kind.CIRCULAR) if three else tuple(_DATAPATHS)
        latency = {Kind.LINEAR: self.latency_linear, Kind.CIRCULAR: self.latency_circular,
                   Kind.PARABOLIC: self.latency_circular}
        datapaths = ([LinearDatapath3(), CircularDatapath(axes=3)] if three
                     else [_DATAPATHS[k]() for k in kinds])
        for k, datapath in zip(kinds, datapaths, strict=True):
            m.submodules[k.name.lower()] = datapath

        phase = Signal(_Phase)
        kind = Signal(range(len(_DATAPATHS)))  # the running block's datapath
        sqrt2 = Signal()
        xm = Signal(signed(24))
        ym = Signal(signed(24))
        m.submodules.latency = step_latency = StepLatency(
            [latency[k] for k in kinds], [d.STAGES for d in datapaths])
        count = step_latency.count
        m.d.comb += step_latency.run.eq(phase == _Phase.RUN)
        held = Signal()
        credit = Signal(4 if three else 3)

        word = regs.ctrl.w_data
        # The type of a block starting now.
        new_kind = (word[ctrl.field("circular").offset] if three else
                    Mux(word[ctrl.field("parabolic").offset]
                        | word[ctrl.field("exponential").offset], Kind.PARABOLIC,
                        word[ctrl.field("circular").offset]))
        start = regs.cmd.w_stb & regs.cmd.w_data[cmd.field("start").offset]
        m.d.comb += [
            regs.x.r_data.eq(xm),
            regs.y.r_data.eq(ym),
            regs.ctrl.r_data.eq(word),
            regs.status.r_data.eq(Cat(self.busy, self.irq, self.error, self.overrun)),
        ]
        if three:
            zm = Signal(signed(24))
            plane = Signal(2)
            m.submodules.helix = helix = HelixAxis()
            m.d.comb += [regs.z.r_data.eq(zm), helix.ze.eq(regs.z.w_data),
                         helix.n.eq(regs.h.w_data),
                         helix.start.eq(datapaths[Kind.CIRCULAR].start),
                         helix.advance.eq(datapaths[Kind.CIRCULAR].advance)]
        for i, (k, datapath) in enumerate(zip(kinds, datapaths, strict=True)):
            block = datapath.block
            m.d.comb += [
                block.xe.eq(regs.x.w_data), block.ye.eq(regs.y.w_data),
                block.i.eq(regs.i.w_data), block.j.eq(regs.j.w_data),
                block.cw.eq(word[ctrl.field("cw").offset]),
                block.quadrant.eq(_field(word, ctrl.field("quadrant"))),
                *([block.ze.eq(regs.z.w_data)] if three else
                  [block.swap.eq(word[ctrl.field("swap").offset]), block.e.eq(regs.e.w_data),
                   block.exponential.eq(word[ctrl.field("exponential").offset])]),
                datapath.start.eq(start & (phase == _Phase.IDLE) & (new_kind == k)),
                step_latency.running[i].eq((phase == _Phase.RUN) & (kind == k)),
                datapath.advance.eq(step_latency.advance[i]),
                *([datapath.stage.eq(step_latency.stage[i])] if datapath.STAGES else []),
            ]
            if datapath.SETUP:
                m.d.comb += datapath.setup.eq((phase == _Phase.SETUP) & (kind == k))

        def running_step() -> SimpleNamespace:
            """The running block's next step: its datapath's ``step`` members, as fresh
            expressions (see ``answer``); on the three-axis chip an arc's third axis is the
            helix's."""
            steps = [d.step for d in datapaths]
            if three:
                arc = SimpleNamespace(**{n: getattr(steps[Kind.CIRCULAR], n) for n in
                                         StepSignature(2).members},
                                      z=helix.move, z_neg=helix.neg,
                                      diag3=steps[Kind.CIRCULAR].diag & helix.move)
                arc.diag = arc.diag | helix.move  # an arc step moves one plane axis or two
                steps[Kind.CIRCULAR] = arc
            return SimpleNamespace(**{name: _select(kind, [getattr(st, name) for st in steps])
                                      for name in StepSignature(self.axes).members})

        def answer(which: Value, port: str, setup: bool) -> Value:
            """A datapath's answer on ``port``, from datapaths with ``SETUP`` == ``setup``
            (else 0), for the type ``which``: a fresh expression at each call, so that it is
            evaluated only where it is used."""
            return _select(which, [getattr(d, port) if d.SETUP is setup else Const(0)
                                   for d in datapaths])

        # --- feed intake: hold one FP while the engine is busy, lose (and flag) a second ---
        engine_busy = (phase == _Phase.SETUP) | ((phase == _Phase.RUN) & ~step_latency.zero)

        pulses = [getattr(self, f"{a}_{d}") for a in "xyz"[:self.axes] for d in ("pos", "neg")]
        m.d.sync += [p.eq(0) for p in pulses]
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
            m.d.sync += [phase.eq(_Phase.IDLE), self.busy.eq(0), self.irq.eq(1), held.eq(0)]
            m.d.comb += step_latency.clear.eq(1)
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
                        *([zm.eq(regs.z.w_data),
                           plane.eq(_field(word, ctrl.field("plane")))] if three else []),
                        credit.eq(0), held.eq(0),
                        phase.eq(_select(new_kind, [_Phase.SETUP if d.SETUP else _Phase.RUN
                                                    for d in datapaths])),
                        self.busy.eq(1),
                    ]
                    m.d.comb += step_latency.clear.eq(1)
                    with m.If(answer(new_kind, "end", setup=False)):
                        finish(answer(new_kind, "error", setup=False))
            with m.Case(_Phase.SETUP):
                ready = answer(kind, "ready", setup=True)
                with m.If(answer(kind, "end", setup=True)):
                    finish(answer(kind, "error", setup=True))
                if three:  # a helix of more third-axis moves than arc steps is refused
                    with m.Elif(ready & helix.error):
                        finish(Const(1))
                with m.Elif(ready):
                    m.d.sync += phase.eq(_Phase.RUN)
            with m.Case(_Phase.RUN):
                with m.If(step_latency.zero):
                    take = held | self.fp
                    m.d.sync += held.eq(held & self.fp)
                    if three:
                        credit2 = credit + 4
                        step = running_step()
                        cost = Mux(sqrt2 & step.diag, Mux(step.diag3, 7, 6), 4)
                    else:
                        credit2 = credit + 2
                        cost = Mux(sqrt2 & running_step().diag, 3, 2)
                    with m.If(take):
                        with m.If(credit2 >= cost):
                            m.d.sync += credit.eq(credit2 - cost)
                            m.d.comb += [step_latency.load.eq(1), step_latency.value.eq(
                                _select(kind, [latency[k] - 1 for k in kinds]))]
                        with m.Else():
                            m.d.sync += credit.eq(credit2)
                with m.Else():
                    with m.If(step_latency.last):
                        step = running_step()
                        if three:
                            self._pulses_routed(m, step, plane)
                            dx, dy, dz = moves(step, "xyz")
                            m.d.sync += [xm.eq(xm - dx), ym.eq(ym - dy), zm.eq(zm - dz)]
                        else:
                            dx, dy = moves(step)
                            m.d.sync += [
                                self.x_pos.eq(step.x & ~step.x_neg),
                                self.x_neg.eq(step.x & step.x_neg),
                                self.y_pos.eq(step.y & ~step.y_neg),
                                self.y_neg.eq(step.y & step.y_neg),
                                xm.eq(xm - dx), ym.eq(ym - dy),
                            ]
                        with m.If(step.final):
                            finish(step.error)

        # Idle skipping may run while the count is 0 or at least 2 and past the stages.
        past_stages = _select(kind, [count <= latency[k] - 1 - d.STAGES if d.STAGES else Const(1)
                                     for k, d in zip(kinds, datapaths, strict=True)])
        m.d.comb += self.quiet.eq(~self.fp & ((count == 0) | ((count >= 2) & past_stages)))

        # START while a block runs is refused (and flagged), never obeyed.
        with m.If(start & (phase != _Phase.IDLE)):
            m.d.sync += self.error.eq(1)
        return m

    def _pulses_routed(self, m: Module, step: SimpleNamespace, plane: Signal) -> None:
        """The three-axis chip's step pulses: the block's axes to the machine's, by CTRL.plane
        (:data:`hdl.k3701_datapath_model.PLANES`; code 3 routes as 0)."""
        for code, axes in enumerate((*PLANES, PLANES[0])):
            with m.If(plane == code):
                for block_axis, machine_axis in zip("xyz", axes, strict=True):
                    move = getattr(step, block_axis)
                    neg = getattr(step, f"{block_axis}_neg")
                    out = "xyz"[machine_axis]
                    m.d.sync += [getattr(self, f"{out}_pos").eq(move & ~neg),
                                 getattr(self, f"{out}_neg").eq(move & neg)]
