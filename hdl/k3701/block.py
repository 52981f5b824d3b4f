"""What every path of the K3701's reference model shares (:mod:`k37.hdl.k3701.model.chip`): the
block the host loads (:class:`Block`, its :class:`Kind`), a decided :class:`Step` and its FP cost,
the routing of a three-axis chip's steps by plane, and the chip's constants. It is the model's
side of :mod:`k37.hdl.k3701.datapaths.base`, the interface between the chip's core and its
datapaths. """

from __future__ import annotations

import enum
from dataclasses import dataclass

from k37.hdl.common.constants import PLANE_AXES

__all__ = ["CIRCLE_SETUP_CYCLES", "COORD_INVALID", "COORD_MAX", "EXPONENTIAL_R2_BITS",
           "EXPONENTIAL_SETUP_CYCLES",
           "LATENCY_CIRCULAR", "LATENCY_LINEAR", "MAX_RADIUS_SQUARED", "PARABOLA_SETUP_CYCLES",
           "PLANES", "QUADRANT_SIGNS", "Block", "BlockError", "Kind", "Step", "check_coord",
           "quadrant_of", "route", "step_cost", "wrap"]

#: Largest coordinate magnitude: 2^23 - 1 LSB, a 24-bit register's.
COORD_MAX = (1 << 23) - 1
#: The one 24-bit word no coordinate takes, -2^23 (a block with it is refused).
COORD_INVALID = -(COORD_MAX + 1)
#: Cycles from the FP that completes a step's credit to the step's output pulses.
LATENCY_LINEAR = 11
LATENCY_CIRCULAR = 21
#: Cycles a circular block spends checking its radius (a serial squarer) before it takes FP.
CIRCLE_SETUP_CYCLES = 25
#: Largest valid I^2 + J^2: the digital circle then stays within +-(2^23 - 1).
MAX_RADIUS_SQUARED = (COORD_MAX + 1) * COORD_MAX
#: CTRL.plane code -> the machine axes (0 X, 1 Y, 2 Z) of a block's first, second and third
#: coordinates: G17, G18, G19 (:data:`k37.hdl.common.constants.PLANE_AXES`).
PLANES = tuple(PLANE_AXES.values())
#: Step cost in quarter-FP units on the three-axis chip with sqrt(2) control, by the number of
#: axes a step moves: 1, 1.5 (sqrt 2 = 1.41) and 1.75 (sqrt 3 = 1.73) FP.
_COST_3 = {1: 4, 2: 6, 3: 7}
#: Cycles a parabolic block spends before it takes FP: two serial multipliers (24 cycles) form
#: its coefficients, then four cycles decide its first step.
PARABOLA_SETUP_CYCLES = 29
#: Cycles an exponential block spends before it takes FP: it loads its data, then three
#: cycles decide its first step.
EXPONENTIAL_SETUP_CYCLES = 4
#: Width of an exponential's second digit r2 (two's complement, as the chip's register):
#: within 0..|k|-1 but for what a p step adds (|R| < 2^25) not yet carried.
EXPONENTIAL_R2_BITS = 28


class Kind(enum.IntEnum):
    """Interpolation type (the control word's TYPE field)."""

    LINEAR = 0
    CIRCULAR = 1
    PARABOLIC = 2
    EXPONENTIAL = 3


class BlockError(ValueError):
    """A block the chip refuses (it would set its ERROR status bit and not start)."""


@dataclass(frozen=True)
class Step:
    """One interpolation step: the moves on each block axis (-1, 0, +1)."""

    dx: int
    dy: int
    dz: int = 0

    @property
    def diagonal(self) -> bool:
        return self.dx != 0 and self.dy != 0

    @property
    def moved(self) -> int:
        """How many axes the step moves."""
        return (self.dx != 0) + (self.dy != 0) + (self.dz != 0)


def step_cost(step: Step, sqrt2: bool, axes: int = 2) -> int:
    """A step's cost in credit units: half FP on the two-axis chip (2, or 3 for a diagonal
    with sqrt(2) control), quarter FP on the three-axis one (4; with sqrt(2) control 6 for two
    axes, 7 for three)."""
    if axes == 2:
        return 3 if sqrt2 and step.diagonal else 2
    return _COST_3[step.moved] if sqrt2 else 4


def route(step: Step, plane: int) -> tuple[int, int, int]:
    """The machine's (X, Y, Z) moves of a step in block coordinates, for CTRL.plane code
    ``plane`` (:data:`PLANES`)."""
    moves = [0, 0, 0]
    axes = PLANES[plane] if plane < len(PLANES) else PLANES[0]  # code 3 routes as 0
    for axis, move in zip(axes, (step.dx, step.dy, step.dz), strict=True):
        moves[axis] = move
    return moves[0], moves[1], moves[2]


# Motion signs (dx, dy) inside each quadrant, for CCW and CW.
QUADRANT_SIGNS = {
    False: {1: (-1, 1), 2: (-1, -1), 3: (1, -1), 4: (1, 1)},
    True: {1: (1, -1), 2: (1, 1), 3: (-1, 1), 4: (-1, -1)},
}


