"""The K3701's shared core: what runs a block whatever the chip's axes.

The core holds the block's registers, START and BUSY, the feed intake and step credit, the
step latency and the end of a block; its :class:`Axes` composition adds the datapaths and
everything that depends on the number of axes: which datapath a block starts, the block's
registers each datapath reads, the credit a step costs and where a step's pulses go. The
two compositions are :class:`k37.hdl.k3701.two_axis.TwoAxes` (the paper's chip) and
:class:`k37.hdl.k3701.three_axis.ThreeAxes`; :class:`k37.hdl.k3701.chip.K3701` picks one.

Written for compiled simulation (CXXRTL evaluates an expression only when the conditions
around it select it, if it feeds one register and no intermediate value is used twice or
sign-extended): the heavy logic sits under rare conditions, and multi-use values are
registers.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from types import SimpleNamespace
from typing import ClassVar

from amaranth.hdl import Cat, Const, Module, Mux, Signal, Value, ValueLike, signed
from amaranth.lib import enum, wiring
from amaranth.lib.wiring import connect, flipped

from k37.hdl.bus.hostbus import RegisterBank
from k37.hdl.bus.registers import Field, Register
from k37.hdl.common.constants import ALL_AXES
from k37.hdl.k3701.block import Kind
from k37.hdl.k3701.datapaths.base import Datapath, StepSignature
from k37.hdl.k3701.latency import StepLatency

__all__ = ["Axes", "build", "field_of", "select"]


class _Phase(enum.Enum, shape=2):
    IDLE = 0
    SETUP = 1
    RUN = 2


def field_of(word: Value, field: Field) -> Value:
    """The bits of ``field`` in ``word`` (a slice: cheaper to simulate than Field.decode)."""
    return word[field.offset:field.offset + field.width]


def select(kind: Value, values: Sequence[ValueLike]) -> Value:
    """``values[kind]``, a fresh expression at each call (see :func:`build`)."""
    result = values[0]
    for k, value in enumerate(values[1:], 1):
        result = Mux(kind == k, value, result)
    return result


class Axes:
    """What a K3701 build adds to the core: its datapaths and what depends on its axes.

    :func:`build` calls the hooks below in this order while it elaborates the chip; ``chip``
    is the :class:`k37.hdl.k3701.chip.K3701` being built, ``m`` its module, ``regs`` its
    register bank, ``word`` the CTRL register's value and ``ctrl`` CTRL's description.
    """

    #: The interpolation types of this build, in datapath order.
    KINDS: ClassVar[tuple[Kind, ...]]
    #: Bits of the FP credit register.
    CREDIT_WIDTH: ClassVar[int]

    def datapaths(self) -> list[Datapath]:
        """One datapath per kind of :attr:`KINDS`, in that order (built once per elaboration)."""
        raise NotImplementedError

    def new_kind(self, regs: RegisterBank, word: Value, ctrl: Register) -> Value:
        """The type of a block starting now, from CTRL (and the build's own registers)."""
        raise NotImplementedError

    def connect(self, m: Module, regs: RegisterBank, datapaths: list[Datapath]) -> None:
        """The build's own registers and blocks beside the datapaths."""

    def block_inputs(self, block: wiring.PureInterface, regs: RegisterBank, word: Value,
                     ctrl: Register) -> list:
        """The assignments of a datapath's block inputs beyond X, Y, I, J, CW and quadrant."""
        raise NotImplementedError

    def running_step(self, steps: list) -> list:
        """The datapaths' ``step`` members as the core reads them (``steps`` by kind)."""
        return steps

    def latch(self, regs: RegisterBank, word: Value, ctrl: Register) -> list:
        """What the build latches at START beyond the kind, sqrt(2) control and X, Y."""
        return []

    def setup_refusal(self, ready: Value) -> Value | None:
        """A condition that refuses the block when its setup is ready (None: no such)."""
        return None

    def credit(self, credit: Value, sqrt2: Value,
               step: Callable[[], SimpleNamespace]) -> tuple[Value, Value]:
        """The credit after one FP and the cost of the running step (``step()`` gives it,
        fresh expressions at each call)."""
        raise NotImplementedError

    def output(self, m: Module, chip: wiring.Component, step: SimpleNamespace,
               position: tuple[Signal, Signal]) -> None:
        """The step pulses of ``step`` and the remaining distance's update (``position``:
        the core's X and Y registers), at the step's last latency cycle."""
        raise NotImplementedError


def build(chip: wiring.Component, axes: Axes) -> Module:
    """The K3701 ``chip`` elaborated with the composition ``axes``."""
    m = Module()
    m.submodules.regs = regs = RegisterBank(chip.regmap)
    connect(m, flipped(chip.bus), regs.bus)
    ctrl = chip.regmap["CTRL"]
    cmd = chip.regmap["CMD"]
    kinds = axes.KINDS
    latency = {Kind.LINEAR: chip.latency_linear, Kind.CIRCULAR: chip.latency_circular,
               Kind.PARABOLIC: chip.latency_circular}
    datapaths = axes.datapaths()
    for k, datapath in zip(kinds, datapaths, strict=True):
        m.submodules[k.name.lower()] = datapath

    phase = Signal(_Phase)
    kind = Signal(range(Kind.PARABOLIC + 1))  # the running block's datapath
    sqrt2 = Signal()
    xm = Signal(signed(24))
    ym = Signal(signed(24))
    m.submodules.latency = step_latency = StepLatency(
        [latency[k] for k in kinds], [d.STAGES for d in datapaths])
    count = step_latency.count
    m.d.comb += step_latency.run.eq(phase == _Phase.RUN)
    held = Signal()
    credit = Signal(axes.CREDIT_WIDTH)

    word = regs.ctrl.w_data
    new_kind = axes.new_kind(regs, word, ctrl)
    start = regs.cmd.w_stb & regs.cmd.w_data[cmd.field("start").offset]
    m.d.comb += [
        regs.x.r_data.eq(xm),
        regs.y.r_data.eq(ym),
        regs.ctrl.r_data.eq(word),
        regs.status.r_data.eq(Cat(chip.busy, chip.irq, chip.error, chip.overrun)),
    ]
    axes.connect(m, regs, datapaths)
    for i, (k, datapath) in enumerate(zip(kinds, datapaths, strict=True)):
        block = datapath.block
        m.d.comb += [
            block.xe.eq(regs.x.w_data), block.ye.eq(regs.y.w_data),
            block.i.eq(regs.i.w_data), block.j.eq(regs.j.w_data),
            block.cw.eq(word[ctrl.field("cw").offset]),
            block.quadrant.eq(field_of(word, ctrl.field("quadrant"))),
            *axes.block_inputs(block, regs, word, ctrl),
            datapath.start.eq(start & (phase == _Phase.IDLE) & (new_kind == k)),
            step_latency.running[i].eq((phase == _Phase.RUN) & (kind == k)),
            datapath.advance.eq(step_latency.advance[i]),
            *([datapath.stage.eq(step_latency.stage[i])] if datapath.STAGES else []),
        ]
        if datapath.SETUP:
            m.d.comb += datapath.setup.eq((phase == _Phase.SETUP) & (kind == k))

    def running_step() -> SimpleNamespace:
        """The running block's next step: its datapath's ``step`` members, as fresh
        expressions (see ``answer``)."""
        steps = axes.running_step([d.step for d in datapaths])
        return SimpleNamespace(**{name: select(kind, [getattr(st, name) for st in steps])
                                  for name in StepSignature(chip.axes).members})

    def answer(which: Value, port: str, setup: bool) -> Value:
        """A datapath's answer on ``port``, from datapaths with ``SETUP`` == ``setup``
        (else 0), for the type ``which``: a fresh expression at each call, so that it is
        evaluated only where it is used."""
        return select(which, [getattr(d, port) if d.SETUP is setup else Const(0)
                              for d in datapaths])

    # --- feed intake: hold one FP while the engine is busy, lose (and flag) a second ---
    engine_busy = (phase == _Phase.SETUP) | ((phase == _Phase.RUN) & ~step_latency.zero)

    pulses = [getattr(chip, f"{a}_{d}") for a in ALL_AXES[:chip.axes] for d in ("pos", "neg")]
    m.d.sync += [p.eq(0) for p in pulses]
    with m.If(regs.cmd.w_stb & regs.cmd.w_data[cmd.field("ack").offset]):
        m.d.sync += chip.irq.eq(0)
    with m.If(regs.cmd.w_stb & regs.cmd.w_data[cmd.field("clear").offset]):
        m.d.sync += [chip.error.eq(0), chip.overrun.eq(0)]
    with m.If(engine_busy & chip.fp):
        with m.If(held):
            m.d.sync += chip.overrun.eq(1)
        with m.Else():
            m.d.sync += held.eq(1)

    def finish(error: Value) -> None:
        m.d.sync += [phase.eq(_Phase.IDLE), chip.busy.eq(0), chip.irq.eq(1), held.eq(0)]
        m.d.comb += step_latency.clear.eq(1)
        with m.If(error):
            m.d.sync += chip.error.eq(1)

    with m.Switch(phase):
        with m.Case(_Phase.IDLE):
            with m.If(start):
                # Latch the block (the registers may be rewritten while it runs); the
                # datapath of its type latches its own part.
                m.d.sync += [
                    kind.eq(new_kind),
                    sqrt2.eq(word[ctrl.field("sqrt2").offset]),
                    xm.eq(regs.x.w_data), ym.eq(regs.y.w_data),
                    *axes.latch(regs, word, ctrl),
                    credit.eq(0), held.eq(0),
                    phase.eq(select(new_kind, [_Phase.SETUP if d.SETUP else _Phase.RUN
                                               for d in datapaths])),
                    chip.busy.eq(1),
                ]
                m.d.comb += step_latency.clear.eq(1)
                with m.If(answer(new_kind, "end", setup=False)):
                    finish(answer(new_kind, "error", setup=False))
        with m.Case(_Phase.SETUP):
            ready = answer(kind, "ready", setup=True)
            refusal = axes.setup_refusal(ready)
            with m.If(answer(kind, "end", setup=True)):
                finish(answer(kind, "error", setup=True))
            if refusal is not None:
                with m.Elif(refusal):
                    finish(Const(1))
            with m.Elif(ready):
                m.d.sync += phase.eq(_Phase.RUN)
        with m.Case(_Phase.RUN):
            with m.If(step_latency.zero):
                take = held | chip.fp
                m.d.sync += held.eq(held & chip.fp)
                credit2, cost = axes.credit(credit, sqrt2, running_step)
                with m.If(take):
                    with m.If(credit2 >= cost):
                        m.d.sync += credit.eq(credit2 - cost)
                        m.d.comb += [step_latency.load.eq(1), step_latency.value.eq(
                            select(kind, [latency[k] - 1 for k in kinds]))]
                    with m.Else():
                        m.d.sync += credit.eq(credit2)
            with m.Else():
                with m.If(step_latency.last):
                    step = running_step()
                    axes.output(m, chip, step, (xm, ym))
                    with m.If(step.final):
                        finish(step.error)

    # Idle skipping may run while the count is 0 or at least 2 and past the stages.
    past_stages = select(kind, [count <= latency[k] - 1 - d.STAGES if d.STAGES else Const(1)
                                for k, d in zip(kinds, datapaths, strict=True)])
    m.d.comb += chip.quiet.eq(~chip.fp & ((count == 0) | ((count >= 2) & past_stages)))

    # START while a block runs is refused (and flagged), never obeyed.
    with m.If(start & (phase != _Phase.IDLE)):
        m.d.sync += chip.error.eq(1)
    return m
