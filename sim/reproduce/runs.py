"""The experiments' runs: the machine, the scales, what each run is and what it sends back.

:func:`run_specs` lists every run at a :class:`Scale`: a :class:`RunSpec` is a G-code program
on the machine with the accel/decel circuit before (``pre``) or after (``post``) the
interpolator, the :class:`RateSpec` the step-rate measurement. :mod:`k37.sim.reproduce.workers`
executes them; each comes back as a :class:`RunData`, whose samples :class:`Trace` reads.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import TypeVar

import numpy as np

from k37.firmware_model.feeds import word_feed
from k37.firmware_model.gcode.parser import parse
from k37.firmware_model.job import AxisAccelConfig, ContourConfig, Job, MachineConfig, ServoConfig
from k37.firmware_model.motion.program import Arc, Line, Parabola, Program
from k37.firmware_model.motion.splines import Nurbs, SplineSpan
from k37.hdl.k3701.block import Block
from k37.sim.reproduce.paper import FEED_HIGH, FEED_LOW
from k37.sim.reproduce.theory import hardware_tau
from k37.sim.run.sampler import TRACE_COLUMNS

__all__ = ["FULL", "MACHINE", "PARABOLA_FEED", "PARABOLA_MM", "QUICK", "SERVO", "RateSpec",
           "RunData", "RunSpec", "Scale", "Specs", "Trace", "minus_spec", "parabola_y",
           "run_specs"]


@dataclass(frozen=True)
class Scale:
    """The sizes of the runs (LSB = 1 um); the paper gives no sizes, only feeds and tau."""

    name: str
    #: Experiments 1 and 5: the line (X, Y) at the high feed; its FP budget sets how long the
    #: feed stays on (25000 FP at 21.4 kFP/s: 1.17 s, 3.9 tau).
    line: tuple[int, int]
    #: Experiments 4 and 5: radius of the full circles at the high feed.
    radius: int
    #: Experiment 4: radius of the low-feed arc and its sweep (degrees, CCW from the x axis).
    low_radius: int
    low_sweep: int
    #: Experiment 6: length of the X line and its feed (FP/s).
    hazard_steps: int
    hazard_fp_s: float
    #: Experiment 2: steps counted at the maximum rate, per interpolation type.
    rate_steps: int
    #: Experiment 7: the G01 chords the parabola of the contour-error paper is cut into (equal steps
    #: in X).
    parabola_chords: int = 30
    #: Sampling period of the closed-loop runs (cycles).
    sample_every: int = 1000


FULL = Scale("full", line=(20_000, 10_000), radius=3000, low_radius=150, low_sweep=90,
             hazard_steps=300, hazard_fp_s=1000.0, rate_steps=20_000)
QUICK = Scale("quick", line=(10_000, 5000), radius=3000, low_radius=100, low_sweep=45,
              hazard_steps=100, hazard_fp_s=1000.0, rate_steps=5000, parabola_chords=10)

#: Experiment 7: the contour-error paper's parabola y = (x - 15)^2 / 15 - 15 (mm) from x = 0 to 30,
#: and the feed both of its programs run at (mm/min).
PARABOLA_MM = (30.0, 15.0)
PARABOLA_FEED = 1000.0


def parabola_y(x_mm: float) -> float:
    """The contour-error paper's parabola (mm)."""
    return (x_mm - 15.0) ** 2 / 15.0 - 15.0

#: The machine by accel/decel placement, and every axis's servo: the defaults.
MACHINE = {accel: MachineConfig(accel=accel) for accel in ("pre", "post")}
SERVO = ServoConfig()

_Move = TypeVar("_Move", Line, Arc, Parabola)


def _with_curve(program: Program, curve: Nurbs, ends: tuple[float, ...]) -> Program:
    """``program`` with its G01 chords carrying the exact curve between ``ends``."""
    chords = [k for k, item in enumerate(program.items) if isinstance(item, Line)]
    if len(chords) != len(ends) - 1:
        raise ValueError(f"{len(chords)} chords for {len(ends) - 1} spans of the curve")
    items = list(program.items)
    for n, k in enumerate(chords):
        items[k] = replace(items[k], curve=SplineSpan(curve, ends[n], ends[n + 1]))
    return replace(program, items=tuple(items))