def quadrant_of(x: int, y: int, cw: bool) -> int:
    """Quadrant (1-4) of a point relative to the centre, for motion in direction ``cw``.

    A point on an axis belongs to the quadrant the motion is entering: for CCW, (R, 0) is in
    quadrant 1 and (0, R) in quadrant 2; for CW, (R, 0) is in quadrant 4 and (0, R) in 1.
    """
    if x == 0 and y == 0:
        raise BlockError("a point at the centre has no quadrant")
    if not cw:
        if x > 0 and y >= 0:
            return 1
        if x <= 0 and y > 0:
            return 2
        if x < 0 and y <= 0:
            return 3
        return 4
    if x >= 0 and y > 0:
        return 1
    if x < 0 and y >= 0:
        return 2
    if x <= 0 and y < 0:
        return 3
    return 4


@dataclass(frozen=True)
class Block:
    """The data of one block as the host loads it.

    ``xe, ye``: end point relative to the start. ``i, j``: centre relative to the start
    (circular), the point whose tangent is parallel to the chord (parabolic); exponential:
    ``i`` = |k| (k the curve's constant, LSB of the abscissa; ``cw``: k < 0), ``j`` and
    ``frac`` (the register E) its offset c = j - frac / k (:class:`ExponentialPath`).
    ``quadrant``:
    the control word's end-point quadrant (circular only). ``swap``: parabolic: the curve's
    abscissa is Y (the parabola's axis is parallel to X; an exponential in Y, which is a
    logarithm in X), else X. Three-axis chip only:
    ``ze``, the travel along the third axis (a line's, or a helix's along the plane's
    normal); ``plane``, the CTRL.plane code routing the block's axes to the machine's
    (:data:`PLANES`); ``helix_steps``, the arc's step count N, over which a helix spreads its
    ``ze`` (the host's plan gives it: :attr:`Plan.steps`).
    """

    kind: Kind
    xe: int
    ye: int
    i: int = 0
    j: int = 0
    cw: bool = False
    sqrt2: bool = False
    quadrant: int = 1
    swap: bool = False
    ze: int = 0
    plane: int = 0
    helix_steps: int = 0
    frac: int = 0

    @classmethod
    def line(cls, xe: int, ye: int, ze: int = 0, *, sqrt2: bool = False) -> Block:
        return cls(Kind.LINEAR, xe, ye, sqrt2=sqrt2, ze=ze)

    @classmethod
    def arc(cls, xe: int, ye: int, i: int, j: int, *, cw: bool = False, sqrt2: bool = False,
            ze: int = 0, plane: int = 0, helix_steps: int = 0) -> Block:
        """An arc with its end-point quadrant computed from the end point (as the host does)."""
        return cls(Kind.CIRCULAR, xe, ye, i, j, cw, sqrt2, quadrant_of(xe - i, ye - j, cw),
                   ze=ze, plane=plane, helix_steps=helix_steps)

    @classmethod
    def parabola(cls, xe: int, ye: int, i: int, j: int, *, swap: bool = False,
                 sqrt2: bool = False) -> Block:
        """A parabola from the start to (xe, ye) through the point (i, j) (relative to the
        start) where its tangent is parallel to the chord; its axis is parallel to Y, or to X
        with ``swap``."""
        return cls(Kind.PARABOLIC, xe, ye, i, j, sqrt2=sqrt2, swap=swap)

    @classmethod
    def exponential(cls, xe: int, ye: int, k: int, c: int, frac: int, *, swap: bool = False,
                    sqrt2: bool = False) -> Block:
        """An exponential from the start to (xe, ye) of constant ``k`` (signed) and offset
        c = ``c`` + ``frac`` / |k| (:class:`ExponentialPath`: I = |k|, CTRL.cw for k < 0,
        E = -sign(k) ``frac``); with ``swap`` its abscissa is Y (a logarithm as a function of
        X)."""
        return cls(Kind.EXPONENTIAL, xe, ye, abs(k), c, k < 0, sqrt2=sqrt2, swap=swap,
                   frac=frac if k < 0 else -frac)

    @property
    def latency(self) -> int:
        return LATENCY_LINEAR if self.kind is Kind.LINEAR else LATENCY_CIRCULAR

    @property
    def setup_cycles(self) -> int:
        """Cycles from S+1 before the block takes FP (0: none)."""
        return {Kind.CIRCULAR: CIRCLE_SETUP_CYCLES, Kind.PARABOLIC: PARABOLA_SETUP_CYCLES,
                Kind.EXPONENTIAL: EXPONENTIAL_SETUP_CYCLES}.get(self.kind, 0)


def wrap(value: int, bits: int) -> int:
    """``value`` in ``bits``-bit two's complement."""
    half = 1 << (bits - 1)
    return (value + half) % (2 * half) - half


def check_coord(name: str, value: int) -> None:
    if not -COORD_MAX <= value <= COORD_MAX:
        raise BlockError(f"{name} = {value} is outside -(2^23-1)..2^23-1")
