"""The exact plan of a circular block without walking every step: the host's FP count.

:func:`k37.hdl.k3701.model.chip.plan` runs a block through the reference algorithm one step at
a time (a circle of radius R takes about 5.7 R steps: minutes of Python for a large circle).
:func:`plan_block` gives the same :class:`~k37.hdl.k3701.model.chip.Plan`, exactly, in time
independent of the radius for all but a few steps per octant.

Why the jumps are exact: where X is the long axis (|y| >= |x|), each step moves X one LSB and
moves Y too when that makes |D| = |x^2 + y^2 - R0^2| strictly smaller (no ties: the two
values differ by an odd number). If the point is the integer y nearest the circle in that
sense (the argmin of |D| over y) and the true circle's y changes by less than one LSB per
step (|x| + 2 <= |y|), the next argmin is y or its neighbour in the direction of motion, so
the walk picks it: from an argmin point the walk *is* the argmin curve, and its point after n
steps is computed with one integer square root. The walk's long/short choice, its quadrant
and its end check cannot change inside such a stretch (the jump stops short of an axis, of
the diagonal and of the end point's coordinate); the few steps around those go through the
reference :class:`~k37.hdl.k3701.datapaths.model.circular.CircularPath` itself. Same for Y long,
with the axes swapped. Tested against :func:`k37.hdl.k3701.model.chip.plan` step for step
(``tests/firmware_model/gcode/test_arc_plan.py``).

A helix spreads its third axis over the arc's N steps with a DDA (its k-th move at the step
where floor((N // 2 + s |Ze|) / N) grows), and its FP count needs B, the steps where that move
falls on a diagonal step of the arc (a step moving three axes). The arc's plan is first made
as above (N); B is then counted over the same stretches: the arc's diagonal steps inside a
jump are where the argmin curve's short coordinate changes, found for the whole jump at once
with array arithmetic (:func:`_nearest_array`), so no step is walked in Python.
"""

from __future__ import annotations

from dataclasses import replace
from math import isqrt

import numpy as np

from k37.hdl.k3701.block import QUADRANT_SIGNS, Block, Kind
from k37.hdl.k3701.datapaths.model.circular import CircularPath
from k37.hdl.k3701.datapaths.model.helix import HelixPath
from k37.hdl.k3701.model.chip import Plan, fp_of_steps, make_path, plan

__all__ = ["plan_block"]

#: Stretches shorter than this are walked step by step.
_MIN_JUMP = 8
#: Steps of a jump whose diagonal steps are found in one array (memory stays bounded).
_CHUNK = 1 << 18


def _nearest(r2: int, long: int) -> int:
    """The integer s >= 0 minimising |long^2 + s^2 - r2|: the smallest s with s(s+1) >= t."""
    t = r2 - long * long
    if t <= 0:
        return 0
    s = isqrt(t)
    while s * (s + 1) < t:
        s += 1
    while s > 0 and (s - 1) * s >= t:
        s -= 1
    return s


