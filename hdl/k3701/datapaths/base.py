"""The interface between the K3701's core and its interpolation datapaths.

The core (:class:`k37.hdl.k3701.chip.K3701`) runs a block: the host bus, START, BUSY, the feed
intake and step credit, the step latency and the step pulses. A datapath (one per interpolation
type: :class:`k37.hdl.k3701.datapaths.linear.LinearDatapath`,
:class:`k37.hdl.k3701.datapaths.circular.CircularDatapath`,
:class:`k37.hdl.k3701.datapaths.parabolic.ParabolicDatapath`, which also runs exponentials) decides
the steps: it loads the block, answers with the step to take next, and decides the one after when
the core takes it. A new interpolation type is one more :class:`Datapath`. """

from __future__ import annotations

import operator
from collections.abc import Iterable
from functools import reduce
from typing import Any, ClassVar

from amaranth.hdl import Mux, Value, signed
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from k37.hdl.common.constants import ALL_AXES
from k37.hdl.k3701.block import COORD_INVALID

__all__ = ["BlockSignature", "Datapath", "DatapathSignature", "StepSignature", "frame_step",
           "magnitude", "moves", "refused", "shorter"]


def magnitude(v: Value) -> Value:
    """|v|, one bit wider than ``v`` (signed), so that the most negative value fits."""
    return Mux(v < 0, -v, v)


def refused(block: wiring.PureInterface, *names: str) -> Value:
    """Any of the coordinates ``names`` of ``block`` (a :class:`BlockSignature`) is -2^23,
    outside the chip's range."""
    return reduce(operator.or_, (getattr(block, name) == COORD_INVALID for name in names))


def moves(step: Any, axes: Iterable[str] = ALL_AXES[:2]) -> tuple[Value, ...]:
    """The moves (-1, 0 or +1) of ``step`` (with the members of a :class:`StepSignature`) on
    its ``axes``."""
    return tuple(Mux(getattr(step, a), Mux(getattr(step, f"{a}_neg"), -1, 1), 0) for a in axes)


def frame_step(step: Any, *, swap: Value, su_neg: Value, sv_neg: Value, long_p: Value,
               diag: Value, final: Value, error: Value) -> list[Any]:
    """Drive ``step`` (a :class:`StepSignature` port) with a step decided in a curve's own
    frame: the abscissa p is X (Y with ``swap``), moving towards negative with ``su_neg``,
    the ordinate v the other axis, moving towards negative with ``sv_neg``; the long axis is
    p with ``long_p``, and ``diag`` moves both. Returns the assignments (comb)."""
    p_moves = long_p | diag
    v_moves = ~long_p | diag
    return [step.x.eq(Mux(swap, v_moves, p_moves)), step.x_neg.eq(Mux(swap, sv_neg, su_neg)),
            step.y.eq(Mux(swap, p_moves, v_moves)), step.y_neg.eq(Mux(swap, su_neg, sv_neg)),
            step.diag.eq(diag), step.final.eq(final), step.error.eq(error)]


def shorter(d1: Value, d2: Value, up: Value) -> Value:
    """|d2| < |d1|, for d2 = d1 + t with t never 0, positive with ``up``: exactly when
    t (d1 + d2) < 0 (one adder, no magnitudes)."""
    total = d1 + d2
    return (total != 0) & ((total < 0) == up)


class BlockSignature(wiring.Signature):
    """A block as the host loaded it (the K3701's X, Y, I, J and CTRL registers), as the
    core drives it.

    Members
    -------
    xe, ye : Out(signed(24))
        End point relative to the start.
    i, j : Out(signed(24))
        Circle centre relative to the start; parabolic: the point whose tangent is parallel
        to the chord.
    cw : Out(1)
        Circular direction: 0 CCW, 1 CW; exponential: the constant is negative.
    quadrant : Out(2)
        Circular end-point quadrant code (0..3 = quadrant 1..4).
    swap : Out(1)
        Parabolic, exponential: the curve's abscissa is Y (else X).
    exponential, e : Out(1), Out(signed(24))
        The block is an exponential (of the parabolic datapath's type); the fraction of its
        offset (see the register E).
    ze : Out(signed(24))
        Three-axis chip only (``axes=3``): the end point's third coordinate (lines).
    """

    def __init__(self, axes: int = 2) -> None:
        members = {"xe": Out(signed(24)), "ye": Out(signed(24)), "i": Out(signed(24)),
                   "j": Out(signed(24)), "cw": Out(1), "quadrant": Out(2), "swap": Out(1),
                   "exponential": Out(1), "e": Out(signed(24))}
        if axes == 3:
            members["ze"] = Out(signed(24))
        super().__init__(members)


