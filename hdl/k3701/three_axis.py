"""The three-axis K3701: the core with a 3-D linear datapath, the circular one and a helix,
and the two-axis chip's parabolic datapath.

A block is given in its own axes (first, second, third); CTRL.plane routes them to the
machine's X, Y and Z (:data:`k37.hdl.k3701.block.PLANES`). A line moves all three
(:class:`k37.hdl.k3701.datapaths.linear.LinearDatapath3`), an arc runs in the first two and a
helix moves the third with the arc's steps (:class:`k37.hdl.k3701.datapaths.helix.HelixAxis`); a
helix of more third-axis moves than arc steps is refused. A parabola or an exponential (MODE,
the two-axis chip's CTRL.parabolic, swap and exponential) runs in the first two axes
(:class:`k37.hdl.k3701.datapaths.parabolic.ParabolicDatapath`); one with a third coordinate Ze
other than 0 is refused at the end of its setup. The FP credit is in quarter-FP units: a step
moving 1, 2 or 3 axes costs 4, 6 or 7 with sqrt(2) control.
"""

from __future__ import annotations

from collections.abc import Callable

from amaranth.hdl import Module, Mux, Signal, Value, signed
from amaranth.lib import wiring

from k37.hdl.bus.hostbus import RegisterBank
from k37.hdl.bus.registers import Register
from k37.hdl.common.constants import ALL_AXES
from k37.hdl.k3701.block import PLANES, Kind
from k37.hdl.k3701.core import Assignments, Axes, Step, Step3, field_of
from k37.hdl.k3701.datapaths.base import Datapath, moves
from k37.hdl.k3701.datapaths.circular import CircularDatapath
from k37.hdl.k3701.datapaths.helix import HelixAxis
from k37.hdl.k3701.datapaths.linear import LinearDatapath3
from k37.hdl.k3701.datapaths.parabolic import ParabolicDatapath
from k37.hdl.k3701.map import K3701_MAP_3
from k37.hdl.k3701.two_axis import curve_inputs, curve_kind

__all__ = ["ThreeAxes"]

_MODE = K3701_MAP_3["MODE"]


class ThreeAxes(Axes):
    """The three-axis build (:data:`k37.hdl.k3701.map.K3701_MAP_3`)."""

    KINDS = (Kind.LINEAR, Kind.CIRCULAR, Kind.PARABOLIC)
    CREDIT_WIDTH = 4
    STEP = Step3

    # the block's third axis (made by connect): its remaining distance, its plane, whether
    # it is a parabola or an exponential, and an arc's helix
    zm: Signal
    plane: Signal
    curve: Signal
    helix: HelixAxis

    def datapaths(self) -> list[Datapath]:
        return [LinearDatapath3(), CircularDatapath(axes=3), ParabolicDatapath(axes=3)]

    def new_kind(self, regs: RegisterBank, word: Value, ctrl: Register) -> Value:
        return curve_kind(regs.mode.w_data, _MODE, word, ctrl)

    def connect(self, m: Module, regs: RegisterBank, datapaths: list[Datapath]) -> None:
        self.zm = Signal(signed(24))
        zm = self.zm
        self.plane = Signal(2)
        self.curve = Signal()  # the block is a parabola or an exponential
        m.submodules.helix = self.helix = helix = HelixAxis()
        arc = datapaths[Kind.CIRCULAR]
        m.d.comb += [regs.z.r_data.eq(zm), regs.mode.r_data.eq(regs.mode.w_data),
                     helix.ze.eq(regs.z.w_data),
                     helix.n.eq(regs.h.w_data),
                     helix.start.eq(arc.start), helix.advance.eq(arc.advance)]

    def block_inputs(self, block: wiring.PureInterface, regs: RegisterBank, word: Value,
                     ctrl: Register) -> Assignments:
        return [block.ze.eq(regs.z.w_data), *curve_inputs(block, regs, regs.mode.w_data, _MODE)]

    def latch(self, regs: RegisterBank, word: Value, ctrl: Register) -> Assignments:
        return [self.zm.eq(regs.z.w_data), self.plane.eq(field_of(word, ctrl.field("plane"))),
                self.curve.eq(self.new_kind(regs, word, ctrl) == Kind.PARABOLIC)]

    def setup_refusal(self, ready: Value) -> Value:
        # a helix steeper than its arc, a curve with a third coordinate
        return ready & Mux(self.curve, self.zm != 0, self.helix.error)

    def credit(self, credit: Value, sqrt2: Value,
               step: Callable[[], Step]) -> tuple[Value, Value]:
        running = step()
        return credit + 4, Mux(sqrt2 & running.diag, Mux(running.diag3, 7, 6), 4)

    def running_steps(self, ports: list[wiring.PureInterface]) -> list[Step]:
        # an arc's third axis is the helix's; an arc step moves one plane axis or two
        helix = self.helix
        arc = ports[Kind.CIRCULAR]
        return [Step3.of(arc, z=helix.move, z_neg=helix.neg, diag=arc.diag | helix.move,
                         diag3=arc.diag & helix.move) if k == Kind.CIRCULAR else Step3.of(port)
                for k, port in zip(self.KINDS, ports, strict=True)]

    def output(self, m: Module, chip: wiring.Component, step: Step,
               position: tuple[Signal, Signal]) -> None:
        xm, ym = position
        self._route(m, chip, step)
        dx, dy, dz = moves(step, ALL_AXES)
        m.d.sync += [xm.eq(xm - dx), ym.eq(ym - dy), self.zm.eq(self.zm - dz)]

    def _route(self, m: Module, chip: wiring.Component, step: Step) -> None:
        """The step pulses: the block's axes to the machine's, by CTRL.plane (code 3 routes
        as 0)."""
        for code, axes in enumerate((*PLANES, PLANES[0])):
            with m.If(self.plane == code):
                for block_axis, machine_axis in zip(ALL_AXES, axes, strict=True):
                    move = getattr(step, block_axis)
                    neg = getattr(step, f"{block_axis}_neg")
                    out = ALL_AXES[machine_axis]
                    m.d.sync += [getattr(chip, f"{out}_pos").eq(move & ~neg),
                                 getattr(chip, f"{out}_neg").eq(move & neg)]