@dataclass(frozen=True)
class RunSpec:
    """One closed-loop run of a G-code program on the machine with ``accel``.

    The companion papers' runs name their own machine, servos and per-axis accel/decel
    circuits; runs whose machines elaborate the same design share one compiled model
    (:func:`~k37.sim.run.runner.design_key`).
    """

    key: str
    accel: str
    gcode: str
    sample_every: int
    max_cycles: int = 10**9
    budget_offset: int = 0
    #: After the run, keep stepping until the accel/decel circuit is empty (at most this
    #: many cycles), to see where its last pulses go.
    drain_cycles: int = 0
    #: The machine (default ``MACHINE[accel]``; its ``accel`` must be ``accel``).
    machine: MachineConfig | None = None
    #: Servo overrides by axis (default :data:`SERVO` on every axis).
    servo: Mapping[str, ServoConfig] = field(default_factory=dict)
    #: Per-axis accel/decel circuits (``[machine.x]``, ...; the post placement only).
    axis_accel: Mapping[str, AxisAccelConfig] = field(default_factory=dict)
    #: The host's contour controller (``[contour]``; default none).
    contour: ContourConfig = field(default_factory=ContourConfig)
    #: The exact curve the program's G01 chords cut, as a G5 spline's chords carry it: the
    #: spline (LSB) and its parameter at every chord end, in order (the host's CEC and the
    #: report measure against it).
    exact: tuple[Nurbs, tuple[float, ...]] | None = None
    #: The first-order plants' update period (servo ``update_cycles``) on every axis; 1: the
    #: papers' plant, updated every cycle.
    update_cycles: int = 1

    def __post_init__(self) -> None:
        if self.machine is not None and self.machine.accel != self.accel:
            raise ValueError(f"run {self.key}: machine.accel {self.machine.accel!r} is not "
                             f"{self.accel!r}")

    def job(self) -> Job:
        machine = self.machine or MACHINE[self.accel]
        program = parse(self.gcode, source=f"<{self.key}>", lsb_mm=machine.lsb_mm,
                        sqrt2=machine.sqrt2)
        servo = {axis: self.servo.get(axis, SERVO) for axis in machine.axis_names}
        if self.update_cycles != 1:
            servo = {axis: replace(s, update_cycles=self.update_cycles)
                     if s.drive == "first_order" else s for axis, s in servo.items()}
        if self.exact is not None:
            program = _with_curve(program, *self.exact)
        return Job(self.key, machine, servo, program, axis_accel=dict(self.axis_accel),
                   contour=self.contour)

    def move(self, kind: type[_Move]) -> _Move:
        """The program's first move (the one observed), which must be a ``kind``."""
        item = self.job().program.items[0]
        if not isinstance(item, kind):
            raise TypeError(f"run {self.key} does not start with a {kind.__name__}")
        return item


@dataclass(frozen=True)
class RateSpec:
    """Experiment 2: K3701 blocks run with FP offered every cycle (the post machine)."""

    key: str
    #: (name, block, port counting one pulse per step, steps to count)
    blocks: tuple[tuple[str, Block, str, int], ...]
    accel: str = "post"

    def job(self) -> Job:
        """An empty job on the machine the blocks run on."""
        return RunSpec(self.key, self.accel, "M30", 1).job()


Specs = dict[str, RunSpec | RateSpec]


@dataclass
class RunData:
    """What a worker sends back: the report and samples of a run, probes, wall time."""

    key: str
    report: dict
    samples: np.ndarray
    probes: dict[str, int]
    seconds: float


_COL = {name: k for k, name in enumerate(TRACE_COLUMNS)}


class Trace:
    """A closed-loop run's samples as seconds since its first block started, and columns."""

    def __init__(self, data: RunData, clock_hz: float):
        self.data = data
        self.block = data.report["blocks"][0]
        s = data.samples
        self.t = (s[:, _COL["cycle"]] - self.block["start_cycle"]) / clock_hz
        self.cols = {name: s[:, k] for name, k in _COL.items()}
        self.clock_hz = clock_hz

    def __getitem__(self, name: str) -> np.ndarray:
        return self.cols[name]

    def seconds(self, cycle: int) -> float:
        return (cycle - self.block["start_cycle"]) / self.clock_hz

    def rate(self, name: str, window_s: float) -> tuple[np.ndarray, np.ndarray]:
        """Mid-window times and the rate of column ``name`` over windows of ``window_s``."""
        w = max(1, round(window_s / (self.t[1] - self.t[0])))
        v = self[name]
        return (self.t[w:] + self.t[:-w]) / 2, (v[w:] - v[:-w]) / (self.t[w:] - self.t[:-w])