class StepSignature(wiring.Signature):
    """A decided step, as its datapath drives it: the axes it moves, in which direction, and
    whether it ends the block.

    Members
    -------
    x, y : Out(1)
        The axis moves.
    x_neg, y_neg : Out(1)
        ... in the negative direction (meaningful with ``x``, ``y``).
    diag : Out(1)
        Both axes move (``x & y``): with sqrt(2) control the step costs 1.5 FP.
    final : Out(1)
        The block ends with this step.
    error : Out(1)
        ... with ERROR (meaningful with ``final``).
    z, z_neg, diag3 : Out(1)
        Three-axis chip only: the third axis's move, and all three axes move (``diag`` is
        then any two or more; with sqrt(2) control such a step costs 1.75 FP, and 1.5 with
        two).
    """

    def __init__(self, axes: int = 2) -> None:
        names = ("x", "x_neg", "y", "y_neg", "diag", "final", "error")
        if axes == 3:
            names += ("z", "z_neg", "diag3")
        super().__init__({name: Out(1) for name in names})


class DatapathSignature(wiring.Signature):
    """The ports of a datapath (its own view: In from the core, Out to it).

    S is the start cycle (the core sees the host's START in it). A block of a type without
    setup runs from S+1; one with setup first spends as many cycles as its datapath needs
    from S+1 (the circle's radius check), then runs. While it runs, each step's credit
    completes with an FP in some cycle C, the step's pulses come out in C+L (L the type's
    latency), and the next step's credit may complete from C+L on.

    Members
    -------
    start : In(1)
        High in S when the block is of this datapath's type.
    block : In(BlockSignature())
        The block's data, valid with ``start``.
    setup : In(1)
        High in each cycle of this datapath's setup phase, from S+1 to the cycle in which
        ``ready`` or ``end`` is high (only for a datapath with ``SETUP``).
    stage : In(stages)
        Bit k high in cycle C+1+k of a step of this datapath's block: the cycles in which
        it decides the next step (all before ``advance``: L >= 2 + ``stages``).
    advance : In(1)
        High in C+L-1, the cycle in which the core takes the step in ``step`` (its pulses
        show in C+L); from C+L ``step`` holds the next step (unless this one was ``final``).
    ready : Out(1)
        Combinational, read in setup cycles: the setup is over; the run phase starts in the
        next cycle, with the first step in ``step``.
    end : Out(1)
        Combinational, read in S without ``SETUP`` and in setup cycles with it: the block
        ends in this cycle without a step (BUSY falls, or never rises when in S; the
        interrupt rises).
    error : Out(1)
        Combinational, with ``end``: the block is refused (the chip sets ERROR).
    step : Out(StepSignature())
        The step to take next, read by the core in the run phase: its moves (``diag`` in the
        cycle its credit completes, all with ``advance``) from the run phase's first cycle
        or the cycle after the previous ``advance``; ``final`` and ``error`` by ``advance``
        (they may be decided in the stages).
    """

    def __init__(self, stages: int, axes: int = 2):
        super().__init__({
            "start": In(1), "block": In(BlockSignature(axes)), "setup": In(1),
            "stage": In(stages), "advance": In(1),
            "ready": Out(1), "end": Out(1), "error": Out(1),
            "step": Out(StepSignature(axes)),
        })


class Datapath(wiring.Component):
    """A K3701 interpolation datapath: a :class:`DatapathSignature` with ``STAGES`` stages.

    ``SETUP``: whether its blocks have a setup phase. ``STAGES``: how many cycles of a
    step's latency it needs to decide the next step (0: it decides it in the cycle the step
    is output). ``axes``: the chip's axis count (2 or 3), which decides the signature.
    """

    SETUP: ClassVar[bool] = False
    STAGES: ClassVar[int] = 0

    def __init__(self, axes: int = 2) -> None:
        self.axes = axes
        super().__init__(DatapathSignature(self.STAGES, axes))
