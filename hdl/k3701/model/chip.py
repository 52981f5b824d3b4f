"""Reference model of the KM3701 interpolator (``docs/chips/k3701.md``), in plain Python.

Two layers:

* the paths state the interpolation algorithms step by step, with no notion of time, one
  module beside each datapath: :class:`~k37.hdl.k3701.datapaths.model.linear.LinearPath`,
  :class:`~k37.hdl.k3701.datapaths.model.circular.CircularPath` (and a helix's
  :class:`~k37.hdl.k3701.datapaths.model.helix.HelixPath`),
  :class:`~k37.hdl.k3701.datapaths.model.parabolic.ParabolicPath` and
  :class:`~k37.hdl.k3701.datapaths.model.parabolic.ExponentialPath`, on the block, step and
  constants of :mod:`k37.hdl.k3701.block`. :func:`make_path` picks a block's path and :func:`plan`
  runs a whole block through it: the exact FP-count calculator the firmware model uses.
* :class:`K3701Model` adds the chip's timing, cycle by cycle: BUSY, the step latency, the FP
  credit in half-FP units (quarter-FP units on the three-axis chip), the one-FP hold and the
  overrun bit. The gateware (:mod:`k37.hdl.k3701.chip`) is tested against it cycle by cycle.

The three-axis K3701 (``axes=3``) takes a block in its own coordinates (first, second,
third): a line moves all three (``LinearPath`` steps the longest of the three), an arc runs in
the first two and a helix moves the third, the plane's normal, with the arc (``HelixPath``);
a parabola or an exponential runs in the first two and is refused with a third coordinate;
``Block.plane`` routes the three to the machine's X, Y and Z
(:func:`~k37.hdl.k3701.block.route`).
"""

from __future__ import annotations

import enum
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, replace

from k37.hdl.common.constants import ALL_AXES
from k37.hdl.k3701.block import (
    CIRCLE_SETUP_CYCLES,
    LATENCY_CIRCULAR,
    LATENCY_LINEAR,
    Block,
    BlockError,
    Kind,
    Step,
    check_coord,
    route,
    step_cost,
)
from k37.hdl.k3701.datapaths.model.circular import CircularPath, HelicalPath
from k37.hdl.k3701.datapaths.model.helix import HelixPath
from k37.hdl.k3701.datapaths.model.linear import Dda, LinearPath
from k37.hdl.k3701.datapaths.model.parabolic import ExponentialPath, ParabolicPath

__all__ = ["K3701Model", "K3701Outputs", "Path", "Plan", "fp_of_steps", "make_path", "plan",
           "walk"]

Path = LinearPath | CircularPath | HelicalPath | ParabolicPath | ExponentialPath


def make_path(block: Block) -> Path:
    """The algorithm for a block; raises :class:`BlockError` for data the chip refuses."""
    if block.kind is Kind.LINEAR:
        return LinearPath(block.xe, block.ye, block.ze)
    if block.kind is Kind.CIRCULAR:
        arc = CircularPath(block.xe, block.ye, block.i, block.j, block.cw, block.quadrant)
        return HelicalPath(arc, HelixPath(block.ze, block.helix_steps)) if block.ze else arc
    if block.ze:  # the three-axis chip: a curve runs in the block's first two axes only
        raise BlockError(f"a {block.kind.name.lower()} block runs in its plane only: its third "
                         f"coordinate Ze is {block.ze}, not 0")
    if block.kind is Kind.PARABOLIC:
        return ParabolicPath(block.xe, block.ye, block.i, block.j, block.swap)
    return ExponentialPath(block.xe, block.ye, block.i, block.cw, block.j, block.frac,
                           block.swap)


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


def _coincident(a: Dda, b: Dda) -> int:
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


def fp_of_steps(steps: int, two: int, three: int, sqrt2: bool) -> int:
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
        ends = (block.xe, block.ye, block.ze)
        for name, end in zip(("Xe", "Ye", "Ze"), ends, strict=True):
            check_coord(name, end)
        # the DDA on the longest axis (LinearPath), counted without a walk
        low, mid, n = sorted(map(abs, ends))
        three = _coincident(Dda(low, n), Dda(mid, n)) if low else 0
        diag = low + mid - three
        pulses = {"x+": max(block.xe, 0), "x-": max(-block.xe, 0),
                  "y+": max(block.ye, 0), "y-": max(-block.ye, 0),
                  "z+": max(block.ze, 0), "z-": max(-block.ze, 0)}
        return Plan(n, diag, fp_of_steps(n, diag - three, three, block.sqrt2), ends[:2], False,
                    pulses, block.ze)
    # an arc without its helix (spread over its steps below); a curve as it is (refused
    # with a third coordinate)
    path = make_path(replace(block, ze=0) if block.kind is Kind.CIRCULAR else block)
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
              for axis in ALL_AXES for sign in "+-"}
    end = (pulses["x+"] - pulses["x-"], pulses["y+"] - pulses["y-"])
    return Plan(len(steps), counts[2] + counts[3],
                fp_of_steps(len(steps), counts[2], counts[3], block.sqrt2), end, error, pulses,
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
    |Ze| exceeds its step count N ends at the radius check with ERROR, and a parabola or an
    exponential with Ze other than 0 at the end of its setup.
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
