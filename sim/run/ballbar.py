"""Ballbar analysis of a circular run, as ISO 230-4 and a double-ballbar report give it.

The nominal circle is the program's arcs' (they must share one centre and radius); the data
are the samples taken while an arc block ran, from the first arc's start to the last arc's
end, less the feed-in and the feed-out, as ISO 230-4 leaves them out of the evaluated arc:
by default the samples before the tool first reaches :data:`STEADY_FRACTION` of its steady
speed round the circle and those after it last had it (:func:`feed_in_out`); with a settle
angle, the first that many degrees instead (the feed-out kept). For each sample, the radial
deviation dr = |p - c| - R (LSB) at the angle theta of p around the centre. Figures:

* ``mean_radius_deviation``: the mean of dr (the radius loss of the motion-errors paper's eqs
  (9)/(10));
* ``circularity``: max dr - min dr (ISO 230-4's circular deviation G, peak to valley);
* a least-squares fit dr = a0 + a1 cos t + b1 sin t + a2 cos 2t + b2 sin 2t:
  ``centre_offset`` (the first harmonic's amplitude) and the **2-theta component**,
  ``two_theta_amplitude`` = hypot(a2, b2) and ``two_theta_angle`` = atan2(b2, a2)/2 (deg, in
  [0, 180)): where the ellipse's long axis points. A gain or time-constant mismatch between
  X and Y makes that ellipse (the motion-errors paper's Fig. 8), its long axis at 45 or 135 degrees;
* ``reversal_spikes``: at each axis reversal (theta = 0, 90, 180, 270 deg) the largest
  |dr - fit| within ``SPIKE_WINDOW_DEG`` of it (a quadrant glitch); ``None`` for a reversal
  the data do not sweep across (the whole window on either side of it: a 180-degree arc
  from 0 to 180 degrees sweeps across 90 only);
* ``sweep``: the degrees the data cover; ``path_speed``: the tool's median speed round the
  circle over 20 ms windows (LSB/s): in a steady circle, the V of the radius-loss and
  mismatch formulas (the K3701's sqrt(2) control runs a circle some 9% under its programmed
  feed); with long accel/decel ramps, less.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from k37.firmware_model.motion.program import Arc
from k37.sim.run.report import BALLBAR_FIGURES as FIGURES

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from k37.firmware_model.job import Job
    from k37.sim.run.runner import RunResult

__all__ = ["FIGURES", "SPIKE_WINDOW_DEG", "STEADY_FRACTION", "Ballbar", "BallbarError",
           "arc_sweep", "ballbar", "ballbar_figure", "ballbar_of", "break_at_gaps",
           "check_settle", "circle_figures", "feed_in_out"]

#: Half-width of the window around each axis reversal a spike is looked for in (deg).
SPIKE_WINDOW_DEG = 5.0
#: The feed-in ends where the tool first reaches this fraction of its steady speed round the
#: circle (the 90th percentile of its speeds over 20 ms windows: the K3701's sqrt(2) control
#: makes the speed ripple by a few per cent round a circle); the feed-out begins where it
#: last had it.
STEADY_FRACTION = 0.9
#: A step between two consecutive samples larger than this many times the median step is a
#: gap in the data: the plot breaks its line there.
GAP_STEPS = 5.0


class BallbarError(ValueError):
    """A run that is not a ballbar test: no arc, arcs on different circles, too few samples."""


@dataclass(frozen=True)
class Ballbar:
    """The figures of one circular run (LSB and degrees; see the module docstring)."""

    center: tuple[float, float]
    radius: float
    samples: int
    sweep: float
    path_speed: float
    mean_radius_deviation: float
    circularity: float
    centre_offset: float
    two_theta_amplitude: float
    two_theta_angle: float
    reversal_spikes: tuple[float | None, float | None, float | None, float | None]
    theta: np.ndarray
    deviation: np.ndarray

    def figures(self) -> dict[str, float | None]:
        """The scalar figures of :data:`FIGURES`, for a report or a results table."""
        return {"nominal_radius": self.radius, "ballbar_samples": self.samples,
                "ballbar_sweep": self.sweep, "path_speed": self.path_speed,
                **{name: getattr(self, name) for name in list(FIGURES)[4:9]},
                **{f"reversal_spike_{q}": s
                   for q, s in zip((0, 90, 180, 270), self.reversal_spikes, strict=True)}}


def _circle(job: Job) -> tuple[list[Arc], tuple[int, int], float]:
    arcs = [item for item in job.program.items if isinstance(item, Arc)]
    if not arcs:
        raise BallbarError("the program has no arc: a ballbar test runs a circle")
    center, radius = arcs[0].center, arcs[0].radius
    for arc in arcs[1:]:
        if arc.plane != arcs[0].plane or arc.center != center or abs(arc.radius - radius) > 2:
            raise BallbarError(f"the arcs are not on one circle (line {arc.line_no}: centre "
                               f"{arc.center}, radius {arc.radius:.1f} LSB; line "
                               f"{arcs[0].line_no}: {center}, {radius:.1f})")
    return arcs, center, radius


def _steady_speed(t: np.ndarray, angle: np.ndarray, radius: float) -> float:
    """The median of the tool's speed round the circle over 20 ms windows (LSB/s)."""
    if t[-1] <= t[0]:
        return 0.0
    window = max(1, int(np.searchsorted(t, t[0] + 0.02)))
    window = min(window, len(t) - 1)
    rate = (angle[window:] - angle[:-window]) / (t[window:] - t[:-window])
    return float(np.median(np.abs(rate)) * radius)


