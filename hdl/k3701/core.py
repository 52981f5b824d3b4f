"""The K3701's shared core: what runs a block whatever the chip's axes.

The core (:class:`K3701Core`) holds the block's registers, START and BUSY, the feed intake and
step credit, the step latency and the end of a block; its :class:`Axes` composition adds the
datapaths and everything that depends on the number of axes: which datapath a block starts,
the block's registers each datapath reads, the credit a step costs and where a step's pulses
go. The two compositions are :class:`k37.hdl.k3701.two_axis.TwoAxes` (the paper's chip) and
:class:`k37.hdl.k3701.three_axis.ThreeAxes`; :class:`k37.hdl.k3701.chip.K3701` picks one. The
core reads a datapath's step as a :class:`Step` (:class:`Step3` on three axes).

Written for compiled simulation (CXXRTL evaluates an expression only when the conditions
around it select it, if it feeds one register and no intermediate value is used twice or
sign-extended): the heavy logic sits under rare conditions, and multi-use values are
registers.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass, fields
from typing import Any, ClassVar, Self

from amaranth.hdl import Cat, Const, Module, Mux, Signal, Value, ValueLike, signed
from amaranth.lib import enum, wiring
from amaranth.lib.wiring import connect, flipped

from k37.hdl.bus.hostbus import RegisterBank
from k37.hdl.bus.registers import Field, Register
from k37.hdl.common.constants import ALL_AXES
from k37.hdl.k3701.block import Kind
from k37.hdl.k3701.datapaths.base import Datapath
from k37.hdl.k3701.latency import StepLatency

__all__ = ["Assignments", "Axes", "K3701Core", "Step", "Step3", "field_of", "select"]

#: Amaranth assignments (the results of ``Value.eq``, which Amaranth gives no public type).
Assignments = list[Any]


class _Phase(enum.Enum, shape=2):
    IDLE = 0
    SETUP = 1
    RUN = 2


def field_of(word: Value, field: Field) -> Value:
    """The bits of ``field`` in ``word`` (a slice: cheaper to simulate than Field.decode)."""
    return word[field.offset:field.offset + field.width]


def select(kind: Value, values: Sequence[ValueLike]) -> Value:
    """``values[kind]``, a fresh expression at each call (see :meth:`K3701Core.answer`)."""
    result = values[0]
    for k, value in enumerate(values[1:], 1):
        result = Mux(kind == k, value, result)
    return result


@dataclass(frozen=True)
class Step:
    """A step as the core reads it: the members of a two-axis
    :class:`k37.hdl.k3701.datapaths.base.StepSignature`, one Amaranth value each."""

    x: Value
    x_neg: Value
    y: Value
    y_neg: Value
    diag: Value
    final: Value
    error: Value

    @classmethod
    def of(cls, port: wiring.PureInterface, **given: Value) -> Self:
        """The step a datapath's ``step`` port drives, with the members ``given`` instead."""
        return cls(**{f.name: given[f.name] if f.name in given else getattr(port, f.name)
                      for f in fields(cls)})

    @classmethod
    def select(cls, kind: Value, steps: Sequence[Self]) -> Self:
        """``steps[kind]``, member by member (fresh expressions: see :func:`select`)."""
        return cls(**{f.name: select(kind, [getattr(step, f.name) for step in steps])
                      for f in fields(cls)})


@dataclass(frozen=True)
class Step3(Step):
    """A step of the three-axis chip: :class:`Step` and the third axis (``diag`` is then a
    move of any two axes or more, ``diag3`` one of all three)."""

    z: Value
    z_neg: Value
    diag3: Value


