"""The planner both G-code front ends build a program with.

:class:`Planner` turns moves to absolute targets into items. Every block starts where the
previous one really ended and runs to its programmed target, an absolute position in integer
LSB, so nothing accumulates. A line ends exactly on its target. An arc's chip end can differ
from its programmed end (the K3701 stops where its digital path reaches the end's long-axis
coordinate, ``docs/chips/k3701.md``): within :data:`CORRECTION_MAX` LSB on every axis of the exact
programmed end (before its rounding to the LSB grid) it is left, and the next block starts
there; farther, the planner adds a *correction line*, a short linear block at the arc's feed
from the chip's end to the programmed end (``Line.correction``). If the chip would stop far
from the programmed end (a tiny arc whose digital path runs a full extra turn, or leaves the
end quadrant with ERROR), the block's end point is moved to the grid point near the
programmed end whose chip end is closest to it, within :data:`REPAIR_REACH` LSB, and the
correction line follows if needed. An arc the chip cannot run as one block (a helix steeper
than its helix, a radius beyond its registers) and a spline run as chords.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from k37.firmware_model.motion.arcs import plan_block
from k37.firmware_model.motion.curves import CurveError, exponential_block, parabola_block
from k37.firmware_model.motion.program import (
    Arc,
    Dwell,
    Event,
    Exponential,
    Item,
    Line,
    Parabola,
    _arc_steps_bound,
    _sweep,
    chip_end,
)
from k37.firmware_model.motion.splines import Nurbs, SplineSpan, chords
from k37.hdl.common.constants import AXIS_LETTERS, PLANE_AXES
from k37.hdl.k3701.block import COORD_MAX, MAX_RADIUS_SQUARED, Block, BlockError
from k37.hdl.k3701.model.chip import Plan

__all__ = ["CORRECTION_MAX", "MAX_CHORDS", "REPAIR_REACH", "PlanError", "Planner"]

#: The most lines an arc the K3701 cannot run as one block becomes (:meth:`Planner._chords`).
MAX_CHORDS = 100_000
#: How far (LSB, each axis) from the programmed end a repaired arc's block end may be moved.
REPAIR_REACH = 3
#: How far (LSB, each axis) an arc's chip end may stay from its programmed end without a
#: correction line: the K3701 datasheet's 1 LSB.
CORRECTION_MAX = 1


class PlanError(ValueError):
    """A move the planner refuses; the front end adds the place (line, column)."""


class Planner:
    """Builds the items of a program from moves to absolute machine targets (LSB).

    ``position`` is the machine position and ``programmed`` the programmed one (three ints
    each; Z stays 0 on a two-axis machine): they differ by at most :data:`CORRECTION_MAX`
    after an arc. Methods raise :class:`PlanError` for a move the K3701 cannot run.
    """

    def __init__(self, *, axes: int, sqrt2: bool, lsb_mm: float):
        self.axes = axes
        self.sqrt2 = sqrt2
        self.lsb_mm = lsb_mm
        self.items: list[Item] = []
        self.position = (0, 0, 0)
        self.programmed = (0, 0, 0)
        #: What the planner ran otherwise than programmed, and why: (line, text).
        self.notes: list[tuple[int, str]] = []
        #: The plans made so far, by block: a program repeats its blocks (a pattern's
        #: arcs, a zigzag's joins), and a block's plan depends on nothing else.
        self._plans: dict[Block, Plan] = {}

    def _plan(self, block: Block) -> Plan:
        """:func:`~k37.firmware_model.motion.arcs.plan_block` of ``block``, made once."""
        result = self._plans.get(block)
        if result is None:
            result = self._plans[block] = plan_block(block)
        return result

    def mm(self, lsb: float) -> str:
        """A length in LSB as mm, to the LSB's resolution."""
        digits = max(0, -math.floor(math.log10(self.lsb_mm) + 1e-9))
        return f"{lsb * self.lsb_mm:.{digits}f} mm"

    def _start(self) -> tuple[int, ...]:
        return self.position[:self.axes]

    def _check_target(self, target: tuple[int, int, int]) -> tuple[int, int, int]:
        x, y, z = target
        px, py, pz = self.position
        if (-COORD_MAX <= x <= COORD_MAX and -COORD_MAX <= y <= COORD_MAX
                and -COORD_MAX <= z <= COORD_MAX and -COORD_MAX <= x - px <= COORD_MAX
                and -COORD_MAX <= y - py <= COORD_MAX and -COORD_MAX <= z - pz <= COORD_MAX
                and (self.axes == 3 or z == pz)):
            return target  # (most moves)
        for axis in range(3):
            for value, what in ((target[axis], "position"),
                                (target[axis] - self.position[axis], "move")):
                if abs(value) > COORD_MAX:
                    raise PlanError(f"{AXIS_LETTERS[axis]}: the {what} {value} LSB is outside "
                                    f"-(2^23-1)..2^23-1 LSB (+-{self.mm(COORD_MAX)})")
        if self.axes == 2 and target[2] != self.position[2]:
            raise PlanError("this move moves Z: the machine has two axes (machine.axes = 3 "
                            "runs it)")
        return target

    def _check_curve_target(self, name: str, target: tuple[int, int, int]
                            ) -> tuple[int, int, int]:
        """A parabola's or an exponential's end: the K3701 runs them in a plane (and refuses
        a third coordinate), so Z must stay."""
        target = self._check_target(target)
        if target[2] != self.position[2]:
            raise PlanError(f"{name}: the curve moves Z by {self.mm(target[2] - self.position[2])}"
                            f": the K3701's curves stay in their plane (move Z with a line)")
        return target

    def spline(self, line_no: int, curve: Nurbs, target: tuple[int, int, int], feed: float, *,
               tolerance: float, feed_source: tuple[int, int, str] | None = None) -> None:
        """A spline in the XY plane from the position to ``target`` (its last control point,
        rounded), run as lines within ``tolerance`` (LSB) of ``curve`` (see
        :mod:`k37.firmware_model.motion.splines`), the last ending exactly on ``target``."""
        try:
            spans = chords(curve, max(tolerance - 0.5, 0.25))
        except ValueError as e:
            raise PlanError(str(e)) from None
        z = self.position[2]
        for k, (t0, t1) in enumerate(spans):
            x, y = curve.at(np.array([t1]))[0]
            point = target if k == len(spans) - 1 else (round(x), round(y), z)
            self.line(line_no, point, feed, feed_source=feed_source,
                      curve=SplineSpan(curve, t0, t1, z))

    def line(self, line_no: int, target: tuple[int, int, int], feed: float | None, *,
             feed_source: tuple[int, int, str] | None = None, correction: bool = False,
             curve: SplineSpan | None = None) -> None:
        """A straight move to ``target``; ``feed`` None: rapid (G00); ``curve``: the exact
        curve it stands for (a spline's chord)."""
        target = self._check_target(target)
        xe, ye, ze = (t - p for t, p in zip(target, self.position, strict=True))
        block = Block.line(xe, ye, ze, sqrt2=self.sqrt2)
        result = self._plan(block)
        self.items.append(Line(len(self.items), line_no, xe, ye, feed, feed is None, ze=ze,
                               start=self._start(), block=block, plan=result,
                               feed_source=feed_source, correction=correction, curve=curve))
        self.position = self.programmed = target

    def parabola(self, line_no: int, target: tuple[int, int, int], tangent: tuple[int, int],
                 feed: float, *, feed_source: tuple[int, int, str] | None = None) -> None:
        """A parabola (G06) to ``target`` through the tangent point ``tangent`` (relative to
        the start), in the XY plane (Z stays where it is)."""
        target = self._check_curve_target("G06", target)
        xe, ye = target[0] - self.position[0], target[1] - self.position[1]
        try:
            block, result = parabola_block(self.position[:2], xe, ye, *tangent, self.sqrt2)
        except CurveError as e:
            raise PlanError(str(e)) from None
        self.items.append(Parabola(len(self.items), line_no, xe, ye, *tangent, feed,
                                   start=self._start(), block=block, plan=result,
                                   feed_source=feed_source))
        self.position = self.programmed = target

    def exponential(self, line_no: int, target: tuple[int, int, int], constant: int,
                    log: bool, feed: float, *,
                    feed_source: tuple[int, int, str] | None = None) -> None:
        """An exponential (G06.1), or with ``log`` a logarithm (G06.2), to ``target`` of
        constant ``constant`` (LSB along X, or Y with ``log``), in the XY plane (Z stays
        where it is)."""
        name = "G06.2" if log else "G06.1"
        target = self._check_curve_target(name, target)
        xe, ye = target[0] - self.position[0], target[1] - self.position[1]
        try:
            block, result = exponential_block(xe, ye, constant, log=log, sqrt2=self.sqrt2)
        except CurveError as e:
            raise PlanError(f"{name}: {e}") from None
        self.items.append(Exponential(len(self.items), line_no, xe, ye, constant, log, feed,
                                      start=self._start(), block=block, plan=result,
                                      feed_source=feed_source))
        self.position = self.programmed = target

    def dwell(self, line_no: int, seconds: float) -> None:
        self.items.append(Dwell(len(self.items), line_no, seconds))

    def event(self, line_no: int, word: str, kind: str, value: float | None = None) -> None:
        self.items.append(Event(len(self.items), line_no, word, kind, value))

    def arc(self, line_no: int, target: tuple[int, int, int], centre: tuple[int, int],
            plane: int, cw: bool, feed: float, *, tolerance: float,
            feed_source: tuple[int, int, str] | None = None,
            exact: tuple[float, float, float] | None = None) -> None:
        """An arc (a helix if the normal axis moves) from the position to ``target`` around
        ``centre`` (absolute, in the plane's (first, second) coordinates). An end equal to
        the start in the plane is a full circle (around a centre at the start, radius 0: a
        line along the plane's normal, as a cutter as wide as the hole it follows runs).
        ``exact``: the programmed end before its
        rounding to ``target`` (None: ``target``); a correction line follows where the chip
        ends more than :data:`CORRECTION_MAX` from it on any axis."""
        target = self._check_target(target)
        first, second, normal = PLANE_AXES[plane]
        if self.axes == 2 and (plane != 17 or target[normal] != self.position[normal]):
            raise PlanError(f"{'a helical arc' if plane == 17 else f'a G{plane} arc'} moves "
                            f"Z: the machine has two axes (machine.axes = 3 runs it)")
        start = self.position
        i, j = centre[0] - start[first], centre[1] - start[second]
        end = (target[first] - start[first], target[second] - start[second])
        if (target[first], target[second]) == (self.programmed[first], self.programmed[second]):
            end = (0, 0)  # a full circle from wherever the machine is
        if i == 0 and j == 0 and end == (0, 0):  # a helix of radius 0: the normal axis only
            self.line(line_no, target, feed, feed_source=feed_source)
            return
        if i == 0 and j == 0:
            raise PlanError("the arc's centre is its start point (radius 0)")
        r0, r1 = math.hypot(i, j), math.hypot(end[0] - i, end[1] - j)
        if abs(r1 - r0) > tolerance:
            raise PlanError(f"the arc's end is not on its circle: radius {self.mm(r0)} at the "
                            f"start, {self.mm(r1)} at the end (they differ by "
                            f"{abs(r1 - r0):.1f} LSB; tolerance {tolerance:g} LSB)")
        rel = (target[0] - start[0], target[1] - start[1], target[2] - start[2])
        if max(abs(i), abs(j)) > COORD_MAX or i * i + j * j > MAX_RADIUS_SQUARED:
            self._check_sweep(start, (first, second), (i, j), end, cw)
            self._chords(line_no, target, (i, j), plane, cw, feed, tolerance=tolerance,
                         feed_source=feed_source,
                         why=f"its radius {self.mm(r0)} is beyond the K3701's 24-bit registers")
            return
        if rel[normal] and abs(rel[normal]) > _arc_steps_bound(i, j, end, cw):
            self._chords(line_no, target, (i, j), plane, cw, feed, tolerance=tolerance,
                         feed_source=feed_source,
                         why=f"it moves its axis {AXIS_LETTERS[normal]} {abs(rel[normal])} LSB, "
                             f"more than one LSB per arc step (the K3701's helix)")
            return
        block, result = self._arc_block(end, i, j, cw)
        self._check_sweep(start, (first, second), (i, j), result.end, cw)
        offsets = [0, 0, 0]
        offsets[first], offsets[second] = i, j
        if rel[normal] or plane != 17:  # the three-axis chip's helix and plane routing
            try:
                result = self._plan(replace(block, ze=rel[normal], plane=plane - 17))
            except BlockError as e:
                self._chords(line_no, target, (i, j), plane, cw, feed, tolerance=tolerance,
                             feed_source=feed_source, why=f"the K3701 refuses this helix: {e}")
                return
            block = replace(block, ze=rel[normal], plane=plane - 17,
                            helix_steps=result.steps if rel[normal] else 0)
        self.items.append(Arc(len(self.items), line_no, rel[0], rel[1], offsets[0], offsets[1],
                              cw, feed, ze=rel[2], k=offsets[2], plane=plane,
                              start=self._start(), block=block, plan=result,
                              feed_source=feed_source))
        x, y, z = chip_end(start, (first, second, normal), result.end, rel[normal])
        self.position = (x, y, z)
        self.programmed = target
        if max(abs(p - t) for p, t in zip(self.position, exact or target,
                                          strict=True)) > CORRECTION_MAX:
            self.line(line_no, target, feed, feed_source=feed_source, correction=True)

    def _chords(self, line_no: int, target: tuple[int, int, int], ij: tuple[int, int],
                plane: int, cw: bool, feed: float, *, tolerance: float,
                feed_source: tuple[int, int, str] | None, why: str) -> None:
        """An arc the K3701 cannot run as one block, as lines (chords) from the position to
        ``target``: each within ``tolerance`` (LSB) of the circle (its sagitta, plus the
        half LSB of rounding its ends to the grid), the normal axis moving in proportion,
        the last ending exactly on ``target``; one note says why."""
        first, second, normal = PLANE_AXES[plane]
        start = self.position
        i, j = ij
        end = (target[first] - start[first], target[second] - start[second])
        if (target[first], target[second]) == (self.programmed[first],
                                               self.programmed[second]):
            end = (0, 0)
        a0, sweep = _sweep(i, j, end, cw)
        r0, r1 = math.hypot(i, j), math.hypot(end[0] - i, end[1] - j)
        sagitta = max(tolerance - 0.5, 0.25)
        step = 2 * math.acos(max(-1.0, 1 - sagitta / max(r0, r1)))
        count = max(1, math.ceil(sweep / step - 1e-12))
        if count > MAX_CHORDS:
            raise PlanError(f"this arc would take {count} chords within the arc tolerance "
                            f"({tolerance:g} LSB); at most {MAX_CHORDS} an arc: {why}")
        sign = -1 if cw else 1
        cx, cy = start[first] + i, start[second] + j
        for k in range(1, count + 1):
            if k == count:
                point = target
            else:
                angle = a0 + sign * sweep * k / count
                radius = r0 + (r1 - r0) * k / count
                p = [0, 0, 0]
                p[first] = round(cx + radius * math.cos(angle))
                p[second] = round(cy + radius * math.sin(angle))
                p[normal] = round(start[normal] + (target[normal] - start[normal]) * k / count)
                point = (p[0], p[1], p[2])
            self.line(line_no, point, feed, feed_source=feed_source)
        self.notes.append((line_no, f"an arc run as {count} lines within the arc tolerance "
                                    f"({tolerance:g} LSB): {why}"))

    def _arc_block(self, end: tuple[int, int], i: int, j: int, cw: bool) -> tuple[Block, Plan]:
        """The block to load for an arc to ``end`` and its plan: the programmed end, or the
        grid point near it whose chip end is closest to it (see the module's docstring)."""
        refused = None
        try:
            block = Block.arc(end[0], end[1], i, j, cw=cw, sqrt2=self.sqrt2)
            result = self._plan(block)
            if self._close(end, result, i, j, cw):
                return block, result
        except BlockError as e:
            refused = e
        if i * i + j * j > MAX_RADIUS_SQUARED:
            raise PlanError(f"the K3701 refuses this arc: {refused}")
        best = None
        reach = range(-REPAIR_REACH, REPAIR_REACH + 1)
        for dx in reach:
            for dy in reach:
                try:
                    candidate = Block.arc(end[0] + dx, end[1] + dy, i, j, cw=cw,
                                          sqrt2=self.sqrt2)
                    trial = self._plan(candidate)
                except BlockError:
                    continue
                if self._close(end, trial, i, j, cw):
                    key = (math.dist(trial.end, end), abs(dx) + abs(dy))
                    if best is None or key < best[0]:
                        best = key, candidate, trial
        if best is None and refused is not None:
            raise PlanError(f"the K3701 refuses this arc: {refused}")
        if best is None:
            raise PlanError(f"the K3701 cannot end this arc near its end point {end} LSB "
                            f"(relative to the start): its digital path of radius "
                            f"{math.hypot(i, j):.1f} LSB does not pass within "
                            f"{REPAIR_REACH} LSB of it in the programmed direction")
        return best[1], best[2]

    @staticmethod
    def _close(end: tuple[int, int], result: Plan, i: int, j: int, cw: bool) -> bool:
        """Whether the chip's plan ends near ``end`` after the programmed sweep: no ERROR,
        and the arc length between the two sweeps no longer than their distance + 2 LSB."""
        if result.error:
            return False
        full = end == (0, 0)
        sweep = _sweep(i, j, end, cw)[1]
        chip = _sweep(i, j, result.end, cw)[1]
        if full:  # a full circle must close
            return result.end == (0, 0)
        return math.hypot(i, j) * abs(chip - sweep) <= math.dist(result.end, end) + 2

    def _check_sweep(self, start: tuple[int, int, int], axes: tuple[int, int],
                     ij: tuple[int, int], end: tuple[int, int], cw: bool) -> None:
        """Refuse an arc whose path leaves the 24-bit absolute range between its ends."""
        i, j = ij
        r = math.hypot(i, j)
        cx, cy = start[axes[0]] + i, start[axes[1]] + j
        if max(abs(cx), abs(cy)) + r <= COORD_MAX:
            return  # the whole circle is in range (most arcs)
        a0, sweep = _sweep(i, j, end, cw)
        sign = -1 if cw else 1
        for k, (axis, limit) in enumerate(((0, cx + r), (1, cy + r), (0, cx - r), (1, cy - r))):
            offset = (sign * (k * math.pi / 2 - a0)) % math.tau
            crossed = offset <= sweep + 1e-9 or offset >= math.tau - 1e-9
            if crossed and math.ceil(abs(limit) - 1e-9) > COORD_MAX:
                raise PlanError(f"the arc leaves the coordinate range on "
                                f"{AXIS_LETTERS[axes[axis]]}: it reaches {limit:.0f} LSB, "
                                f"beyond +-(2^23-1) LSB (+-{self.mm(COORD_MAX)})")