def _last_with_margin(r2: int) -> int:
    """The largest m >= 0 with m + 2 <= :func:`_nearest` (r2, m): the farthest the long
    coordinate may run towards the diagonal keeping the jump's margin (the margin shrinks
    as m grows; m^2 + (m + 2)^2 = r2 is its estimate, mended to the exact bound)."""
    m = max(0, (isqrt(max(0, 2 * r2 - 4)) - 2) // 2)
    while m + 3 <= _nearest(r2, m + 1):
        m += 1
    while m > 0 and m + 2 > _nearest(r2, m):
        m -= 1
    return m


def _before_end(r2: int, lo: int, sl: int, sh: int, ss: int, end: int, n: int) -> int:
    """The most steps, up to ``n``, after which the short coordinate (the argmin curve's,
    monotone along the jump) has not reached ``end``: found by bisection."""
    sign = 1 if sh > 0 else -1
    if (end - sh) * ss <= 0:
        return 0
    good, bad = 0, n + 1
    while bad - good > 1:
        mid = (good + bad) // 2
        if (end - _nearest(r2, lo + mid * sl) * sign) * ss > 0:
            good = mid
        else:
            bad = mid
    return good


def _jump(path: CircularPath, r2: int) -> tuple[int, int, int] | None:
    """How far the walk can be jumped from here: (steps, new x, new y), or None."""
    x, y, d = path.x, path.y, path.d
    sx, sy = QUADRANT_SIGNS[path.cw][path.q]
    x_long = abs(y) >= abs(x)
    # (long, short) coordinates, their directions and the end check on the long/short axis
    lo, sh, sl, ss = (x, y, sx, sy) if x_long else (y, x, sy, sx)
    if lo == 0 or sh == 0 or abs(lo) + 2 > abs(sh):
        return None
    if abs(d) >= abs(d + 2 * sh + 1) or abs(d) >= abs(d - 2 * sh + 1):
        return None  # not the argmin of its column
    # The long coordinate may run to 1 LSB short of its axis or, towards the diagonal, as
    # far as the margin |long| + 2 <= |short| holds.
    n = abs(lo) - 1 if lo * sl < 0 else _last_with_margin(r2) - abs(lo)
    if path.armed and path.q == path.end_q:
        end = path.ex if path.end_on_x else path.ey
        if path.end_on_x == x_long:  # the end check watches the long coordinate
            if (end - lo) * sl >= 0:
                n = min(n, (end - lo) * sl - 1)
        elif (end - sh) * ss >= 0:  # ... the short one: stop before it reaches it
            n = _before_end(r2, lo, sl, sh, ss, end, n)
    if n < _MIN_JUMP:
        return None
    lo2 = lo + n * sl
    sh2 = _nearest(r2, lo2) * (1 if sh > 0 else -1)
    assert abs(lo2) + 2 <= abs(sh2) and lo2 * lo > 0
    return (n, lo2, sh2) if x_long else (n, sh2, lo2)


def _nearest_array(r2: int, long: np.ndarray) -> np.ndarray:
    """:func:`_nearest` of every element of ``long`` (int64; r2 < 2^53, so the float square
    root is off by at most one, which the two corrections mend)."""
    t = r2 - long * long
    s = np.floor(np.sqrt(np.maximum(t, 0).astype(np.float64))).astype(np.int64)
    for _ in range(2):
        s += s * (s + 1) < t
        s -= (s > 0) & ((s - 1) * s >= t)
    return np.where(t <= 0, 0, s)


#: A jump of the walk: (its first step's index from 0, its steps, the long coordinate and
#: the short one's magnitude before it, the long axis's direction).
_Jump = tuple[int, int, int, int, int]


def _walk(block: Block) -> tuple[Plan, list[int], list[_Jump]]:
    """The arc's plan (:func:`plan_block` without a third axis), the indices (from 0) of
    its diagonal steps walked one by one, and its jumps."""
    path = make_path(block)
    assert isinstance(path, CircularPath)
    r2 = block.i * block.i + block.j * block.j
    x0, y0 = path.x, path.y
    n = diag = 0
    pulses = {"x+": 0, "x-": 0, "y+": 0, "y-": 0, "z+": 0, "z-": 0}
    singles: list[int] = []
    jumps: list[_Jump] = []
    final = error = jumped = False
    while not final:
        # A jump runs as far as it may: the step after it is walked without asking again.
        jump = None if jumped else _jump(path, r2)
        jumped = jump is not None
        if jump is None:
            step, final, error = path.advance()
            dx, dy, steps = step.dx, step.dy, 1
            if dx != 0 and dy != 0:
                diag += 1
                singles.append(n)
        else:
            steps, nx, ny = jump
            x_long = abs(path.y) >= abs(path.x)
            sx, sy = QUADRANT_SIGNS[path.cw][path.q]
            lo, sh, sl = (path.x, path.y, sx) if x_long else (path.y, path.x, sy)
            jumps.append((n, steps, lo, abs(sh), sl))
            dx, dy = nx - path.x, ny - path.y
            diag += min(abs(dx), abs(dy))
            path.x, path.y, path.d = nx, ny, nx * nx + ny * ny - r2
        n += steps
        pulses["x+" if dx > 0 else "x-"] += abs(dx)
        pulses["y+" if dy > 0 else "y-"] += abs(dy)
    fp = n + (diag + 1) // 2 if block.sqrt2 else n
    return Plan(n, diag, fp, (path.x - x0, path.y - y0), error, pulses), singles, jumps


def _helix_coincidences(block: Block, total: int, singles: list[int],
                        jumps: list[_Jump]) -> int:
    """B: the arc's diagonal steps (``singles``, and those inside ``jumps``) on which the
    helix's third axis moves too, its |Ze| moves spread over ``total`` steps by the DDA."""
    zn, h = abs(block.ze), total // 2
    r2 = block.i * block.i + block.j * block.j

    def z_moves(index: np.ndarray) -> np.ndarray:  # steps counted from 0
        return (h + (index + 1) * zn) // total - (h + index * zn) // total

    both = int(z_moves(np.array(singles, dtype=np.int64)).sum())
    for first, steps, lo, short, sl in jumps:
        for k0 in range(0, steps, _CHUNK):
            k = np.arange(k0, min(steps, k0 + _CHUNK) + 1, dtype=np.int64)
            shorts = _nearest_array(r2, lo + k * sl)
            if k0 == 0:
                shorts[0] = short
            moved = shorts[1:] != shorts[:-1]  # the step k + 1 of the jump is diagonal
            both += int(z_moves(first + k[:-1][moved]).sum())
    return both


def plan_block(block: Block) -> Plan:
    """:func:`k37.hdl.k3701.model.chip.plan` of ``block``, exactly, without walking every step of an
    arc or a helix. Raises :class:`~k37.hdl.k3701.block.BlockError` for data the chip refuses."""
    if block.kind is Kind.LINEAR:
        return plan(block)  # a line is in closed form there
    arc, singles, jumps = _walk(replace(block, ze=0))
    if not block.ze:
        return arc
    HelixPath(block.ze, arc.steps)  # the chip's checks: Ze's range, one move per step
    zn = abs(block.ze)
    three = _helix_coincidences(block, arc.steps, singles, jumps)
    two = arc.diagonal + zn - 2 * three
    pulses = {**arc.pulses, "z+": max(block.ze, 0), "z-": max(-block.ze, 0)}
    return Plan(arc.steps, two + three, fp_of_steps(arc.steps, two, three, block.sqrt2),
                arc.end, arc.error, pulses, block.ze)
