"""Reference model of :mod:`k37.hdl.k3701.datapaths.parabolic`: a parabola by evaluation of its
function (:class:`ParabolicPath`) and an exponential or logarithm by a self-fed DDA
(:class:`ExponentialPath`), both drawn in the curve's own frame (:class:`FramePath`)."""

from __future__ import annotations

from k37.hdl.k3701.block import EXPONENTIAL_R2_BITS, BlockError, Step, check_coord, wrap

__all__ = ["ExponentialPath", "FramePath", "ParabolicPath"]

class FramePath:
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


class ParabolicPath(FramePath):
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
            check_coord(name, value)
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


class ExponentialPath(FramePath):
    """An exponential by a self-fed DDA whose integrand carries its own fraction.

    In the curve's frame (:class:`FramePath`) the chip draws v = sv (u_p - c) sign(k),
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
            check_coord(name, value)
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
            self.r2 = wrap(self.r2 + sr, EXPONENTIAL_R2_BITS)
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
