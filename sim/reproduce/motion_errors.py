"""Section 9: the motion-errors paper, the radius error of a circle by accel/decel type.

The motion-errors paper (Shin, Kwak and Chung, motion errors by accel/decel type) runs circles over
an L16(4^5) orthogonal array of feed, radius, inertia ratio, time constant and position gain
(its Tables 1 and 2), with the exponential and the linear filter after the interpolator, and
compares each run's radius error with its eqs (9) and (10); a gain mismatch between the axes
makes the error an ellipse with its extremes at 45 and 225 degrees (Fig. 8); a second-order
response surface (eqs (14)-(20)) is fitted to the runs. Here each L16 run is an arc on the
post-interpolation machine of :mod:`~k37.sim.reproduce.filters`, measured in its steady state
against the formulas of :mod:`~k37.sim.reproduce.circle_error`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

from k37.firmware_model.job import ServoConfig
from k37.sim.reproduce.circle_error import (
    LEVELS,
    LINEAR_A,
    SETTLE_S,
    TM_MOTOR,
    ArcLoss,
    Condition,
    arc_losses,
    conditions,
    exact_loss,
    loss_table,
    mismatch_ellipse,
    run_key,
    steady,
)
from k37.sim.reproduce.filters import SHAPES, filter_machine
from k37.sim.reproduce.markdown import Section, pct, pyplot, save_figure
from k37.sim.reproduce.runs import QUICK, RunData, RunSpec, Scale, Specs
from k37.sim.reproduce.theory import mismatch_amplitude
from k37.sim.run.ballbar import Ballbar, break_at_gaps, circle_figures
from k37.sim.study.analysis import Surface, response_surface

__all__ = ["section", "specs"]

#: The paper's agreement of experiment and eqs (9)/(10) (Figs. 11 and 12).
PAPER_AGREEMENT = {"exponential": 0.039, "linear": 0.023}
#: Seconds of steady arc measured, by scale.
MEASURE_S = {"quick": 0.25, "full": 2.0}
#: Fig. 8: the mismatched axes' gains (1/s; Table 1's F1 and F4), the circle (mm) and feed.
ELLIPSE_KP = (30.0, 39.0)
ELLIPSE_RADIUS = 10.0
ELLIPSE_FEED = 2500.0
#: ... and both axes' velocity lag (Table 1's inertia ratio C2, 50%) and time constant (D1).
ELLIPSE_TM = TM_MOTOR * (1 + LEVELS["inertia"][1])
ELLIPSE_TAU = LEVELS["tau"][0]
#: The surface's factors (eq (16) has four; inertia, absent from eqs (9)/(10), is left out).
SURFACE_FACTORS = ("feed", "radius", "tau", "kp")


def _arc(radius_lsb: float, sweep: float) -> str:
    """A CCW arc from the origin round the centre (-R, 0) through ``sweep`` radians (mm)."""
    r = radius_lsb / 1000
    return f"X{r * math.cos(sweep) - r:.3f} Y{r * math.sin(sweep):.3f} I-{r:.3f} J0"


def specs(scale: Scale) -> Specs:
    """The L16 arcs with both filters (long enough to settle and be measured for the
    scale's seconds), and the mismatch circle."""
    # The K3701's sqrt(2) control runs a circle about 9% under its feed.
    seconds = (SETTLE_S + MEASURE_S["quick" if scale is QUICK else "full"]) / 0.9
    out: Specs = {}
    for shape in SHAPES:
        for k, c in enumerate(conditions()):
            sweep = c.feed / 60 * seconds / c.radius
            out[run_key(shape, k)] = RunSpec(
                run_key(shape, k), "post",
                f"G17 G21 G91\nG03 {_arc(1000 * c.radius, sweep)} F{c.feed:g}\nM30", 1000,
                machine=filter_machine(shape, c.tau), servo=dict.fromkeys("xy", c.servo))
    out["s001_ellipse"] = RunSpec(
        "s001_ellipse", "post",
        f"G17 G21 G91\nG03 I0 J{ELLIPSE_RADIUS:g} F{ELLIPSE_FEED:g}\nM30", 1000,
        machine=filter_machine("exponential", ELLIPSE_TAU),
        servo={axis: ServoConfig(kp=kp, tm=ELLIPSE_TM)
               for axis, kp in zip("xy", ELLIPSE_KP, strict=True)})
    return out


def _surface(arcs: list[ArcLoss]) -> Surface:
    rows = [{**{name: str(getattr(a.condition, name)) for name in SURFACE_FACTORS},
             "loss": str(a.loss)} for a in arcs]
    return response_surface(rows, SURFACE_FACTORS, "loss")


def _gap(measured: float, model: float) -> float:
    """How far ``measured`` is outside 5% + 0.5 LSB of ``model`` (<= 0: inside)."""
    return abs(measured - model) - 0.05 * abs(model) - 0.5


def _turn(angle: float, other: float) -> float:
    """How far apart two axes of an ellipse are (degrees, modulo 180)."""
    return abs((angle - other + 90) % 180 - 90)


def _largest(arcs: list[ArcLoss], model: Callable[[ArcLoss], float]) -> str:
    """The largest |emulator - model| over the runs, and its run."""
    k = max(range(len(arcs)), key=lambda i: abs(arcs[i].loss - model(arcs[i])))
    return (f"largest gap {abs(arcs[k].loss - model(arcs[k])):.2f} LSB (run {k + 1}: "
            f"{arcs[k].loss:.2f} vs {model(arcs[k]):.2f})")


def _l16_rows(sec: Section, shape: str, arcs: list[ArcLoss]) -> None:
    """The rows of one filter shape's L16 runs: against the exact form and eq (9)/(10)."""
    eq = "(9)" if shape == "exponential" else "(10)"
    losses = [a.loss for a in arcs]
    sec.row(f"{shape} filter: each L16 run's radius error against the exact form",
            "none (eqs (9)/(10) are its second-order terms)",
            f"radius loss {min(losses):.1f} to {max(losses):.1f} LSB; against R (1 - |G_acc(jw)"
            f" G(jw)|): {_largest(arcs, lambda a: a.exact(shape))}",
            "every run within 5% + 0.5 LSB",
            all(_gap(a.loss, a.exact(shape)) <= 0 for a in arcs), kind="quoted")
    over = [a.paper(shape) / a.loss - 1 for a in arcs]
    sec.row(f"{shape} filter: each L16 run's radius error against eq {eq}",
            f"experiment within +-{pct(PAPER_AGREEMENT[shape])} of eq {eq} (Fig. "
            f"{11 if shape == 'linear' else 12})",
            f"eq {eq} as printed is {pct(min(over))} to {pct(max(over))} above the emulator "
            f"(it has no velocity lag Tm); with its servo term x (1 - 2 Kp Tm): "
            f"{_largest(arcs, lambda a: a.paper(shape, a.condition.tm))}",
            f"eq {eq} with (1 - 2 Kp Tm) within 5% + 0.5 LSB of every run",
            all(_gap(a.loss, a.paper(shape, a.condition.tm)) <= 0 for a in arcs), kind="trend")


def section(runs: dict[str, RunData], specs: Specs, scale: Scale, out: Path) -> Section:
    """Section 9's rows, text and figure ``motion_errors.png``."""
    keys = tuple(key for key in specs if key.startswith("s001_"))
    sec = Section(9, "The motion-errors paper: radius error by accel/decel type over the L16 "
                     "array, the mismatch ellipse (Fig. 8) and the response surface", keys)
    arcs = {shape: arc_losses(runs, shape) for shape in SHAPES}
    for shape in SHAPES:
        _l16_rows(sec, shape, arcs[shape])

    r = 1000 * ELLIPSE_RADIUS
    t, x, y, speed = steady(runs["s001_ellipse"], (0, r))
    measured = circle_figures(t, x, y, r)
    v = float(np.sqrt(np.mean(speed**2)))
    exact = mismatch_ellipse("exponential", r, v, ELLIPSE_KP, ELLIPSE_TM, ELLIPSE_TAU)
    approx = mismatch_amplitude(v, *(1 / kp for kp in ELLIPSE_KP))
    sec.row(f"gain mismatch Kp_x = {ELLIPSE_KP[0]:g}, Kp_y = {ELLIPSE_KP[1]:g}/s: the "
            f"ellipse (Fig. 8)",
            "error extremes at 45 and 225 degrees (CCW)",
            f"2-theta component {measured.two_theta_amplitude:.1f} LSB with its long axis at "
            f"{measured.two_theta_angle:.1f} (and {measured.two_theta_angle + 180:.1f}) deg; "
            f"exact form {exact.two_theta_amplitude:.1f} LSB at {exact.two_theta_angle:.1f} "
            f"deg; (V/2) |1/Kp_x - 1/Kp_y| = {approx:.1f} LSB",
            "long axis within 5 deg of 45 and 1.5 deg of the exact form's (45 turned by the "
            "servo's phase); amplitude within 5% + 0.5 LSB of the exact form",
            _turn(measured.two_theta_angle, 45) <= 5
            and _turn(measured.two_theta_angle, exact.two_theta_angle) <= 1.5
            and _gap(measured.two_theta_amplitude, exact.two_theta_amplitude) <= 0, kind="number")

    centre = Condition(*(float(np.mean(levels)) for levels in LEVELS.values()))
    fits = {shape: _surface(arcs[shape]) for shape in SHAPES}
    predicted = {}
    for shape, fit in fits.items():
        at = [getattr(centre, name) for name in SURFACE_FACTORS]
        speed_c = 1000 * centre.feed / 60 * np.mean([a.speed / (1000 * a.condition.feed / 60)
                                                    for a in arcs[shape]])
        predicted[shape] = (fit.predict(at), exact_loss(shape, 1000 * centre.radius, speed_c,
                                                         centre.kp, centre.tm, centre.tau))
    sec.row("second-order response surface (eqs (14)-(20)) fitted to the 16 runs",
            "Table 3's coefficients (garbled in the text: not comparable)",
            "at the array's centre (" + ", ".join(
                f"{shape}: surface {p:.2f} vs exact {e:.2f} LSB"
                for shape, (p, e) in predicted.items()) + ")",
            "within 10% + 0.5 LSB of the exact form at the centre",
            all(abs(p - e) <= 0.1 * e + 0.5 for p, e in predicted.values()), kind="quoted")
    _text(sec, scale, fits, measured)
    sec.text.append(loss_table(arcs))
    _figure(sec, out, arcs, measured, exact)
    return sec


def _stationary(fit: Surface) -> str:
    """Eq (20)'s point of a fitted surface and what it is."""
    if fit.stationary is None:
        return "none (singular)"
    inside = all(min(LEVELS[name]) <= value <= max(LEVELS[name])
                 for name, value in zip(fit.factors, fit.stationary, strict=True))
    return (", ".join(f"{name} {value:.3g}" for name, value in
                      zip(fit.factors, fit.stationary, strict=True))
            + f" (a {fit.kind}, {'inside' if inside else 'outside'} the levels)")


def _text(sec: Section, scale: Scale, fits: dict[str, Surface], ellipse: Ballbar) -> None:
    measure = MEASURE_S["quick" if scale is QUICK else "full"]
    stationary = "; ".join(f"{shape}: {_stationary(fit)}" for shape, fit in fits.items())
    sec.text += [
        "The motion-errors paper runs circles over the L16(4^5) array of its Tables 1 and 2 "
        "(feed 1000 to "
        "2500 mm/min, radius 50 to 200 mm, inertia ratio 30 to 90%, time constant 15 to 45 "
        "ms, position gain) with the linear and the exponential filter, and finds the "
        "measured radius error within +-2.3% (linear) and +-3.9% (exponential) of its eqs "
        "(9) and (10) (Figs. 11 and 12, plots lost in the text: only these two numbers "
        "remain). The emulator runs the array (Rao's L16 over GF(4), `k37.sim.study.design`: the "
        "standard table up to its column order and level names) on the post-interpolation "
        "machine of section 8, one arc per run and filter, at the paper's feeds and radii: "
        f"{SETTLE_S} s to settle, then {measure} s of steady arc whose mean radial deviation "
        "is the run's radius loss. V is the measured (RMS) command speed: the K3701's "
        "sqrt(2) control runs a circle some 9% under its programmed feed. The linear "
        "circuit's count is the floor of its moving average while it moves (its accumulator "
        "keeps the fraction until it drains, where the count comes out exact), which puts "
        "the path half a pulse towards -X and -Y on average; its arcs, which start at 0 "
        "degrees, are measured round the centre moved by that (-0.5, -0.5) LSB (else their "
        "radius loss reads 0.5 LSB high). The exponential circuit's counter feeds the "
        "fraction back and has no such offset.",
        "Corrections to the extracted formulas: eq (10)'s denominator reads 2AR with A "
        f"undefined; the moving average's gain sin(wT/2) / (wT/2) gives A = {LINEAR_A} "
        "(T^2 V^2 / 24R). Table 1's gains \"30000 to 39000 (msec)\" are read as 30 to 39/s "
        "(units of 0.001/s). Eqs (9)/(10) add the magnitudes of an undercut (eq (8) has the "
        "sign: the radius shrinks). The paper's servo (its eq (3)) is a first-order lag "
        "1/(1 + s/Kp); the emulator's drive has a velocity lag Tm, set by the inertia ratio "
        f"as Tm = {1e3 * TM_MOTOR:g} ms x (1 + ratio), and its radius loss is R (1 - "
        "|G_acc(jw) G(jw)|), whose second-order term multiplies eq (9)'s servo term by "
        "(1 - 2 Kp Tm): eq (9) as printed is its Tm = 0 limit, and overstates the loss by "
        "the velocity loop's share.",
        f"Fig. 8: with Kp_x = {ELLIPSE_KP[0]:g} and Kp_y = {ELLIPSE_KP[1]:g}/s (Table 1's "
        f"extremes), X lags Y and a CCW circle of R = {ELLIPSE_RADIUS:g} mm at "
        f"F{ELLIPSE_FEED:g} bulges at 45 and 225 degrees: the 2-theta component of the "
        f"ballbar fit ({ellipse.two_theta_amplitude:.1f} LSB) has its long axis there. The "
        "paper's amplitude (V/2) |1/Kp_x - 1/Kp_y| is the first-order term in w/Kp of the "
        "exact form, which takes each axis's full G(jw) (and turns the axis by the servo's "
        "phase, the 3 degrees past 45).",
        "The response surface of eq (19) over four factors (feed, radius, time constant, "
        "gain; eq (16) has four, and the inertia ratio, absent from eqs (9)/(10), is left "
        "out) has 15 coefficients for 16 runs, so it fits the runs almost exactly; the row "
        "checks it where no run was made, at the array's centre. Table 3's coefficients are "
        "split across the extracted columns and their coding is not given: they cannot be "
        f"compared. Stationary points (eq (20)): {stationary}. The radius loss itself grows "
        "with V^2/R, T^2 and 1/Kp^2 and has no optimum inside the array (its least is at a "
        "corner: the lowest feed and time constant, the largest radius and gain): eq (20)'s "
        "point is the fitted quadratic's, not the machine's.",
    ]


def _figure(sec: Section, out: Path, arcs: dict[str, list[ArcLoss]], measured: Ballbar,
            exact: Ballbar) -> None:
    plt = pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4))
    runs = np.arange(1, 17)
    for colour, (shape, items) in zip(("C0", "C1"), arcs.items(), strict=True):
        a.plot(runs, [i.loss for i in items], "o", color=colour, ms=4,
               label=f"{shape}: emulator")
        a.plot(runs, [i.exact(shape) for i in items], "-", color=colour, lw=0.8,
               label="exact form")
        a.plot(runs, [i.paper(shape) for i in items], ":", color=colour, lw=0.8,
               label="eq (9)" if shape == "exponential" else "eq (10)")
    a.set(title="Figs. 11/12: radius loss per L16 run", xlabel="run (Table 2)",
          ylabel="LSB (um)", yscale="log")
    a.legend(fontsize=7)
    for data, style, label in ((measured, "-", "emulator"), (exact, "k--", "exact form")):
        order = np.argsort(np.degrees(data.theta) % 360)
        b.plot(*break_at_gaps((np.degrees(data.theta) % 360)[order], data.deviation[order]),
               style, lw=0.9, label=label)
    for angle in (45, 225):
        b.axvline(angle, color="C3", lw=0.6)
    b.set(title="Fig. 8: gain mismatch, radial deviation", xlabel="angle (deg, CCW)",
          ylabel="LSB")
    b.legend(fontsize=8)
    sec.figure = save_figure(fig, out, "motion_errors.png")