def arc_sweep(job: Job) -> float:
    """The degrees the program's arcs sweep in all (:class:`BallbarError` if they are not
    one circle)."""
    arcs, _, _ = _circle(job)
    return math.degrees(sum(arc.span[1] for arc in arcs))


def check_settle(job: Job, settle_deg: float | None) -> None:
    """Refuse (:class:`BallbarError`) a settle angle that leaves out the whole circle: one of
    the program's arcs' total sweep or more. A program that is no circle passes (its run
    gets the warning)."""
    if settle_deg is None:
        return
    try:
        sweep = arc_sweep(job)
    except BallbarError:
        return
    if not 0 <= settle_deg < sweep:
        raise BallbarError(f"a settle angle of {settle_deg:g} degrees leaves out the whole "
                           f"circle: the program's arcs sweep {sweep:.4g} degrees; give less")


def ballbar(result: RunResult, settle_deg: float | None = None) -> Ballbar:
    """The ballbar figures of a run of a circular program (:class:`BallbarError` if not),
    leaving out the feed-in and the feed-out (:func:`feed_in_out`), or, with ``settle_deg``,
    the data until the tool has gone that many degrees round the circle (ISO 230-4's
    overshoot arc)."""
    return ballbar_of(result.job, result.report, result.store.chunks(), result.store.columns,
                      settle_deg)


def ballbar_of(job: Job, report: dict, chunks: Iterable[np.ndarray], columns: Sequence[str],
               settle_deg: float | None = None) -> Ballbar:
    """:func:`ballbar` of ``job``'s run given as its report and its samples (``chunks`` of
    rows of ``columns``)."""
    arcs, (cx, cy), radius = _circle(job)
    indices = {arc.index for arc in arcs}
    spans = [(b["start_cycle"], b["end_cycle"] if b["end_cycle"] is not None else math.inf)
             for b in report["blocks"] if b["index"] in indices]
    if not spans:
        raise BallbarError("no arc block ran")
    first, last = spans[0][0], spans[-1][1]
    names = job.machine.axis_names
    first_axis, second_axis, _ = arcs[0].plane_axes
    cx_col = columns.index(f"{names[first_axis]}_actual")
    cy_col = columns.index(f"{names[second_axis]}_actual")
    t, x, y = [], [], []
    for chunk in chunks:
        mine = (chunk[:, 0] >= first) & (chunk[:, 0] <= last)
        t.append(chunk[mine, 0] / report["clock_hz"])
        x.append(chunk[mine, cx_col])
        y.append(chunk[mine, cy_col])
    return circle_figures(np.concatenate(t), np.concatenate(x) - cx, np.concatenate(y) - cy,
                          radius, settle_deg, (float(cx), float(cy)))


