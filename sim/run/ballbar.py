"""Ballbar analysis of a circular run, as ISO 230-4 and a double-ballbar report give it.

The nominal circle is the program's arcs' (they must share one centre and radius); the data
are the samples taken while an arc block ran, from the first arc's start to the last arc's
end. For each sample, the radial deviation dr = |p - c| - R (LSB) at the angle theta of p
around the centre. Figures:

* ``mean_radius_deviation``: the mean of dr (the radius loss of the motion-errors paper's eqs
  (9)/(10));
* ``circularity``: max dr - min dr (ISO 230-4's circular deviation G, peak to valley);
* a least-squares fit dr = a0 + a1 cos t + b1 sin t + a2 cos 2t + b2 sin 2t:
  ``centre_offset`` (the first harmonic's amplitude) and the **2-theta component**,
  ``two_theta_amplitude`` = hypot(a2, b2) and ``two_theta_angle`` = atan2(b2, a2)/2 (deg, in
  [0, 180)): where the ellipse's long axis points. A gain or time-constant mismatch between
  X and Y makes that ellipse (the motion-errors paper's Fig. 8), its long axis at 45 or 135 degrees;
* ``reversal_spikes``: at each axis reversal (theta = 0, 90, 180, 270 deg) the largest
  |dr - fit| within ``SPIKE_WINDOW_DEG`` of it (a quadrant glitch);
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

from firmware_model.gcode.parser import Arc
from sim.run.report import BALLBAR_FIGURES as FIGURES

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from firmware_model.job import Job
    from sim.run.runner import RunResult

__all__ = ["FIGURES", "SPIKE_WINDOW_DEG", "Ballbar", "BallbarError", "ballbar", "ballbar_figure",
           "ballbar_of", "circle_figures"]

#: Half-width of the window around each axis reversal a spike is looked for in (deg).
SPIKE_WINDOW_DEG = 5.0


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
    reversal_spikes: tuple[float, float, float, float]
    theta: np.ndarray
    deviation: np.ndarray

    def figures(self) -> dict[str, float]:
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


def ballbar(result: RunResult, settle_deg: float = 0.0) -> Ballbar:
    """The ballbar figures of a run of a circular program (:class:`BallbarError` if not),
    leaving out the data until the tool has gone ``settle_deg`` degrees round the circle (the
    feed-in, as ISO 230-4's overshoot arcs do)."""
    return ballbar_of(result.job, result.report, result.store.chunks(), result.store.columns,
                      settle_deg)


def ballbar_of(job: Job, report: dict, chunks: Iterable[np.ndarray], columns: Sequence[str],
               settle_deg: float = 0.0) -> Ballbar:
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


def circle_figures(t: np.ndarray, px: np.ndarray, py: np.ndarray, radius: float,
                   settle_deg: float = 0.0, center: tuple[float, float] = (0.0, 0.0)
                   ) -> Ballbar:
    """The ballbar figures of the samples at times ``t`` (s) of a path round a circle of
    ``radius``: ``px``, ``py`` relative to its ``center`` (LSB), after ``settle_deg``."""
    if len(px) and settle_deg > 0:
        travelled = np.abs(np.unwrap(np.arctan2(py, px)) - math.atan2(py[0], px[0]))
        keep = travelled >= math.radians(settle_deg)
        t, px, py = t[keep], px[keep], py[keep]
    if len(px) < 16:
        raise BallbarError(f"{len(px)} samples on the circle: too few (sample more often)")
    theta = np.arctan2(py, px)
    dr = np.hypot(px, py) - radius
    basis = np.column_stack([np.ones_like(theta), np.cos(theta), np.sin(theta),
                             np.cos(2 * theta), np.sin(2 * theta)])
    coef, *_ = np.linalg.lstsq(basis, dr, rcond=None)
    residual = dr - basis @ coef
    degrees = np.degrees(theta) % 360
    spikes = []
    for q in (0, 90, 180, 270):
        near = np.abs((degrees - q + 180) % 360 - 180) <= SPIKE_WINDOW_DEG
        spikes.append(float(np.abs(residual[near]).max()) if near.any() else 0.0)
    unwrapped = np.unwrap(theta)
    return Ballbar(
        center=center, radius=float(radius), samples=len(dr),
        sweep=float(np.degrees(unwrapped.max() - unwrapped.min())),
        path_speed=_steady_speed(t, unwrapped, radius),
        mean_radius_deviation=float(dr.mean()), circularity=float(dr.max() - dr.min()),
        centre_offset=float(math.hypot(coef[1], coef[2])),
        two_theta_amplitude=float(math.hypot(coef[3], coef[4])),
        two_theta_angle=float(math.degrees(math.atan2(coef[4], coef[3])) / 2 % 180),
        reversal_spikes=tuple(spikes), theta=theta, deviation=dr)


def ballbar_figure(b: Ballbar, title: str, magnification: float | None = None) -> Figure:
    """The polar plot: the nominal circle and the radial deviation magnified so that the
    circularity spans a quarter of the radius (or by ``magnification``)."""
    from matplotlib.figure import Figure

    scale = magnification or (0.25 / max(b.circularity / b.radius, 1e-12))
    fig = Figure(figsize=(7, 7.5), layout="constrained")
    ax = fig.add_subplot(projection="polar")
    order = np.argsort(b.theta)
    ring = np.linspace(0, 2 * np.pi, 361)
    ax.plot(ring, np.full_like(ring, 1.0), color="0.6", lw=1, label="nominal")
    ax.plot(b.theta[order], 1 + scale * b.deviation[order] / b.radius, color="C3", lw=0.9,
            label=f"measured, deviation x{scale:.3g}")
    ax.set_rmax(1.6)
    ax.set_yticklabels([])
    ax.legend(loc="lower right", fontsize=8)
    ax.set_title(f"{title}\nR {b.radius:.0f} LSB; mean dR {b.mean_radius_deviation:+.2f}; "
                 f"circularity {b.circularity:.2f}; 2-theta {b.two_theta_amplitude:.2f} at "
                 f"{b.two_theta_angle:.0f} deg (LSB)", fontsize=9, parse_math=False)
    return fig
