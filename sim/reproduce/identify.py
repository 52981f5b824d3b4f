"""The filters paper's missing resonance, identified from one of its numbers and tested on another.

Fig. 12 gives the corner following error of the linear filter (70 um at 15 ms, 9 um at 30 ms)
and of the exponential filter (60 and 8 um), but not the machine's resonance or damping. The
corner runs on the two-mass drive of :data:`~k37.sim.reproduce.filters.RESONANT_SERVO` with the
free-mode frequency and damping ratio as the unknowns (masses, lead and velocity loop kept): a
bracketed grid of both (:func:`coarse_grid`) is run with the linear filter, the point nearest
the paper's two linear numbers is refined on a finer grid around it (:func:`refine_grid`, run
with both filters), and the exponential filter's errors at the identified point are the
prediction of the paper's 60 and 8 um. The measured quantity is the corner rows' own: the
largest |command - actual| of either axis over the run (LSB = 1 um).

:func:`specs` declares the coarse grid's runs, :func:`follow_up` the refinement's once the
coarse runs are in; :func:`identify` reads both.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from k37.firmware_model.job import ServoConfig
from k37.sim.reproduce.runs import RunData, RunSpec, Scale, Specs

__all__ = ["FIT_TOLERANCE", "PREDICTION_TOLERANCE", "Fit", "Point", "Problem", "coarse_grid",
           "follow_up", "identify", "refine_grid", "residual", "resonant_servo", "specs",
           "within"]

#: A fit reproduces a number when within this fraction of it, and a prediction holds when each
#: of its numbers is (both stated before the runs).
FIT_TOLERANCE = 0.25
PREDICTION_TOLERANCE = 0.25
#: The coarse grid: free-mode frequencies (Hz) and damping ratios, log-spaced, per scale.
_HZ = {"full": (10.0, 100.0, 9), "quick": (10.0, 100.0, 5)}
_ZETA = {"full": (0.005, 0.2, 4), "quick": (0.005, 0.2, 2)}
#: The refinement per scale: steps per coarse step of the frequency and of the damping (the
#: finer grid spans one coarse step either side of the coarse best).
_REFINE = {"full": (4, 2), "quick": (2, 1)}
#: Points whose errors are within this (LSB) of the best fit's are as good as it.
_EQUAL_LSB = 1.0


@dataclass(frozen=True, order=True)
class Point:
    """One candidate of the unknowns: the free-mode frequency (Hz) and damping ratio."""

    hz: float
    zeta: float

    @property
    def tag(self) -> str:
        return f"{self.hz:.2f}hz_{100 * self.zeta:.3f}pct"


def resonant_servo(base: ServoConfig, point: Point) -> ServoConfig:
    """``base`` (a two-mass drive of equal motor and table sides) with its spring and damping
    set for ``point``'s free mode."""
    w = 2 * math.pi * point.hz
    half = base.mass / 2  # the reduced mass of two equal masses
    return dataclasses.replace(base, ks=w**2 * half, cs=2 * point.zeta * w * half)


def coarse_grid(scale: Scale) -> list[Point]:
    """The bracketing grid at ``scale``."""
    return [Point(float(h), float(z)) for h in np.geomspace(*_HZ[scale.name])
            for z in np.geomspace(*_ZETA[scale.name])]


def refine_grid(scale: Scale, best: Point) -> list[Point]:
    """The finer grid around the coarse grid's ``best``: steps of a fraction of the coarse
    steps (:data:`_REFINE`), over one coarse step either side, within the coarse bounds."""
    steps = []
    for (low, high, count), value, per in zip((_HZ[scale.name], _ZETA[scale.name]),
                                              (best.hz, best.zeta), _REFINE[scale.name],
                                              strict=True):
        ratio = (high / low) ** (1 / (count - 1))
        values = (value * ratio ** (k / per) for k in range(-per, per + 1))
        steps.append([v for v in values if low * (1 - 1e-9) <= v <= high * (1 + 1e-9)])
    return [Point(h, z) for h in steps[0] for z in steps[1]]


def _key(stage: str, shape: str, tau: float, point: Point) -> str:
    return f"s000_identify_{stage}_{shape}_{round(1e3 * tau)}ms_{point.tag}"


@dataclass(frozen=True)
class Problem:
    """What the identification runs: the corner's run (key, shape, time constant, servo), the
    measured quantity of a run, the two-mass drive whose spring is unknown, the time constants,
    the paper's numbers by shape, the shape identified from and the one predicted."""

    corner: Callable[[str, str, float, ServoConfig], RunSpec]
    peak: Callable[[RunData], float]
    base: ServoConfig
    taus: tuple[float, float]
    paper: Mapping[str, tuple[int, int]]
    fitted: str = "linear"
    predicted: str = "exponential"


