"""The paper's two-axis K3701: the core with the linear, circular and parabolic datapaths.

A block moves X and Y; CTRL.parabolic or CTRL.exponential runs the parabolic datapath (which
also draws exponentials), else CTRL.circular picks the circular or the linear one
(:func:`curve_kind`; the three-axis chip reads the same modes from its MODE register). The FP
credit is in half-FP units: a step costs 2, a diagonal one 3 with sqrt(2) control.
"""

from __future__ import annotations

from collections.abc import Callable

from amaranth.hdl import Module, Mux, Signal, Value
from amaranth.lib import wiring

from k37.hdl.bus.hostbus import RegisterBank
from k37.hdl.bus.registers import Register
from k37.hdl.k3701.block import Kind
from k37.hdl.k3701.core import Assignments, Axes, Step
from k37.hdl.k3701.datapaths.base import Datapath, moves
from k37.hdl.k3701.datapaths.circular import CircularDatapath
from k37.hdl.k3701.datapaths.linear import LinearDatapath
from k37.hdl.k3701.datapaths.parabolic import ParabolicDatapath

__all__ = ["DATAPATHS", "TwoAxes", "curve_inputs", "curve_kind"]

#: The datapath of each interpolation type (the type is CTRL.parabolic or CTRL.exponential,
#: else CTRL.circular): the parabolic datapath also runs exponentials (CTRL.exponential).
DATAPATHS: dict[Kind, type[Datapath]] = {Kind.LINEAR: LinearDatapath,
                                         Kind.CIRCULAR: CircularDatapath,
                                         Kind.PARABOLIC: ParabolicDatapath}


def curve_kind(modes: Value, where: Register, word: Value, ctrl: Register) -> Value:
    """The type of a block starting now: parabolic (which runs exponentials too) if the curve
    modes ``modes`` (the register ``where`` describes) name one, else circular or linear by
    CTRL's value ``word``."""
    return Mux(modes[where.field("parabolic").offset] | modes[where.field("exponential").offset],
               Kind.PARABOLIC, word[ctrl.field("circular").offset])


def curve_inputs(block: wiring.PureInterface, regs: RegisterBank, modes: Value,
                 where: Register) -> Assignments:
    """The parabolic datapath's block inputs beyond the common ones, from the curve modes
    ``modes`` (the register ``where`` describes) and E."""
    return [block.swap.eq(modes[where.field("swap").offset]), block.e.eq(regs.e.w_data),
            block.exponential.eq(modes[where.field("exponential").offset])]


class TwoAxes(Axes):
    """The two-axis build (:data:`k37.hdl.k3701.map.K3701_MAP`)."""

    KINDS = tuple(DATAPATHS)
    CREDIT_WIDTH = 3
    STEP = Step

    def datapaths(self) -> list[Datapath]:
        return [DATAPATHS[k]() for k in self.KINDS]

    def new_kind(self, regs: RegisterBank, word: Value, ctrl: Register) -> Value:
        return curve_kind(word, ctrl, word, ctrl)

    def block_inputs(self, block: wiring.PureInterface, regs: RegisterBank, word: Value,
                     ctrl: Register) -> Assignments:
        return curve_inputs(block, regs, word, ctrl)

    def credit(self, credit: Value, sqrt2: Value,
               step: Callable[[], Step]) -> tuple[Value, Value]:
        return credit + 2, Mux(sqrt2 & step().diag, 3, 2)

    def output(self, m: Module, chip: wiring.Component, step: Step,
               position: tuple[Signal, Signal]) -> None:
        xm, ym = position
        dx, dy = moves(step)
        m.d.sync += [
            chip.x_pos.eq(step.x & ~step.x_neg),
            chip.x_neg.eq(step.x & step.x_neg),
            chip.y_pos.eq(step.y & ~step.y_neg),
            chip.y_neg.eq(step.y & step.y_neg),
            xm.eq(xm - dx), ym.eq(ym - dy),
        ]