#: Dwell (s) after the last move: three times 1 / Kp, so the servo has made its last count.
REST_S = 0.1


def _mm(lsb: int, machine: MachineConfig) -> str:
    return f"{lsb * machine.lsb_mm:.3f}"


def _arc_end(radius: int, sweep_deg: int) -> tuple[int, int]:
    """End of a CCW arc from the x axis through ``sweep_deg``, relative to its start."""
    a = math.radians(sweep_deg)
    return round(radius * math.cos(a)) - radius, round(radius * math.sin(a))


def _tau_cycles() -> int:
    """The accel/decel time constant of the pre machine, in cycles."""
    pre = MACHINE["pre"]
    return round(hardware_tau(pre) * pre.clock_hz)


def run_specs(scale: Scale) -> Specs:
    """Every run of the experiments at ``scale`` (the budget-too-low run comes later)."""
    pre = MACHINE["pre"]
    high, low = word_feed(pre, FEED_HIGH), word_feed(pre, FEED_LOW)
    every = scale.sample_every
    x, y = scale.line
    r = scale.radius
    ex, ey = _arc_end(scale.low_radius, scale.low_sweep)
    # A dwell at the end lets the servo finish its last count before the firmware's settle
    # check (which is satisfied inside the position zone).
    rest = f"G04 P{REST_S}\nM30"
    circle = f"G17 G21 G91\nG03 I-{_mm(r, pre)} J0 F{high:.6f}\n{rest}"
    hazard = (f"G17 G21 G91\nG01 X{_mm(scale.hazard_steps, pre)} "
              f"F{pre.mm_per_min(scale.hazard_fp_s):.6f}\n{rest}")
    big = 100_000  # a radius whose first octant holds the whole circular count
    span, vertex = PARABOLA_MM
    chords = "\n".join(f"G01 X{span * k / scale.parabola_chords:.4f} "
                       f"Y{parabola_y(span * k / scale.parabola_chords):.4f}"
                       for k in range(1, scale.parabola_chords + 1))
    return {
        "parabola": RunSpec("parabola", "pre",
                            f"G17 G21 G90 F{PARABOLA_FEED:g}\nG06 X{span:g} Y0 I{vertex:g} "
                            f"J{parabola_y(vertex):g}\n{rest}", every),
        "parabola_chords": RunSpec("parabola_chords", "pre",
                                   f"G17 G21 G90 F{PARABOLA_FEED:g}\n{chords}\n{rest}", every),
        "hazard_exact": RunSpec("hazard_exact", "pre", hazard, every),
        "line": RunSpec("line", "pre",
                        f"G17 G21 G91\nG01 X{_mm(x, pre)} Y{_mm(y, pre)} F{high:.6f}\n{rest}",
                        every),
        "pre_circle": RunSpec("pre_circle", "pre", circle, every),
        "hazard_plus": RunSpec("hazard_plus", "pre", hazard, every, budget_offset=1,
                               drain_cycles=3 * _tau_cycles()),
        "post_low": RunSpec("post_low", "post",
                            f"G17 G21 G91\nG03 X{_mm(ex, pre)} Y{_mm(ey, pre)} "
                            f"I-{_mm(scale.low_radius, pre)} J0 F{low:.6f}\nM30", every),
        "post_high": RunSpec("post_high", "post", circle, every),
        "rates": RateSpec("rates", (
            ("linear", Block.line(scale.rate_steps + 1000, 0), "x__pulses_pos",
             scale.rate_steps),
            ("circular", Block.arc(0, 0, -big, 0), "y__pulses_pos", scale.rate_steps),
        )),
    }


def minus_spec(exact: RunData, spec: RunSpec) -> RunSpec:
    """The budget-too-low run: stopped 3 tau after the exact run's block ended."""
    end = exact.report["blocks"][0]["end_cycle"]
    return RunSpec("hazard_minus", spec.accel, spec.gcode, spec.sample_every,
                   max_cycles=end + 3 * _tau_cycles(), budget_offset=-1)