def _runs(problem: Problem, stage: str, points: Sequence[Point],
          shapes: Sequence[str]) -> Specs:
    out: Specs = {}
    for point in points:
        servo = resonant_servo(problem.base, point)
        for shape in shapes:
            for tau in problem.taus:
                key = _key(stage, shape, tau, point)
                out[key] = problem.corner(key, shape, tau, servo)
    return out


def specs(problem: Problem, scale: Scale) -> Specs:
    """The coarse grid's runs: the fitted shape at both time constants."""
    return _runs(problem, "coarse", coarse_grid(scale), (problem.fitted,))


def residual(measured: Sequence[float], paper: Sequence[float]) -> float:
    """The misfit of ``measured`` against ``paper``: the largest factor by which a number is
    missed, either way (1: every number met), so that a miss of the small number weighs as much
    as the same factor on the large one."""
    return max(max(m / p, p / m) if m > 0 else math.inf
               for m, p in zip(measured, paper, strict=True))


def within(measured: Sequence[float], paper: Sequence[float], tolerance: float) -> bool:
    """Whether each of ``measured`` is within ``tolerance`` (a fraction) of the paper's."""
    return all(abs(m / p - 1) <= tolerance for m, p in zip(measured, paper, strict=True))


def _scan(problem: Problem, runs: Mapping[str, RunData], stage: str,
          points: Sequence[Point]) -> dict[Point, tuple[float, float]]:
    return {p: (problem.peak(runs[_key(stage, problem.fitted, problem.taus[0], p)]),
                problem.peak(runs[_key(stage, problem.fitted, problem.taus[1], p)]))
            for p in points}


def _best(scan: Mapping[Point, tuple[float, float]], paper: Sequence[float]) -> Point:
    return min(scan, key=lambda p: (residual(scan[p], paper), p))


def follow_up(problem: Problem, runs: Mapping[str, RunData], scale: Scale) -> Specs:
    """The refinement's runs (both shapes) around the coarse grid's best point, once the coarse
    runs are in ``runs`` and the refinement's are not; else none."""
    coarse = coarse_grid(scale)
    if any(_key("coarse", problem.fitted, problem.taus[0], p) not in runs for p in coarse):
        return {}
    best = _best(_scan(problem, runs, "coarse", coarse), problem.paper[problem.fitted])
    fine = _runs(problem, "fine", refine_grid(scale, best),
                 (problem.fitted, problem.predicted))
    return {} if fine.keys() <= runs.keys() else fine


@dataclass(frozen=True)
class Fit:
    """The identified point and the coarse grid's best; the fitted shape's errors there (LSB),
    the paper's numbers and the residual; the predicted shape's errors and the paper's; the
    range of the finer grid's points as good as the identified one (frequencies and damping
    ratios, low and high); the number of runs."""

    point: Point
    coarse: Point
    fitted: tuple[float, float]
    paper: tuple[float, float]
    residual: float
    predicted: tuple[float, float]
    paper_predicted: tuple[float, float]
    span: tuple[Point, Point]
    runs: int

    @property
    def fits(self) -> bool:
        """The fitted shape's errors within :data:`FIT_TOLERANCE` of the paper's."""
        return within(self.fitted, self.paper, FIT_TOLERANCE)

    @property
    def holds(self) -> bool:
        """A fit, and the prediction within :data:`PREDICTION_TOLERANCE` of the paper's."""
        return self.fits and within(self.predicted, self.paper_predicted,
                                    PREDICTION_TOLERANCE)


def identify(problem: Problem, runs: Mapping[str, RunData], scale: Scale) -> Fit:
    """The coarse grid's best point, refined, and the prediction at the refined point."""
    coarse = coarse_grid(scale)
    paper = problem.paper[problem.fitted]
    best = _best(_scan(problem, runs, "coarse", coarse), paper)
    fine = refine_grid(scale, best)
    scan = _scan(problem, runs, "fine", fine)
    point = _best(scan, paper)
    short, long = (problem.peak(runs[_key("fine", problem.predicted, tau, point)])
                   for tau in problem.taus)
    alike = [p for p, errors in scan.items()
             if max(abs(a - b) for a, b in zip(errors, scan[point], strict=True)) <= _EQUAL_LSB]
    span = (Point(min(p.hz for p in alike), min(p.zeta for p in alike)),
            Point(max(p.hz for p in alike), max(p.zeta for p in alike)))
    return Fit(point, best, scan[point], paper, residual(scan[point], paper), (short, long),
               problem.paper[problem.predicted], span, 2 * len(coarse) + 4 * len(fine))