class Axes(ABC):
    """What a K3701 build adds to the core: its datapaths and what depends on its axes.

    :meth:`K3701Core.elaborate` calls the hooks below while it elaborates the chip, in the
    order in which they are listed here; ``m`` is the chip's module, ``regs`` its register
    bank, ``word`` the CTRL register's value and ``ctrl`` CTRL's description.
    """

    #: The interpolation types of this build, in datapath order.
    KINDS: ClassVar[tuple[Kind, ...]]
    #: Bits of the FP credit register.
    CREDIT_WIDTH: ClassVar[int]
    #: The type of this build's steps.
    STEP: ClassVar[type[Step]]

    @abstractmethod
    def datapaths(self) -> list[Datapath]:
        """One datapath per kind of :attr:`KINDS`, in that order (built once per elaboration)."""

    @abstractmethod
    def new_kind(self, regs: RegisterBank, word: Value, ctrl: Register) -> Value:
        """The type of a block starting now, from CTRL (and the build's own registers)."""

    def connect(self, m: Module, regs: RegisterBank,  # noqa: B027 (optional: none by default)
                datapaths: list[Datapath]) -> None:
        """The build's own registers and blocks beside the datapaths."""

    @abstractmethod
    def block_inputs(self, block: wiring.PureInterface, regs: RegisterBank, word: Value,
                     ctrl: Register) -> Assignments:
        """The assignments of a datapath's block inputs beyond X, Y, I, J, CW and quadrant."""

    def latch(self, regs: RegisterBank, word: Value, ctrl: Register) -> Assignments:
        """What the build latches at START beyond the kind, sqrt(2) control and X, Y."""
        return []

    def setup_refusal(self, ready: Value) -> Value | None:
        """A condition that refuses the block when its setup is ready (None: no such)."""
        return None

    @abstractmethod
    def credit(self, credit: Value, sqrt2: Value,
               step: Callable[[], Step]) -> tuple[Value, Value]:
        """The credit after one FP and the cost of the running step (``step()`` gives it,
        fresh expressions at each call)."""

    def running_steps(self, ports: list[wiring.PureInterface]) -> list[Step]:
        """The datapaths' ``step`` ports (by kind) as the core reads them."""
        return [self.STEP.of(port) for port in ports]

    @abstractmethod
    def output(self, m: Module, chip: wiring.Component, step: Step,
               position: tuple[Signal, Signal]) -> None:
        """The step pulses of ``step`` and the remaining distance's update (``position``:
        the core's X and Y registers), at the step's last latency cycle."""


