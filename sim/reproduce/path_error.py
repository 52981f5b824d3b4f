"""Experiment 4: the circular path error (Photos 3 and 4, and FP control).

The circles run with the accel/decel circuit after the interpolator at the high and the low
feed, and before it (FP control), each seen around its centre (:func:`circles`) with its model:
two independent first-order lags plus the servo for the post machine, the servo's
steady-state radius loss for FP control.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from k37.firmware_model.job import MachineConfig
from k37.firmware_model.motion.program import Arc
from k37.sim.reproduce.markdown import Section, pct, pyplot, save_figure
from k37.sim.reproduce.paper import FEED_HIGH, FEED_LOW
from k37.sim.reproduce.runs import MACHINE, SERVO, RunData, RunSpec, Scale, Specs, Trace
from k37.sim.reproduce.theory import (
    fp_rate,
    hardware_tau,
    ideal_command,
    lag,
    servo,
    servo_radius_loss,
)

__all__ = ["Circle", "circles", "section"]


@dataclass
class Circle:
    """A circular run seen around its centre (the program starts at the origin, centre at
    (-R, 0)): unwrapped angle (deg), radial error (LSB), and a model's radial error."""

    run: Trace
    radius: int
    angle: np.ndarray
    radial: np.ndarray
    model: np.ndarray

    @property
    def worst(self) -> float:
        return float(np.abs(self.radial).max())

    def quadrant_worst(self) -> list[float | None]:
        """The largest |radial error| in each quadrant around the centre (None: not visited)."""
        q = (np.floor(np.mod(self.angle, 360) / 90)).astype(int)
        return [float(np.abs(self.radial[q == k]).max()) if (q == k).any() else None
                for k in range(4)]


