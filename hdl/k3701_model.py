"""Reference model of the KM3701 interpolator (SPEC section 3), in plain Python.

Two layers:

* :class:`LinearPath` and :class:`CircularPath` state the interpolation algorithms step by
  step, with no notion of time. :func:`plan` runs a whole block through them and is the
  exact FP-count calculator the firmware model uses.
* :class:`K3701Model` adds the chip's timing, cycle by cycle: BUSY, the step latency, the FP
  credit in half-FP units (quarter-FP units on the three-axis chip), the one-FP hold and the
  overrun bit. The gateware (:mod:`hdl.k3701`) is tested against it cycle by cycle.

The three-axis K3701 (``axes=3``) takes a block in its own coordinates (first, second,
third): a line moves all three (:class:`LinearPath` steps the longest of the three), an arc
runs in the first two and a helix moves the third, the plane's normal, with the arc
(:class:`HelixPath`); ``Block.plane`` routes the three to the machine's X, Y and Z
(:func:`route`).
"""

from __future__ import annotations

import enum
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, replace

__all__ = [
    "CIRCLE_SETUP_CYCLES",
    "COORD_MAX",
    "EXPONENTIAL_R2_BITS",
    "EXPONENTIAL_SETUP_CYCLES",
    "LATENCY_CIRCULAR",
    "LATENCY_LINEAR",
    "MAX_RADIUS_SQUARED",
    "PARABOLA_SETUP_CYCLES",
    "PLANES",
    "Block",
    "BlockError",
    "CircularPath",
    "ExponentialPath",
    "HelixPath",
    "K3701Model",
    "K3701Outputs",
    "Kind",
    "LinearPath",
    "ParabolicPath",
    "Plan",
    "Step",
    "make_path",
    "plan",
    "quadrant_of",
    "route",
    "step_cost",
    "walk",
]