class K3701Core:
    """The K3701 ``chip`` (a :class:`k37.hdl.k3701.chip.K3701`) elaborated with the
    composition ``axes``: :meth:`elaborate` runs its steps in order.

    Cycles are named as in :class:`k37.hdl.k3701.datapaths.base.DatapathSignature`: S is the
    cycle in which the host writes CMD.start, a step's credit completes with an FP in C and
    its pulses come out in C+L (L the latency of the block's type).
    """

    regs: RegisterBank
    datapaths: list[Datapath]
    phase: Signal
    kind: Signal
    sqrt2: Signal
    xm: Signal
    ym: Signal
    held: Signal
    credit: Signal
    step_latency: StepLatency
    word: Value
    new_kind: Value
    start: Value

    def __init__(self, chip: wiring.Component, axes: Axes) -> None:
        self.chip = chip
        self.axes = axes
        self.m = Module()
        self.ctrl = chip.regmap["CTRL"]
        self.cmd = chip.regmap["CMD"]
        self.kinds = axes.KINDS
        self.latency = {Kind.LINEAR: chip.latency_linear, Kind.CIRCULAR: chip.latency_circular,
                        Kind.PARABOLIC: chip.latency_circular}

    def elaborate(self) -> Module:
        """The chip's module: the steps of the core, in the order in which they call the
        hooks of :class:`Axes`."""
        m = self.m
        self.add_register_bank()
        self.add_datapaths()           # Axes.datapaths
        self.add_state()
        self.read_registers()          # Axes.new_kind
        self.drive_datapaths()         # Axes.connect, Axes.block_inputs
        self.obey_commands()
        self.hold_feed()
        with m.Switch(self.phase):
            with m.Case(_Phase.IDLE):
                self.start_block()     # Axes.latch
            with m.Case(_Phase.SETUP):
                self.set_up()          # Axes.setup_refusal
            with m.Case(_Phase.RUN):
                with m.If(self.step_latency.zero):
                    self.earn_credit()  # Axes.credit, Axes.running_steps
                with m.Else():
                    self.output_step()  # Axes.running_steps, Axes.output
        self.report_quiet()
        self.refuse_start()
        return m

    def add_register_bank(self) -> None:
        """The chip's registers on its host bus (the timing of :mod:`k37.hdl.bus.hostbus`)."""
        self.m.submodules.regs = self.regs = RegisterBank(self.chip.regmap)
        connect(self.m, flipped(self.chip.bus), self.regs.bus)

    def add_datapaths(self) -> None:
        """The composition's datapaths, one submodule per interpolation type."""
        self.datapaths = self.axes.datapaths()
        for k, datapath in zip(self.kinds, self.datapaths, strict=True):
            self.m.submodules[k.name.lower()] = datapath

    def add_state(self) -> None:
        """The running block's registers (its phase, type, sqrt(2) control, remaining X and
        Y, the held FP and the credit) and the step latency count, which runs in the run
        phase."""
        self.phase = Signal(_Phase)
        self.kind = Signal(range(Kind.PARABOLIC + 1))  # the running block's datapath
        self.sqrt2 = Signal()
        self.xm = Signal(signed(24))
        self.ym = Signal(signed(24))
        self.m.submodules.latency = self.step_latency = StepLatency(
            [self.latency[k] for k in self.kinds], [d.STAGES for d in self.datapaths])
        self.m.d.comb += self.step_latency.run.eq(self.phase == _Phase.RUN)
        self.held = Signal()
        self.credit = Signal(self.axes.CREDIT_WIDTH)

    def read_registers(self) -> None:
        """START and the type of the block it starts, decoded in S from the host's writes;
        what the host reads back, in every cycle: X and Y (the running block's remaining
        distance), CTRL and STATUS."""
        regs, chip = self.regs, self.chip
        self.word = regs.ctrl.w_data
        self.new_kind = self.axes.new_kind(regs, self.word, self.ctrl)
        self.start = regs.cmd.w_stb & regs.cmd.w_data[self.cmd.field("start").offset]
        self.m.d.comb += [
            regs.x.r_data.eq(self.xm),
            regs.y.r_data.eq(self.ym),
            regs.ctrl.r_data.eq(self.word),
            regs.status.r_data.eq(Cat(chip.busy, chip.irq, chip.error, chip.overrun)),
        ]

    def drive_datapaths(self) -> None:
        """The composition's own blocks, then each datapath's inputs: the block (valid in S),
        its start in S, its setup phase from S+1, its strobes from the step latency."""
        m, regs, word, ctrl, step_latency = (self.m, self.regs, self.word, self.ctrl,
                                             self.step_latency)
        self.axes.connect(m, regs, self.datapaths)
        for i, (k, datapath) in enumerate(zip(self.kinds, self.datapaths, strict=True)):
            block = datapath.block
            m.d.comb += [
                block.xe.eq(regs.x.w_data), block.ye.eq(regs.y.w_data),
                block.i.eq(regs.i.w_data), block.j.eq(regs.j.w_data),
                block.cw.eq(word[ctrl.field("cw").offset]),
                block.quadrant.eq(field_of(word, ctrl.field("quadrant"))),
                *self.axes.block_inputs(block, regs, word, ctrl),
                datapath.start.eq(self.start & (self.phase == _Phase.IDLE)
                                  & (self.new_kind == k)),
                step_latency.running[i].eq((self.phase == _Phase.RUN) & (self.kind == k)),
                datapath.advance.eq(step_latency.advance[i]),
                *([datapath.stage.eq(step_latency.stage[i])] if datapath.STAGES else []),
            ]
            if datapath.SETUP:
                m.d.comb += datapath.setup.eq((self.phase == _Phase.SETUP) & (self.kind == k))

    def obey_commands(self) -> None:
        """The step pulses' default (low: a pulse lasts one cycle) and CMD.ack and CMD.clear,
        which take effect in the cycle after the host's write."""
        m, chip, cmd, regs = self.m, self.chip, self.cmd, self.regs
        pulses = [getattr(chip, f"{a}_{d}") for a in ALL_AXES[:chip.axes] for d in ("pos", "neg")]
        m.d.sync += [p.eq(0) for p in pulses]
        with m.If(regs.cmd.w_stb & regs.cmd.w_data[cmd.field("ack").offset]):
            m.d.sync += chip.irq.eq(0)
        with m.If(regs.cmd.w_stb & regs.cmd.w_data[cmd.field("clear").offset]):
            m.d.sync += [chip.error.eq(0), chip.overrun.eq(0)]

    def hold_feed(self) -> None:
        """The feed intake: an FP coming while the engine is busy (in setup, or counting a
        step's latency) is held, a second one sets OVERRUN in the next cycle and is lost."""
        m, chip = self.m, self.chip
        engine_busy = (self.phase == _Phase.SETUP) | ((self.phase == _Phase.RUN)
                                                      & ~self.step_latency.zero)
        with m.If(engine_busy & chip.fp):
            with m.If(self.held):
                m.d.sync += chip.overrun.eq(1)
            with m.Else():
                m.d.sync += self.held.eq(1)

    def start_block(self) -> None:
        """Idle, START in S: latch the block (the registers may be rewritten while it runs;
        the datapath of its type latches its own part) and raise BUSY from S+1, in the setup
        or the run phase; a block its datapath ends at once ends in S."""
        m, regs, word, ctrl = self.m, self.regs, self.word, self.ctrl
        with m.If(self.start):
            m.d.sync += [
                self.kind.eq(self.new_kind),
                self.sqrt2.eq(word[ctrl.field("sqrt2").offset]),
                self.xm.eq(regs.x.w_data), self.ym.eq(regs.y.w_data),
                *self.axes.latch(regs, word, ctrl),
                self.credit.eq(0), self.held.eq(0),
                self.phase.eq(select(self.new_kind, [_Phase.SETUP if d.SETUP else _Phase.RUN
                                                     for d in self.datapaths])),
                self.chip.busy.eq(1),
            ]
            m.d.comb += self.step_latency.clear.eq(1)
            with m.If(self.answer(self.new_kind, "end", setup=False)):
                self.finish(self.answer(self.new_kind, "error", setup=False))

    def set_up(self) -> None:
        """The setup phase, from S+1: the block ends when its datapath ends or the
        composition refuses it, else runs from the cycle after its datapath is ready."""
        m = self.m
        ready = self.answer(self.kind, "ready", setup=True)
        refusal = self.axes.setup_refusal(ready)
        with m.If(self.answer(self.kind, "end", setup=True)):
            self.finish(self.answer(self.kind, "error", setup=True))
        if refusal is not None:
            with m.Elif(refusal):
                self.finish(Const(1))
        with m.Elif(ready):
            m.d.sync += self.phase.eq(_Phase.RUN)

    def earn_credit(self) -> None:
        """The run phase, while the latency count is 0: an FP (or the held one) in C earns
        credit; when the credit covers the running step's cost, the step is paid for and its
        latency count loaded (L - 1 in C+1)."""
        m, chip, step_latency = self.m, self.chip, self.step_latency
        take = self.held | chip.fp
        m.d.sync += self.held.eq(self.held & chip.fp)
        credit2, cost = self.axes.credit(self.credit, self.sqrt2, self.running_step)
        with m.If(take):
            with m.If(credit2 >= cost):
                m.d.sync += self.credit.eq(credit2 - cost)
                m.d.comb += [step_latency.load.eq(1), step_latency.value.eq(
                    select(self.kind, [self.latency[k] - 1 for k in self.kinds]))]
            with m.Else():
                m.d.sync += self.credit.eq(credit2)

    def output_step(self) -> None:
        """The run phase, at the step's last latency cycle C+L-1: its pulses and the
        remaining distance's update in C+L, and the block's end with a final step (BUSY
        falls and the interrupt rises in C+L)."""
        with self.m.If(self.step_latency.last):
            step = self.running_step()
            self.axes.output(self.m, self.chip, step, (self.xm, self.ym))
            with self.m.If(step.final):
                self.finish(step.error)

    def report_quiet(self) -> None:
        """The chip's ``quiet`` (combinational): idle skipping may run while no FP comes and
        the count is 0, or at least 2 and past the running datapath's stages."""
        count = self.step_latency.count
        past_stages = select(self.kind, [count <= self.latency[k] - 1 - d.STAGES
                                         if d.STAGES else Const(1)
                                         for k, d in zip(self.kinds, self.datapaths,
                                                         strict=True)])
        self.m.d.comb += self.chip.quiet.eq(
            ~self.chip.fp & ((count == 0) | ((count >= 2) & past_stages)))

    def refuse_start(self) -> None:
        """START while a block runs is refused (ERROR from the next cycle), never obeyed."""
        with self.m.If(self.start & (self.phase != _Phase.IDLE)):
            self.m.d.sync += self.chip.error.eq(1)

    def finish(self, error: Value) -> None:
        """End the block in this cycle: idle, BUSY low and the interrupt high from the next
        one (ERROR too with ``error``); the latency count clears."""
        m = self.m
        m.d.sync += [self.phase.eq(_Phase.IDLE), self.chip.busy.eq(0), self.chip.irq.eq(1),
                     self.held.eq(0)]
        m.d.comb += self.step_latency.clear.eq(1)
        with m.If(error):
            m.d.sync += self.chip.error.eq(1)

    def running_step(self) -> Step:
        """The running block's next step, as fresh expressions (see :meth:`answer`)."""
        steps = self.axes.running_steps([d.step for d in self.datapaths])
        return self.axes.STEP.select(self.kind, steps)

    def answer(self, which: Value, port: str, setup: bool) -> Value:
        """A datapath's answer on ``port``, from datapaths with ``SETUP`` == ``setup``
        (else 0), for the type ``which``: a fresh expression at each call, so that it is
        evaluated only where it is used."""
        return select(which, [getattr(d, port) if d.SETUP is setup else Const(0)
                              for d in self.datapaths])