def feed_in_out(t: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Which samples (at times ``t``, ``angle`` unwrapped round the circle, rad) are off the
    feed-in and the feed-out: from the first sample whose speed round the circle (over 20 ms
    windows) reaches :data:`STEADY_FRACTION` of its steady speed to the last that has it."""
    keep = np.zeros(len(t), dtype=bool)
    if len(t) < 3 or t[-1] <= t[0]:
        return ~keep
    window = min(max(1, int(np.searchsorted(t, t[0] + 0.02))), len(t) - 1)
    rate = np.abs(angle[window:] - angle[:-window]) / (t[window:] - t[:-window])
    steady = np.flatnonzero(rate >= STEADY_FRACTION * np.percentile(rate, 90))
    # window k spans samples k .. k + window: its speed is had from its first to its last
    keep[steady[0]:steady[-1] + window + 1] = True
    return keep


def _swept(degrees: np.ndarray, q: float) -> bool:
    """Whether the unwrapped ``degrees`` cross the whole spike window round ``q``."""
    lo, hi = degrees.min(), degrees.max()
    k = math.ceil((lo + SPIKE_WINDOW_DEG - q) / 360)
    return q + 360 * k + SPIKE_WINDOW_DEG <= hi


def circle_figures(t: np.ndarray, px: np.ndarray, py: np.ndarray, radius: float,
                   settle_deg: float | None = 0.0, center: tuple[float, float] = (0.0, 0.0)
                   ) -> Ballbar:
    """The ballbar figures of the samples at times ``t`` (s) of a path round a circle of
    ``radius``: ``px``, ``py`` relative to its ``center`` (LSB), after ``settle_deg`` (None:
    without the feed-in and the feed-out, :func:`feed_in_out`)."""
    available = len(px)
    if len(px):
        unwrapped = np.unwrap(np.arctan2(py, px))
        if settle_deg is None:
            keep = feed_in_out(t, unwrapped)
        else:
            keep = np.abs(unwrapped - unwrapped[0]) >= math.radians(settle_deg)
        t, px, py = t[keep], px[keep], py[keep]
    if len(px) < 16:
        left = "" if len(px) == available else \
            (f" of {available} once the feed-in and feed-out are left out" if settle_deg is None
             else f" of {available} once the first {settle_deg:g} degrees are left out")
        raise BallbarError(f"{len(px)} samples on the circle{left}: too few (sample more "
                           f"often{'' if left == '' else ', or leave out less'})")
    theta = np.arctan2(py, px)
    dr = np.hypot(px, py) - radius
    basis = np.column_stack([np.ones_like(theta), np.cos(theta), np.sin(theta),
                             np.cos(2 * theta), np.sin(2 * theta)])
    coef, *_ = np.linalg.lstsq(basis, dr, rcond=None)
    residual = dr - basis @ coef
    degrees = np.degrees(theta) % 360
    unwrapped = np.unwrap(theta)
    spikes: list[float | None] = []
    for q in (0, 90, 180, 270):
        near = np.abs((degrees - q + 180) % 360 - 180) <= SPIKE_WINDOW_DEG
        swept = _swept(np.degrees(unwrapped), q)
        spikes.append(float(np.abs(residual[near]).max()) if swept and near.any() else None)
    return Ballbar(
        center=center, radius=float(radius), samples=len(dr),
        sweep=float(np.degrees(unwrapped.max() - unwrapped.min())),
        path_speed=_steady_speed(t, unwrapped, radius),
        mean_radius_deviation=float(dr.mean()), circularity=float(dr.max() - dr.min()),
        centre_offset=float(math.hypot(coef[1], coef[2])),
        two_theta_amplitude=float(math.hypot(coef[3], coef[4])),
        two_theta_angle=float(math.degrees(math.atan2(coef[4], coef[3])) / 2 % 180),
        reversal_spikes=(spikes[0], spikes[1], spikes[2], spikes[3]), theta=theta,
        deviation=dr)


def break_at_gaps(x: np.ndarray, *ys: np.ndarray) -> tuple[np.ndarray, ...]:
    """``x`` and ``ys`` with a NaN inserted wherever consecutive ``x`` are more than
    :data:`GAP_STEPS` median steps apart: a line drawn through them joins only neighbouring
    samples, never across a gap in the data."""
    if len(x) < 2:
        return (x, *ys)
    step = np.abs(np.diff(x))
    gaps = np.flatnonzero(step > GAP_STEPS * max(float(np.median(step)), 1e-12)) + 1
    return tuple(np.insert(np.asarray(v, dtype=float), gaps, np.nan) for v in (x, *ys))


def ballbar_figure(b: Ballbar, title: str, lsb_mm: float = 0.001) -> Figure:
    """The polar plot: the radial deviation (LSB) on a radial scale of its own, the nominal
    circle at 0, the scale's ticks in LSB and um (``lsb_mm`` mm per LSB); the samples drawn
    in time order, the line broken at gaps in the data."""
    from matplotlib.figure import Figure
    from matplotlib.ticker import FuncFormatter, MaxNLocator

    dev = b.deviation
    reach = max(float(np.abs(dev).max()), 0.5) * 1.15
    fig = Figure(figsize=(7, 7.5), layout="constrained")
    ax = fig.add_subplot(projection="polar")
    ax.set_rorigin(-3 * reach)  # the band from -reach to +reach: the outer half of the disc
    ax.set_ylim(-reach, reach)
    ring = np.linspace(0, 2 * np.pi, 361)
    ax.plot(ring, np.zeros_like(ring), color="0.6", lw=1, label="nominal (0)")
    theta, values = break_at_gaps(np.unwrap(b.theta), dev)
    ax.plot(theta, values, color="C3", lw=0.9, label="measured")
    ax.yaxis.set_major_locator(MaxNLocator(5, symmetric=True))
    um = lsb_mm * 1000
    ax.yaxis.set_major_formatter(FuncFormatter(
        lambda v, _: f"{v:+.3g} LSB = {v * um:+.3g} um" if v else "0 LSB"))
    ax.tick_params(axis="y", labelsize=7)
    ax.set_rlabel_position(100)
    ax.legend(loc="lower right", fontsize=8, title="radial deviation", title_fontsize=8)
    ax.set_title(f"{title}\nR {b.radius:.0f} LSB; mean dR {b.mean_radius_deviation:+.2f}; "
                 f"circularity {b.circularity:.2f}; 2-theta {b.two_theta_amplitude:.2f} at "
                 f"{b.two_theta_angle:.0f} deg (LSB); {b.sweep:.0f} deg analysed",
                 fontsize=9, parse_math=False)
    return fig