#: Largest coordinate magnitude: 2^23 - 1 LSB (-2^23 is invalid).
COORD_MAX = (1 << 23) - 1
#: Cycles from the FP that completes a step's credit to the step's output pulses.
LATENCY_LINEAR = 11
LATENCY_CIRCULAR = 21
#: Cycles a circular block spends checking its radius (a serial squarer) before it takes FP.
CIRCLE_SETUP_CYCLES = 25
#: Largest valid I^2 + J^2: the digital circle then stays within +-(2^23 - 1).
MAX_RADIUS_SQUARED = (1 << 46) - (1 << 23)
#: CTRL.plane code -> the machine axes (0 X, 1 Y, 2 Z) of a block's first, second and third
#: coordinates: G17 (X, Y, Z), G18 (Z, X, Y), G19 (Y, Z, X), as LinuxCNC's canon orders them.
PLANES = ((0, 1, 2), (2, 0, 1), (1, 2, 0))
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
_SIGNS = {
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


def _wrap(value: int, bits: int) -> int:
    """``value`` in ``bits``-bit two's complement."""
    half = 1 << (bits - 1)
    return (value + half) % (2 * half) - half


def _check_coord(name: str, value: int) -> None:
    if not -COORD_MAX <= value <= COORD_MAX:
        raise BlockError(f"{name} = {value} is outside -(2^23-1)..2^23-1")


class _Dda:
    """One short axis of a DDA: ``n`` moves spread over ``total`` steps. It moves when its
    accumulator, started at half the total, reaches the total: the moves fall where the true
    line crosses a half-LSB, and exactly ``n`` of them come in ``total`` steps."""

    def __init__(self, n: int, total: int):
        self.n, self.total, self.acc = n, total, total // 2

    def peek(self) -> bool:
        return self.acc + self.n >= self.total

    def advance(self) -> bool:
        move = self.peek()
        self.acc += self.n - (self.total if move else 0)
        return move


class LinearPath:
    """Bresenham/DDA on the long axis (the largest |component|, ties to X, then Y).

    Each short axis moves when its accumulator, started at half the long count, reaches the
    long count: the short moves fall where the true line crosses a half-LSB, and the block
    ends exactly at (xe, ye, ze). A two-axis block has ze = 0.
    """

    def __init__(self, xe: int, ye: int, ze: int = 0):
        _check_coord("Xe", xe)
        _check_coord("Ye", ye)
        _check_coord("Ze", ze)
        ends = (xe, ye, ze)
        mags = [abs(e) for e in ends]
        self.long = mags.index(max(mags))
        self.long_is_x = self.long == 0
        self.n_long = mags[self.long]
        self.signs = [(e > 0) - (e < 0) for e in ends]
        self.shorts = {k: _Dda(mags[k], self.n_long) for k in range(3) if k != self.long}
        self.left = self.n_long

    @property
    def n_short(self) -> int:
        """The moves of the longer short axis (a two-axis line's short count)."""
        return max(d.n for d in self.shorts.values())

    @property
    def done(self) -> bool:
        return self.left == 0

    def _step(self, moves: dict[int, bool]) -> Step:
        return Step(*(self.signs[k] if k == self.long or moves[k] else 0 for k in range(3)))

    def peek(self) -> Step:
        """The next step (the path must not be done)."""
        return self._step({k: d.peek() for k, d in self.shorts.items()})

    def advance(self) -> tuple[Step, bool, bool]:
        """Take the next step; returns (step, final, error)."""
        step = self._step({k: d.advance() for k, d in self.shorts.items()})
        self.left -= 1
        return step, self.left == 0, False


class HelixPath:
    """A helix's third axis: ``ze`` moves spread over the arc's ``n`` steps (a DDA on the arc's
    steps, so it ends exactly with the arc). Needs |ze| <= n: at most one move per step."""

    def __init__(self, ze: int, n: int):
        _check_coord("Ze", ze)
        if abs(ze) > n:
            raise BlockError(f"the helix's third axis moves {abs(ze)} LSB in {n} arc steps: "
                             f"more than one per step")
        self.sign = (ze > 0) - (ze < 0)
        self.dda = _Dda(abs(ze), n)

    def peek(self) -> int:
        return self.sign if self.dda.peek() else 0

    def advance(self) -> int:
        return self.sign if self.dda.advance() else 0


class CircularPath:
    """The incremental circle of SPEC section 3, with D = x^2 + y^2 - R0^2 kept exactly.

    Each step moves the long axis (X where |y| >= |x|, Y where |x| > |y|) one LSB in the
    direction of motion and also the short axis when that makes |D| strictly smaller. The arc
    ends when, inside the armed end quadrant, the end point's long-axis coordinate is reached;
    leaving the armed quadrant without reaching it stops the arc with an error.
    """

    def __init__(self, xe: int, ye: int, i: int, j: int, cw: bool, quadrant: int):
        for name, v in (("Xe", xe), ("Ye", ye), ("I", i), ("J", j)):
            _check_coord(name, v)
        if i == 0 and j == 0:
            raise BlockError("the centre equals the start point (radius 0)")
        if i * i + j * j > MAX_RADIUS_SQUARED:
            raise BlockError(f"the circle of radius {(i * i + j * j) ** 0.5:.1f} leaves the "
                             f"24-bit coordinate range")
        if quadrant not in (1, 2, 3, 4):
            raise BlockError(f"end-point quadrant must be 1..4, not {quadrant}")
        self.cw = cw
        self.x, self.y = -i, -j
        self.ex, self.ey = xe - i, ye - j
        if self.ex == 0 and self.ey == 0:
            raise BlockError("the end point is the centre")
        if quadrant_of(self.ex, self.ey, cw) != quadrant:
            raise BlockError(f"end point ({xe}, {ye}) is not in end-point quadrant {quadrant}")
        self.d = 0
        self.q = quadrant_of(self.x, self.y, cw)
        self.end_q = quadrant
        # The end check looks at the end point's long-axis coordinate.
        self.end_on_x = abs(self.ey) >= abs(self.ex)
        self.armed = self.q == self.end_q and self._ahead()
        self.done = False

    def _ahead(self) -> bool:
        sx, sy = _SIGNS[self.cw][self.q]
        if self.end_on_x:
            return (self.ex - self.x) * sx > 0
        return (self.ey - self.y) * sy > 0

    def _decide(self) -> tuple[Step, int]:
        """The next step and the D it leads to."""
        x, y, d = self.x, self.y, self.d
        sx, sy = _SIGNS[self.cw][self.q]
        if abs(y) >= abs(x):
            d1 = d + 2 * x * sx + 1
            d2 = d1 + 2 * y * sy + 1
            return (Step(sx, sy), d2) if abs(d2) < abs(d1) else (Step(sx, 0), d1)
        d1 = d + 2 * y * sy + 1
        d2 = d1 + 2 * x * sx + 1
        return (Step(sx, sy), d2) if abs(d2) < abs(d1) else (Step(0, sy), d1)

    def peek(self) -> Step:
        """The next step (the path must not be done)."""
        return self._decide()[0]

    def advance(self) -> tuple[Step, bool, bool]:
        """Take the next step; returns (step, final, error)."""
        step, self.d = self._decide()
        self.x += step.dx
        self.y += step.dy
        q = quadrant_of(self.x, self.y, self.cw)
        if not self.armed and q == self.end_q and q != self.q:
            self.armed = True
        self.q = q
        if self.armed:
            if q != self.end_q:
                self.done = True
                return step, True, True
            if (self.x == self.ex) if self.end_on_x else (self.y == self.ey):
                self.done = True
                return step, True, False
        return step, False, False


class HelicalPath:
    """An arc (:class:`CircularPath`) whose steps also drive a helix's third axis
    (:class:`HelixPath`, over ``block.helix_steps`` arc steps)."""

    def __init__(self, arc: CircularPath, helix: HelixPath):
        self.arc, self.helix = arc, helix

    @property
    def done(self) -> bool:
        return self.arc.done

    def peek(self) -> Step:
        step = self.arc.peek()
        return Step(step.dx, step.dy, self.helix.peek())

    def advance(self) -> tuple[Step, bool, bool]:
        step, final, error = self.arc.advance()
        return Step(step.dx, step.dy, self.helix.advance()), final, error


class _FramePath:
    """A curve drawn in its own frame: the abscissa p (X, or Y with ``swap``) runs from 0 to
    pe = |end's p| in the direction of the end (``su``), the ordinate v is the other axis."""

    def __init__(self, pe: int, swap: bool):
        self.swap = swap
        self.su = 1 if pe > 0 else -1
        self.pe = abs(pe)
        self.p = self.v = 0
        self.done = False

    @property
    def x(self) -> int:
        return self.v if self.swap else self.su * self.p

    @property
    def y(self) -> int:
        return self.su * self.p if self.swap else self.v

    def _step(self, dp: int, dv: int) -> Step:
        du = self.su * dp
        return Step(dv, du) if self.swap else Step(du, dv)


class ParabolicPath(_FramePath):
    """A parabola by evaluation of its function, the circle's method on F = A v - B p^2 - C p.

    In the curve's own frame the abscissa p (X, or Y with ``swap``) runs from 0 to
    pe = |end's p| in the direction of the end, and the ordinate v is the other axis. The
    parabola through the start, the end (pe, ve) and the tangent point (pe / 2, vp) is
    v = (B p^2 + C p) / A with A = pe^2, B = 2 ve - 4 vp, C = pe (4 vp - ve): integers, so
    the end point lies exactly on it. F is kept exactly with adders only: a step of p adds
    -G (G = B (2p + 1) + C, the next p step's change of A v along the curve, itself moved by
    2B per p step) and a step of v adds +-A. The long axis is p where |G| <= A (the curve
    moves v by at most one LSB over the next p step), else v; v moves in the sign of G.
    Each step moves the long axis and the short one too if that makes |F| strictly smaller.
    The block ends on the end point (p = pe and v = ve), or with an error if p passes pe
    (never for a parabola the host checked with this model).
    """

    def __init__(self, xe: int, ye: int, i: int, j: int, swap: bool):
        for name, value in (("Xe", xe), ("Ye", ye), ("I", i), ("J", j)):
            _check_coord(name, value)
        pe, ve, vp = (ye, xe, i) if swap else (xe, ye, j)
        if pe == 0:
            raise BlockError(f"a parabola needs a non-zero {'Y' if swap else 'X'} extent "
                             f"(its abscissa)")
        super().__init__(pe, swap)
        self.ve = ve
        self.a = pe * pe
        self.b = 2 * ve - 4 * vp
        self.c = self.pe * (4 * vp - ve)
        self.f = 0
        self.g = self.b + self.c

    def _decide(self) -> tuple[int, int, int]:
        """The next step's moves in the curve's frame (dp, dv) and the F it leads to."""
        f, g, a = self.f, self.g, self.a
        sv = 1 if g > 0 else -1
        if abs(g) <= a:
            d1 = f - g
            d2 = d1 + a * sv
            return (1, sv, d2) if abs(d2) < abs(d1) else (1, 0, d1)
        d1 = f + a * sv
        d2 = d1 - g
        return (1, sv, d2) if abs(d2) < abs(d1) else (0, sv, d1)

    def peek(self) -> Step:
        """The next step (the path must not be done)."""
        dp, dv, _ = self._decide()
        return self._step(dp, dv)

    def advance(self) -> tuple[Step, bool, bool]:
        """Take the next step; returns (step, final, error)."""
        dp, dv, self.f = self._decide()
        if dp:
            self.g += 2 * self.b
        self.p += dp
        self.v += dv
        error = self.p > self.pe
        self.done = error or (self.p == self.pe and self.v == self.ve)
        return self._step(dp, dv), self.done, error


class ExponentialPath(_FramePath):
    """An exponential by a self-fed DDA whose integrand carries its own fraction.

    In the curve's frame (:class:`_FramePath`) the chip draws v = sv (u_p - c) sign(k),
    u_p = c r^p with r = 1 + 1/k (|k| = ``i`` >= 2, k < 0 with ``flat``: k > 0 grows, k < 0
    flattens) and the offset c = ``j`` - ``e`` / k >= 0 (-1 < e / k <= 0); sv is the sign of
    the end's v (+ for 0). The discrete recursion is the curve: c r^p is exactly
    c e^(p / k') with k' = 1 / ln(1 + 1/k). u is kept in base |k| as
    Z = |k|^2 u = |k|^2 Q + |k| R - r2, so that a p step,
    Z += sign(k) ceil(Z / |k|) = sign(k) (|k| Q + R), is digit-wise: R += sign(k) Q and
    r2 -= sign(k) R, adders only. Q is the integrand (the integer part of u, moved by one with
    each v step, which takes |k| from R) and F = sign(k) R + e is the curve's height above
    the point in 1/|k| LSB (0 at the start): a p step adds Q to F, a v step -|k|, and
    -sign(k) R = e - F. r2 is normalized lazily: after each step's additions up to two
    carries move between r2 and R, one at a time while r2 is outside 0..|k|-1 (r2 -= |k|
    carry, F -= sign(k) carry, carry +-1): a p step moves r2 by at most 1.5 |k| where p is
    the long axis, and where v is, the steps of a p step's run take what it adds one by one.
    r2 wraps at 28 bits as the chip's register (only with an ``e`` outside its range: the
    chip does not check it). The long axis is p where |Q| <= |k|, else v; each step moves
    the long axis and the short one too if that makes |F| strictly smaller (the parabola's
    rule). The block ends on the end point (p = pe, v = ve), or with an error if p passes pe
    or v passes ve (never for a curve the host checked with this model): both move one way
    only, so every block ends.
    """

    def __init__(self, xe: int, ye: int, i: int, flat: bool, j: int, e: int, swap: bool):
        for name, value in (("Xe", xe), ("Ye", ye), ("I", i), ("J", j)):
            _check_coord(name, value)
        pe, ve = (ye, xe) if swap else (xe, ye)
        if pe == 0:
            raise BlockError(f"an exponential needs a non-zero {'Y' if swap else 'X'} extent "
                             f"(its abscissa)")
        if i < 2 or j < 0:
            raise BlockError(f"an exponential needs I >= 2 (|k|) and J >= 0 (its offset), "
                             f"not I = {i}, J = {j}")
        super().__init__(pe, swap)
        self.ve = ve
        self.sv = -1 if ve < 0 else 1
        self.sk = -1 if flat else 1
        self.k, self.e = i, e
        self.q, self.f, self.r2 = j, 0, 0

    def _decide(self) -> tuple[int, int, int]:
        """The next step's moves in the curve's frame (dp, dv) and the F it leads to."""
        f, q, k = self.f, self.q, self.k
        if abs(q) <= k:
            d1, d2 = f + q, f + q - k
            return (1, 1, d2) if abs(d2) < abs(d1) else (1, 0, d1)
        # |d2| < |d1| with d2 = d1 + q, as the chip tests it: for q > 0 (every curve the
        # host loads; q < -|k| only from data no host picks).
        d1, d2 = f - k, f + q - k
        return (1, 1, d2) if d1 + d2 < 0 else (0, 1, d1)

    def peek(self) -> Step:
        """The next step (the path must not be done)."""
        dp, dv, _ = self._decide()
        return self._step(dp, self.sv * dv)

    def advance(self) -> tuple[Step, bool, bool]:
        """Take the next step; returns (step, final, error)."""
        sr = self.e - self.f  # -sign(k) R before the step
        dp, dv, self.f = self._decide()
        if dp:
            self.r2 = _wrap(self.r2 + sr, EXPONENTIAL_R2_BITS)
        for _ in range(2):
            carry = 1 if self.r2 >= self.k else -1 if self.r2 < 0 else 0
            self.r2 -= carry * self.k
            self.f -= self.sk * carry
        self.q += self.sk * dv
        self.p += dp
        self.v += self.sv * dv
        error = self.p > self.pe or self.sv * self.v > abs(self.ve)
        self.done = error or (self.p == self.pe and self.v == self.ve)
        return self._step(dp, self.sv * dv), self.done, error


Path = LinearPath | CircularPath | HelicalPath | ParabolicPath | ExponentialPath


def make_path(block: Block) -> Path:
    """The algorithm for a block; raises :class:`BlockError` for data the chip refuses."""
    if block.kind is Kind.LINEAR:
        return LinearPath(block.xe, block.ye, block.ze)
    if block.kind is Kind.PARABOLIC:
        return ParabolicPath(block.xe, block.ye, block.i, block.j, block.swap)
    if block.kind is Kind.EXPONENTIAL:
        return ExponentialPath(block.xe, block.ye, block.i, block.cw, block.j, block.frac,
                               block.swap)
    arc = CircularPath(block.xe, block.ye, block.i, block.j, block.cw, block.quadrant)
    if block.ze:
        return HelicalPath(arc, HelixPath(block.ze, block.helix_steps))
    return arc


def walk(block: Block) -> Iterator[Step]:
    """Every step of a block, in order (an arc that errors out stops at its error)."""
    path = make_path(block)
    if isinstance(path, LinearPath):
        while not path.done:
            yield path.advance()[0]
        return
    final = False
    while not final:
        step, final, _ = path.advance()
        yield step


@dataclass(frozen=True)
class Plan:
    """What a block does: its step counts, the FP it needs and where it ends.

    ``end``: the end in the block's first two coordinates; ``ze``: its travel along the third
    (a line's Ze or a helix's, exactly). ``diagonal``: the steps that move two axes or more;
    ``pulses``: per block axis and direction.
    """

    steps: int
    diagonal: int
    fp: int
    end: tuple[int, int]
    error: bool
    pulses: dict[str, int]
    ze: int = 0


def _coincident(a: _Dda, b: _Dda) -> int:
    """In how many steps of a line both short axes ``a`` and ``b`` (over the same total) move:
    each move of the one with fewer moves, checked against the other (no walk of the line)."""
    if a.n > b.n:
        a, b = b, a
    total, h = a.total, a.total // 2
    both = 0
    for j in range(1, a.n + 1):
        s = -(-(j * total - h) // a.n)  # the step (from 1) of a's j-th move
        both += (h + s * b.n) // total - (h + (s - 1) * b.n) // total
    return both


def _fp(steps: int, two: int, three: int, sqrt2: bool) -> int:
    """FP of a block with ``two`` and ``three`` steps moving two and three axes: the sum of
    the step costs over the credit per FP (N_long + ceil(N_diag / 2) for two axes)."""
    if not sqrt2:
        return steps
    return -(-(4 * steps + 2 * two + 3 * three) // 4)


def plan(block: Block) -> Plan:
    """Run a block through the algorithm: the exact FP count and final point.

    ``fp`` = N_long + ceil(N_diag / 2) with sqrt(2) control for a two-axis block, N_long
    without it; a three-axis one costs 1, 1.5 or 1.75 FP per step moving 1, 2 or 3 axes
    (:func:`step_cost`), rounded up over the block. A helix's third axis is spread over the
    arc's own step count (the ``helix_steps`` the host loads), whatever ``block.helix_steps``
    says. Raises :class:`BlockError` for data the chip refuses; an arc whose end is not on its
    path comes back with ``error`` set (the chip would stop it with its ERROR bit).
    """
    if block.kind is Kind.LINEAR:
        path = LinearPath(block.xe, block.ye, block.ze)
        a, b = path.shorts.values()
        three = _coincident(a, b) if a.n and b.n else 0
        n, diag = path.n_long, a.n + b.n - three
        ends = (block.xe, block.ye, block.ze)
        pulses = {f"{axis}{sign}": max(e if sign == "+" else -e, 0)
                  for axis, e in zip("xyz", ends, strict=True) for sign in "+-"}
        return Plan(n, diag, _fp(n, diag - three, three, block.sqrt2), ends[:2], False, pulses,
                    block.ze)
    path = make_path(replace(block, ze=0))  # the arc; the helix is spread over its steps
    steps: list[Step] = []
    final = error = False
    while not final:
        step, final, error = path.advance()
        steps.append(step)
    if block.ze:
        helix = HelixPath(block.ze, len(steps))
        steps = [Step(s.dx, s.dy, helix.advance()) for s in steps]
    counts = Counter(s.moved for s in steps)
    pulses = {f"{axis}{sign}": sum(getattr(s, f"d{axis}") == (1 if sign == "+" else -1)
                                   for s in steps)
              for axis in "xyz" for sign in "+-"}
    end = (pulses["x+"] - pulses["x-"], pulses["y+"] - pulses["y-"])
    return Plan(len(steps), counts[2] + counts[3],
                _fp(len(steps), counts[2], counts[3], block.sqrt2), end, error, pulses,
                block.ze)


@dataclass
class K3701Outputs:
    """The chip's outputs in one cycle."""

    x_pos: int = 0
    x_neg: int = 0
    y_pos: int = 0
    y_neg: int = 0
    busy: int = 0
    irq: int = 0
    error: int = 0
    overrun: int = 0
    xm: int = 0
    ym: int = 0
    z_pos: int = 0
    z_neg: int = 0
    zm: int = 0


class _Phase(enum.Enum):
    IDLE = 0
    SETUP = 1
    RUN = 2


class K3701Model:
    """The K3701 cycle by cycle, from the cycle its START command is seen.

    Call :meth:`cycle` once per clock cycle with that cycle's inputs; it returns the outputs
    of that cycle (all registered: they depend on earlier cycles only) and advances the state
    to the next cycle. ``start`` is the block whose START command the chip sees in this cycle
    (the cycle after the host's last write of the command byte).

    Timing, with S the start cycle:

    * linear: BUSY from S+1, FP taken from S+1; invalid data sets ERROR and the interrupt at
      S+1 and nothing starts; a zero-length line raises the interrupt at S+1 without BUSY.
    * circular: BUSY from S+1; the radius is checked by a serial squarer for
      ``CIRCLE_SETUP_CYCLES`` cycles and the first FP is taken at S+1+CIRCLE_SETUP_CYCLES;
      invalid data ends the block there with ERROR and the interrupt.
    * an FP taken in cycle t adds 2 half-FP credits; when the credit reaches the next step's
      cost (2, or 3 for a diagonal step with sqrt(2) control) the step's pulses come out in
      cycle t + L and the engine takes its next FP from that cycle on. Before that, one FP is
      held and a further one sets OVERRUN and is lost.
    * the final step's pulses, BUSY falling and the interrupt rising share one cycle.

    ``axes=3``: the three-axis chip. Credit in quarter-FP units (an FP adds 4, a step costs
    :func:`step_cost`); the remaining distances xm, ym, zm are in block coordinates and the
    step pulses go to the machine axes CTRL.plane names (:func:`route`); a helix whose
    |Ze| exceeds its step count N ends at the radius check with ERROR.
    """

    def __init__(self, latency_linear: int = LATENCY_LINEAR,
                 latency_circular: int = LATENCY_CIRCULAR,
                 circle_setup: int = CIRCLE_SETUP_CYCLES, axes: int = 2):
        self.axes = axes
        self.unit = 2 if axes == 2 else 4  # credit units per FP
        self.latency = {Kind.LINEAR: latency_linear, Kind.CIRCULAR: latency_circular,
                        Kind.PARABOLIC: latency_circular, Kind.EXPONENTIAL: latency_circular}
        self.circle_setup = circle_setup
        self.out = K3701Outputs()
        self.phase = _Phase.IDLE
        self.path: Path | None = None
        self.block: Block | None = None
        self.setup_left = 0
        self.count = 0
        self.held = False
        self.credit = 0
        self.pending: Step | None = None

    def _finish(self, nxt: K3701Outputs, error: bool) -> None:
        self.phase = _Phase.IDLE
        self.path = None
        self.held = False
        self.count = 0
        nxt.busy = 0
        nxt.irq = 1
        nxt.error |= error

    def _cost(self) -> int:
        return step_cost(self.path.peek(), self.block.sqrt2, self.axes)

    def cycle(self, fp: bool = False, start: Block | None = None, ack: bool = False,
              clear: bool = False) -> K3701Outputs:
        out = self.out
        nxt = K3701Outputs(busy=out.busy, irq=out.irq, error=out.error, overrun=out.overrun,
                           xm=out.xm, ym=out.ym, zm=out.zm)
        if ack:
            nxt.irq = 0
        if clear:
            nxt.error = nxt.overrun = 0

        was_idle = self.phase is _Phase.IDLE
        if self.phase is _Phase.SETUP:
            if fp:
                self._hold(nxt)
            self.setup_left -= 1
            if self.setup_left == 0:
                try:
                    self.path = make_path(self.block)
                except BlockError:
                    self._finish(nxt, error=True)
                else:
                    self.phase = _Phase.RUN
        elif self.phase is _Phase.RUN:
            self._run(fp, nxt)

        if start is not None:
            if not was_idle:
                nxt.error = 1
            else:
                self._start(start, nxt)
        self.out = nxt
        return out

    def _hold(self, nxt: K3701Outputs) -> None:
        if self.held:
            nxt.overrun = 1
        else:
            self.held = True

    def _start(self, block: Block, nxt: K3701Outputs) -> None:
        self.block = block
        self.credit = 0
        self.held = False
        self.count = 0
        nxt.xm, nxt.ym, nxt.zm = block.xe, block.ye, block.ze
        if block.setup_cycles:
            self.phase = _Phase.SETUP
            self.setup_left = (self.circle_setup if block.kind is Kind.CIRCULAR
                               else block.setup_cycles)
            nxt.busy = 1
            return
        try:
            self.path = LinearPath(block.xe, block.ye, block.ze)
        except BlockError:
            nxt.irq = nxt.error = 1
            return
        if self.path.done:
            nxt.irq = 1
            return
        self.phase = _Phase.RUN
        nxt.busy = 1

    def _run(self, fp: bool, nxt: K3701Outputs) -> None:
        if self.count:
            if fp:
                self._hold(nxt)
            self.count -= 1
            if self.count == 0:
                step, final, error = self.path.advance()
                dx, dy, dz = route(step, self.block.plane)
                nxt.x_pos, nxt.x_neg = int(dx > 0), int(dx < 0)
                nxt.y_pos, nxt.y_neg = int(dy > 0), int(dy < 0)
                nxt.z_pos, nxt.z_neg = int(dz > 0), int(dz < 0)
                nxt.xm -= step.dx
                nxt.ym -= step.dy
                nxt.zm -= step.dz
                if final:
                    self._finish(nxt, error)
            return
        if self.held:
            take = True
            self.held = fp
        else:
            take = fp
        if take:
            self.credit += self.unit
            cost = self._cost()
            if self.credit >= cost:
                self.credit -= cost
                self.count = self.latency[self.block.kind] - 1