def _around(radius: int, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    angle = np.degrees(np.unwrap(np.arctan2(y, x + radius)))
    return angle, np.hypot(x + radius, y) - radius


def _lagged_circle(run: Trace, spec: RunSpec, machine: MachineConfig) -> Circle:
    """A post-interpolation run with its model: the K3701's ideal command at the feed's FP
    rate, each axis through its own first-order lag (tau) and then its servo."""
    item = spec.move(Arc)
    radius = -item.i
    cx, cy = ideal_command(item.block, fp_rate(machine, run.block["feed_word"]), run.t)
    tau = hardware_tau(machine)
    px = servo(run.t, lag(run.t, cx, tau), SERVO.kp, SERVO.tm)
    py = servo(run.t, lag(run.t, cy, tau), SERVO.kp, SERVO.tm)
    angle, radial = _around(radius, run["x_actual"], run["y_actual"])
    return Circle(run, radius, angle, radial, _around(radius, px, py)[1])


def _servo_circle(run: Trace, radius: int) -> Circle:
    """An FP-control run with the servo's steady-state radius loss at the measured speed."""
    w = max(1, round(0.005 / (run.t[1] - run.t[0])))
    x, y = run["x_actual"], run["y_actual"]
    speed = np.zeros(len(x))
    speed[w:-w] = np.hypot(x[2 * w:] - x[:-2 * w], y[2 * w:] - y[:-2 * w]) / (
        run.t[2 * w:] - run.t[:-2 * w])
    model = -np.array([servo_radius_loss(radius, v, SERVO.kp, SERVO.tm) for v in speed])
    angle, radial = _around(radius, x, y)
    return Circle(run, radius, angle, radial, model)


def circles(runs: dict[str, RunData], specs: Specs) -> dict[str, Circle]:
    """The circular runs around their centres: post at both feeds, and FP control."""
    clock = MACHINE["pre"].clock_hz
    return {
        "post_high": _lagged_circle(Trace(runs["post_high"], clock), specs["post_high"],
                                    MACHINE["post"]),
        "post_low": _lagged_circle(Trace(runs["post_low"], clock), specs["post_low"],
                                   MACHINE["post"]),
        "pre_circle": _servo_circle(Trace(runs["pre_circle"], clock),
                                    -specs["pre_circle"].move(Arc).i),
    }


def section(circles: dict[str, Circle], scale: Scale, out: Path) -> Section:
    """Experiment 4's rows, text and figure ``path_error.png``."""
    sec = Section(4, "Circular path error (Photos 3 and 4, and FP control)",
                  ("post_high", "post_low", "pre_circle"))
    high, low, pre = circles["post_high"], circles["post_low"], circles["pre_circle"]
    machine = MACHINE["post"]
    f_high, f_low = fp_rate(machine, FEED_HIGH), fp_rate(machine, FEED_LOW)
    worst_q = high.quadrant_worst()
    quads = ", ".join(f"Q{k + 1} {'-' if v is None else f'{v:.0f}'}"
                      for k, v in enumerate(worst_q))
    q2 = worst_q[1]
    second = ("the error-free second quadrant is not reproduced"
              if q2 is not None and q2 > 0.1 * high.worst else
              "the second quadrant shows little error, as in the paper")
    sec.row(f"post-interpolation accel/decel, feed word {FEED_HIGH} (Photo 3)",
            "path error in quadrants 1, 3 and 4 (not 2); in quadrant 1 the curve runs past "
            "the quadrant",
            f"{high.worst:.0f} LSB = {pct(high.worst / high.radius)} of R = {high.radius} "
            f"(worst per quadrant: {quads} LSB): {second}",
            f"more than 10x the FP-control error ({pre.worst:.1f} LSB)",
            high.worst > 10 * pre.worst, kind="trend")
    model_worst = float(np.abs(high.model).max())
    sec.row("... which is each axis's own exponential lag",
            "a race between the accel/decel input and the position controller's input when "
            "the long axis changes (the paper's explanation)",
            f"{high.worst:.0f} LSB vs {model_worst:.0f} LSB for two independent first-order "
            f"lags (tau) plus the servo, fed the K3701's ideal steps",
            "within 5%", abs(high.worst - model_worst) <= 0.05 * model_worst, kind="trend")
    rel_high, rel_low = high.worst / high.radius, low.worst / low.radius
    sec.row(f"post-interpolation accel/decel, feed word {FEED_LOW} (Photo 4)",
            "far less path error at the low feed",
            f"{low.worst:.1f} LSB = {pct(rel_low)} of R = {low.radius} (model "
            f"{np.abs(low.model).max():.1f} LSB)",
            f"relative error below 1/10 of the high feed's ({pct(rel_high)})",
            rel_low < 0.1 * rel_high, kind="trend")
    peak = float(np.abs(pre.model).max())
    misfit = float(np.abs(pre.radial - pre.model).max())
    sec.row(f"pre-interpolation accel/decel (FP control), feed word {FEED_HIGH}",
            "no path error",
            f"{pre.worst:.1f} LSB inward at the top speed = the servo's steady-state loss "
            f"R (1 - |G(jw)|) = {peak:.1f} LSB; every sample within {misfit:.1f} LSB of it",
            f"every sample within 10% of {peak:.1f} LSB + 1.5 LSB (encoder count) of "
            f"R (1 - |G(jw)|) at its speed", misfit <= 0.1 * peak + 1.5, kind="trend")
    sec.text += [
        f"The paper ran the same circle with the accel/decel circuit after the interpolator "
        f"(one per axis) at the feeds {FEED_HIGH} and {FEED_LOW} (Photos 3 and 4): at the high "
        f"feed the path error was plain in every quadrant but the second, and in the first "
        f"quadrant the curve ran on past the quadrant; at the low feed the error was far "
        f"smaller; with the circuit before the interpolator (FP control) there was none.",
        f"The emulator runs a full CCW circle of R = {high.radius} LSB at the feed word "
        f"{FEED_HIGH} ({f_high:.0f} FP/s) on the post- and the pre-interpolation machines, and "
        f"a {scale.low_sweep} degree arc of R = {low.radius} LSB at the word {FEED_LOW} "
        f"({f_low:.1f} FP/s) on the post machine: a full circle of R = {high.radius} at "
        f"{f_low:.0f} FP/s would take {high.run.block['fp_budget'] / f_low:.0f} s of machine "
        f"time. The small radius makes the low feed's error larger, not smaller (the lag's "
        f"radius loss grows as (v tau / R)^2), so the small arc is the harder test of the "
        f"paper's claim.",
        f"What the emulator shows: the post-interpolation error is large and systematic. The "
        f"K3701 commands a perfect circle; each axis's circuit delays its own coordinate by a "
        f"first-order lag of tau = 300 ms, far longer than the {high.radius / f_high:.2f} s a "
        f"radian takes, so the commanded path cuts inside, spirals in and, after the K3701 has "
        f"finished, closes on the end point from below the x axis. The error is that of two "
        f"independent lags to within a fraction of a percent (row 4b), with no race between "
        f"pulses: the circuit's input separation never loses or doubles a pulse (see the "
        f"accel/decel circuits' datasheet). A lag's error is tied to the start point, not to "
        f"fixed quadrants: it builds up "
        f"from zero where the circle starts, and the path closes on the end point from the "
        f"quadrant before it. This circle starts on the positive x axis, so {second}. The "
        f"paper does not say where its circle started or how large it was; one started at the "
        f"top, and large against v tau = {f_high * hardware_tau(machine):.0f} LSB, would show "
        f"the least error in the second quadrant and close on its end through the first, "
        f"which may be what Photo 3 shows; the emulator cannot confirm it.",
        "Under FP control the path keeps its shape: what remains is the servo's own radius "
        "loss R (1 - |G(jw)|), w = v / R, inward and growing with the square of the speed, the "
        "same on every backend of this emulator and on any real machine with this servo.",
    ]
    plt = pyplot()
    fig, axes = plt.subplots(2, 3, figsize=(12, 7.5))
    titles = {"post_high": f"Photo 3: post, word {FEED_HIGH}",
              "post_low": f"Photo 4: post, word {FEED_LOW}",
              "pre_circle": f"FP control, word {FEED_HIGH}"}
    limit = 100 * max(abs(c.radial / c.radius).max() for c in circles.values()) * 1.1
    for col, (key, c) in enumerate(circles.items()):
        a = axes[0][col]
        t = np.linspace(0, math.radians(360 if key != "post_low" else scale.low_sweep), 400)
        a.plot(c.radius * np.cos(t) - c.radius, c.radius * np.sin(t), color="0.7", lw=3)
        a.plot(c.run["x_actual"], c.run["y_actual"], lw=1)
        a.set(title=titles[key], xlabel="x (LSB)", ylabel="y (LSB)")
        a.set_aspect("equal", adjustable="datalim")
        b = axes[1][col]
        b.plot(c.angle, 100 * c.radial / c.radius, lw=1, label="emulator")
        b.plot(c.angle, 100 * c.model / c.radius, "k--", lw=0.8,
               label="model" if key != "pre_circle" else "R (1 - |G(jw)|)")
        b.set(ylim=(-limit, limit / 4), xlabel="angle around the centre (deg)",
              ylabel="radial error (% of R)")
        b.legend(fontsize=8)
    fig.suptitle("Actual path (grey: programmed) and radial error on one scale")
    sec.figure = save_figure(fig, out, "path_error.png")
    return sec
