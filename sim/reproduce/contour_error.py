"""The contour-error paper (a multi-axis contour error controller): its uncompensated contouring and
its contour error vector, section 10 of ``k37 reproduce``.

The paper tracks a parabola and a cubic Bezier curve at 60 mm/s with a two-axis plant (its
Table 1: open loop gains 10.3 and 10.0 1/s, time constants 35 and 30 ms), and measures the
contour error as the length of the contour error vector: from the tool to the nearest point
of the curve (its eqs (1)-(4)). Table 3 gives the P controller's mean contour error on the
Bezier curve; Fig. 6(b) shows how far the osculating-circle estimate of the variable-gain
cross-coupling controller is from that nearest-point error.

Here both curves run as G01 chords (the K3701 has no Bezier mode) at 60 mm/s on a machine
with no accel/decel circuit and first-order drives of Table 1's gains and time constants;
:class:`Curve` measures the contour error vector by Newton-Raphson, as the paper does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.polynomial import Polynomial

from k37.firmware_model.gcode.parser import parse
from k37.firmware_model.job import ContourConfig, MachineConfig, ServoConfig
from k37.firmware_model.motion.program import Line
from k37.firmware_model.motion.splines import Nurbs
from k37.hdl.chipset.map import AXES
from k37.sim.reproduce.markdown import Section, pyplot, save_figure
from k37.sim.reproduce.runs import RunData, RunSpec, Scale, Specs, Trace
from k37.sim.reproduce.theory import servo

__all__ = ["BEZIER_MM", "CONTOUR_RUNS", "FIG6B", "TABLES", "Curve", "section", "specs"]

#: The Bezier curve's control points (mm; the paper's Fig. 8): a closed loop of 299 mm.
BEZIER_MM = ((0.0, 0.0), (50.0, -200.0), (150.0, 200.0), (0.0, 0.0))
#: Fig. 6(b): the 350th reference point on the parabola, the tool there (mm), the radius of
#: curvature, the osculating-circle estimate and the nearest-point contour error (mm).
FIG6B = {"reference": (13.738, -14.894), "tool": (8.490, -12.118), "radius": 7.821,
         "estimate": 0.377, "error": 0.043}
#: Table 3: the P controller's (no CEC) mean contour error on the Bezier curve (mm).
TABLE3_MEAN = 0.119
#: Table 2: the variable-gain cross-coupling controller on the parabola (max, mean; mm).
TABLE2_VGCCC = (0.327, 0.117)
#: Tables 2 (parabola) and 3 (Bezier curve): max, mean and "RMS" contour error (mm) by
#: controller ("none": the P controller alone).
TABLES = {"parabola": {"vgccc": (0.327, 0.117, 0.113), "cec": (0.064, 0.016, 0.021)},
          "bezier": {"none": (0.403, 0.119, 0.101), "cec": (0.017, 0.002, 0.004)}}
#: Table 3's text: the CEC's mean contour error is "about 5 times" below the P controller's.
TABLE3_FACTOR = 5
#: Each curve's cubic Bezier control points (mm): the parabola's are its quadratic's raised
#: to degree 3 (the tangents at its ends meet at (15, -30)).
CONTROL_MM = {"bezier": BEZIER_MM, "parabola": ((0.0, 0.0), (10.0, -20.0), (20.0, -20.0),
                                                (30.0, 0.0))}
#: The runs with the host's contour controllers: key -> (curve, controller).
CONTOUR_RUNS = {"s002_parabola_vgccc": ("parabola", "vgccc"),
                "s002_parabola_cec": ("parabola", "cec"), "s002_bezier_cec": ("bezier", "cec")}
#: How far the CEC / baseline ratios may be from the paper's (a factor either way).
RATIO_TOLERANCE = 1.5
#: The paper's feed (mm/s) and Table 1's plant: (open loop gain 1/s, time constant s).
SPEED_MM_S = 60.0
PLANT = {"x": (10.3, 0.035), "y": (10.0, 0.030)}
#: 60 mm/s is 60 k LSB/s at 1 um, beyond the K3701's reach with the D/A and servo in
#: range; at 5 um it is 12 k LSB/s and the P controller's 6 mm lag is 1200 LSB.
MACHINE = MachineConfig(accel="none", lsb_mm=0.005)
SERVO = {axis: ServoConfig(kp=kp, tm=tm) for axis, (kp, tm) in PLANT.items()}


@dataclass(frozen=True)
class Curve:
    """A polynomial plane curve ``(x(u), y(u))``, ``u`` in [0, 1] (mm)."""

    x: Polynomial
    y: Polynomial

    @classmethod
    def bezier(cls, points: tuple[tuple[float, float], ...]) -> Curve:
        """The Bezier curve of ``points`` (Bernstein polynomials)."""
        n = len(points) - 1
        u = Polynomial([0.0, 1.0])
        basis = [math.comb(n, k) * u**k * (1 - u) ** (n - k) for k in range(n + 1)]
        return cls(sum(b * p[0] for b, p in zip(basis, points, strict=True)),
                   sum(b * p[1] for b, p in zip(basis, points, strict=True)))

    @classmethod
    def parabola(cls) -> Curve:
        """The contour-error paper's parabola y = (x - 15)^2 / 15 - 15 from x = 0 to 30
        (x = 30 u)."""
        x = Polynomial([0.0, 30.0])
        return cls(x, (x - 15) ** 2 / 15 - 15)

    def at(self, u: np.ndarray, derivative: int = 0) -> np.ndarray:
        """Rows (x, y) of the curve (or its ``derivative``) at ``u``."""
        return np.column_stack([self.x.deriv(derivative)(u) if derivative else self.x(u),
                                self.y.deriv(derivative)(u) if derivative else self.y(u)])

    def arc_length(self, n: int = 20_000) -> tuple[np.ndarray, np.ndarray]:
        """``u`` at ``n`` + 1 even steps and the length of the curve to each (mm)."""
        u = np.linspace(0.0, 1.0, n + 1)
        step = np.hypot(*np.diff(self.at(u), axis=0).T)
        return u, np.concatenate([[0.0], np.cumsum(step)])

    def nearest(self, points: np.ndarray, grid: int = 2048) -> tuple[np.ndarray, np.ndarray]:
        """The contour error vector's foot for each row of ``points`` (mm): its ``u`` and the
        contour error (the distance). Newton-Raphson on (Q(u) - P) . Q'(u) = 0 (the paper's
        eq. (4)) from the nearest of ``grid`` + 1 points of the curve."""
        coarse = self.at(np.linspace(0.0, 1.0, grid + 1))
        u = np.concatenate([
            np.argmin(np.hypot(chunk[:, None, 0] - coarse[:, 0], chunk[:, None, 1] - coarse[:, 1]),
                      axis=1) / grid
            for chunk in np.array_split(points, max(1, len(points) // 256))])
        for _ in range(8):
            rel, d1, d2 = self.at(u) - points, self.at(u, 1), self.at(u, 2)
            f = np.sum(rel * d1, axis=1)
            df = np.sum(d1 * d1, axis=1) + np.sum(rel * d2, axis=1)
            u = np.clip(u - f / np.where(df > 0, df, np.inf), 0.0, 1.0)
        return u, np.hypot(*(self.at(u) - points).T)

    def osculating_estimate(self, u: float, point: np.ndarray) -> tuple[float, np.ndarray]:
        """The variable-gain CCC's contour error estimate of the tool at ``point`` against
        the reference at ``u``: its distance to the osculating circle there, | |P - C| - R |;
        and the circle's (R, centre C)."""
        d1, d2 = self.at(np.array([u]), 1)[0], self.at(np.array([u]), 2)[0]
        cross = d1[0] * d2[1] - d1[1] * d2[0]
        speed = math.hypot(*d1)
        radius = speed**3 / abs(cross)
        normal = np.array([-d1[1], d1[0]]) / speed * math.copysign(1.0, cross)
        centre = self.at(np.array([u]))[0] + radius * normal
        return abs(math.hypot(*(point - centre)) - radius), np.array([radius, *centre])


#: The G01 chords each curve is cut into (equal lengths), by scale.
_CHORDS = {"full": {"bezier": 600, "parabola": 120}, "quick": {"bezier": 300, "parabola": 60}}
#: The 350th reference point of Fig. 6 is this far along the parabola (s at 1 ms a sample).
FIG6_SECONDS = 0.35


def _curves() -> dict[str, Curve]:
    return {"bezier": Curve.bezier(BEZIER_MM), "parabola": Curve.parabola()}


def chords_gcode(curve: Curve, chords: int) -> str:
    """``curve`` as ``chords`` G01 chords of equal length, each with the F word that runs it
    at :data:`SPEED_MM_S` along its length (sqrt(2) control's FP per step corrected for)."""
    u, s = curve.arc_length()
    ends = curve.at(np.interp(np.linspace(0.0, s[-1], chords + 1)[1:], s, u))
    moves = [f"G01 X{x:.3f} Y{y:.3f}" for x, y in ends]
    feed = 60 * SPEED_MM_S
    head = "G17 G21 G90"
    program = parse("\n".join([head, *(f"{m} F{feed:g}" for m in moves)]), source="<chords>",
                    lsb_mm=MACHINE.lsb_mm, sqrt2=MACHINE.sqrt2)
    feeds = [feed * item.plan.fp / math.dist(item.start[:2], item.end[:2])
             for item in program.items if isinstance(item, Line)]
    body = [f"{m} F{f:.3f}" for m, f in zip(moves, feeds, strict=True)]
    return "\n".join([head, *body, "G04 P0.1", "M30"])


def specs(scale: Scale) -> Specs:
    """Both curves as chords on Table 1's plant, sampled every 1 ms as the paper does (the
    parabola every 0.2 ms: Fig. 6(b) looks at one instant)."""
    chords = _CHORDS[scale.name]
    every = {"bezier": 1000, "parabola": 200}
    curves = _curves()
    plain = {f"s002_{name}": RunSpec(f"s002_{name}", "none", chords_gcode(curve, chords[name]),
                                     every[name], machine=MACHINE, servo=SERVO)
             for name, curve in curves.items()}
    controlled = {key: RunSpec(key, "none", chords_gcode(curves[name], chords[name]), 1000,
                               machine=MACHINE, servo=SERVO,
                               contour=ContourConfig(controller=controller),
                               exact=exact_curve(name, chords[name]))
                  for key, (name, controller) in CONTOUR_RUNS.items()}
    return plain | controlled


def exact_curve(name: str, chords: int) -> tuple[Nurbs, tuple[float, ...]]:
    """Curve ``name`` as a cubic spline (LSB) and its parameter at the ends of its ``chords``
    chords of equal length (:func:`chords_gcode`'s): what the host's controller is told."""
    curve = _curves()[name]
    u, s = curve.arc_length()
    ends = np.interp(np.linspace(0.0, s[-1], chords + 1), s, u)
    points = tuple((x / MACHINE.lsb_mm, y / MACHINE.lsb_mm) for x, y in CONTROL_MM[name])
    return Nurbs(points, (1.0,) * 4, 4), tuple(float(t) for t in ends)


@dataclass(frozen=True)
class _Contour:
    """One curve's run: times (s), command and actual paths (mm) while the chords ran, the
    contour errors of the actual path and of the linear model's (mm)."""

    t: np.ndarray
    command: np.ndarray
    actual: np.ndarray
    error: np.ndarray
    model: np.ndarray


def _contour(run: RunData, curve: Curve) -> _Contour:
    trace = Trace(run, MACHINE.clock_hz)
    moving = (trace.t >= 0) & (trace["cycle"] <= run.report["blocks"][-1]["end_cycle"])
    mm = MACHINE.lsb_mm
    command = np.column_stack([trace["x_command"], trace["y_command"]])[moving] * mm
    actual = np.column_stack([trace["x_actual"], trace["y_actual"]])[moving] * mm
    t = trace.t[moving]
    model = np.column_stack([servo(t, command[:, k], *PLANT[axis], substeps=2)
                             for k, axis in enumerate(AXES)])
    return _Contour(t, command, actual, curve.nearest(actual)[1], curve.nearest(model)[1])


def _path_speed(run: RunData, curve: Curve) -> float:
    """The mean path speed (mm/s) from the first block's start to the last block's end."""
    blocks = run.report["blocks"]
    seconds = (blocks[-1]["end_cycle"] - blocks[0]["start_cycle"]) / MACHINE.clock_hz
    return float(curve.arc_length()[1][-1] / seconds)


def ideal_mean_error(curve: Curve, dt: float = 1e-3) -> float:
    """The mean contour error (mm) of Table 1's linear plant following ``curve`` at
    :data:`SPEED_MM_S` exactly (the paper's parametric interpolator), until the reference
    reaches the end."""
    u, s = curve.arc_length()
    t = np.arange(0.0, s[-1] / SPEED_MM_S, dt)
    reference = curve.at(np.interp(t * SPEED_MM_S, s, u))
    tool = np.column_stack([servo(t, reference[:, k], *PLANT[axis], substeps=2)
                            for k, axis in enumerate(AXES)])
    return float(curve.nearest(tool)[1].mean())


def section(runs: dict[str, RunData], specs: Specs, scale: Scale, out: Path) -> Section:
    """Section 10's rows, text and figure ``contour_error.png``."""
    sec = Section(10, "The contour-error paper: uncompensated contouring of a parabola and a "
                      "Bezier curve, and the contour error vector",
                  ("s002_bezier", "s002_parabola", *CONTOUR_RUNS))
    curves = _curves()
    chords = {name: sum(isinstance(item, Line)
                        for item in specs[f"s002_{name}"].job().program.items)
              for name in curves}
    got = {name: _contour(runs[f"s002_{name}"], curve) for name, curve in curves.items()}
    bezier, parabola = got["bezier"], got["parabola"]
    ideal = ideal_mean_error(curves["bezier"])
    mean = float(bezier.error.mean())
    sec.row("P controller on the Bezier curve (Table 1 plant, 60 mm/s): mean contour error",
            f"{TABLE3_MEAN:.3f} mm (Table 3; max 0.403)",
            f"{mean:.3f} mm (max {bezier.error.max():.3f}); the linear plant on an exact "
            f"60 mm/s reference: {ideal:.3f} mm",
            "within 10% of the paper's",
            abs(mean / TABLE3_MEAN - 1) <= 0.10, kind="number")
    cells = []
    ok = True
    for name, c in got.items():
        ratio = float(c.error.mean() / c.model.mean())
        cells.append(f"{name}: mean {c.error.mean():.4f} vs {c.model.mean():.4f} mm "
                     f"({ratio - 1:+.1%}), max {c.error.max():.3f} vs {c.model.max():.3f}")
        ok &= abs(ratio - 1) <= 0.03
    sec.row("both curves: the machine's contour error against Table 1's linear plant "
            "(G(s) = K / (s (1 + s tau) + K)) fed the machine's own command path",
            f"no P-only figure for the parabola (Table 2: variable-gain CCC mean "
            f"{TABLE2_VGCCC[1]} mm, max {TABLE2_VGCCC[0]})",
            "; ".join(cells), "mean within 3% of the model's", ok, kind="quoted")
    # Fig. 6(b) from the paper's printed points.
    curve = curves["parabola"]
    ref, tool = np.array(FIG6B["reference"]), np.array(FIG6B["tool"])
    u_ref = curve.nearest(ref[None, :])[0][0]
    estimate, (radius, *_) = curve.osculating_estimate(u_ref, tool)
    nearest = float(curve.nearest(tool[None, :])[1][0])
    sec.row("Fig. 6(b) from its printed points: R at the 350th reference point, the "
            "osculating-circle estimate and the contour error vector",
            f"R {FIG6B['radius']} mm, estimate {FIG6B['estimate']} mm, contour error "
            f"{FIG6B['error']} mm",
            f"R {radius:.3f} mm, estimate {estimate:.3f} mm, contour error {nearest:.3f} mm",
            "each within 0.002 mm (the points are printed to 1 um)",
            max(abs(radius - FIG6B["radius"]), abs(estimate - FIG6B["estimate"]),
                abs(nearest - FIG6B["error"])) <= 0.002, kind="number")
    # The same geometry on the machine's run, when the command reaches that point.
    k = int(np.argmin(np.hypot(*(parabola.command - ref).T)))
    u_cmd = curve.nearest(parabola.command[k][None, :])[0][0]
    mine, _ = curve.osculating_estimate(u_cmd, parabola.actual[k])
    sec.row("the same on the machine (P only): the tool when the command passes the 350th "
            "reference point",
            f"tool at ({tool[0]}, {tool[1]}) (with the variable-gain CCC): estimate "
            f"{FIG6B['estimate'] / FIG6B['error']:.1f} times the contour error",
            f"command there at {parabola.t[k]:.3f} s, tool at ({parabola.actual[k][0]:.3f}, "
            f"{parabola.actual[k][1]:.3f}): estimate {mine:.3f} mm, contour error "
            f"{parabola.error[k]:.3f} mm",
            "the estimate off the contour error by more than half of it",
            abs(mine - parabola.error[k]) > parabola.error[k] / 2, kind="trend")
    controlled = {key: _contour(runs[key], curves[name])
                  for key, (name, _) in CONTOUR_RUNS.items()}
    controlled_text = _controlled_rows(sec, controlled, bezier)
    sec.text += [
        "The contour-error paper simulates a two-axis plant (its Table 1: open loop gains "
        "10.3 and "
        "10.0 1/s and time constants 35 and 30 ms, position loop gain 1, sampled every 1 ms) "
        "following a parabola y = (x - 15)^2 / 15 - 15 and a cubic Bezier curve of control "
        "points (0, 0), (50, -200), (150, 200), (0, 0) mm at 60 mm/s, first with the P "
        "position controller alone, then with its contour error controller (CEC). Its contour "
        "error is the length of the contour error vector, from the tool to the nearest point "
        "of the curve, found by Newton-Raphson on (Q - P) . Q' = 0 (its eq. (4)); "
        "`Curve.nearest` does the same from the nearest of 2049 points of the curve.",
        f"On the emulator each curve is cut into G01 chords of equal length "
        f"({chords['bezier']} on the 299 mm Bezier curve, {chords['parabola']} on the "
        f"44 mm parabola; scale `{scale.name}`): the K3701 has no Bezier mode, "
        "and its parabolic mode runs at the feed word's FP rate, not at a constant path speed "
        "(section 7 runs the parabola as one G06 block). Each chord's F word is the paper's "
        "3600 mm/min times its FP count over its length, so that sqrt(2) control's 1.5 FP "
        "per diagonal step does not slow the tool. The machine has no "
        "accel/decel circuit (the paper's reference starts at full speed) and first-order "
        "drives of Table 1's gains and time constants (Kp = open loop gain x position loop "
        "gain 1). 60 mm/s is 60 k LSB/s at the default 1 um LSB: beyond the K3702's 12-bit "
        "D/A for a 6 mm following error and near the K3701's step rates, so the LSB is "
        f"{MACHINE.lsb_mm * 1000:g} um here (12 k LSB/s, a 1200 LSB lag). Table 1's "
        "disturbance (LM guide friction, 0.75, unit not given) is left out: the first-order "
        "drive has no friction.",
        f"The mean contour error on the Bezier curve, {mean:.3f} mm, is Table 3's "
        f"{TABLE3_MEAN} mm within the tolerance; the linear plant fed an exact 60 mm/s "
        f"reference (no chords, no LSB) gives {ideal:.3f} mm; the chords' mean path speed "
        f"is {_path_speed(runs['s002_bezier'], curves['bezier']):.2f} mm/s, the firmware's "
        "gap between blocks (it loads each chord when the last one ends) included. The "
        "largest error "
        f"({bezier.error.max():.3f} mm, {bezier.t[np.argmax(bezier.error)]:.1f} s in) is in "
        "the curve's tightest turn; the paper's 0.403 mm maximum and 0.101 mm RMS (below "
        "its mean: an RMS about the mean?) are not reproduced and not checked. The "
        "parabola has no P-only figure in the paper (Table 2 is the compensated "
        "controllers').",
        f"Fig. 6(b): at the 350th reference point ({FIG6_SECONDS} s at 60 mm/s: "
        f"{SPEED_MM_S * FIG6_SECONDS:g} mm along the parabola) the variable-gain CCC estimates "
        "the contour error as the tool's distance to the osculating circle there; with the "
        "tool lagging 5.9 mm behind, that estimate (0.377 mm) is 8.8 times the true "
        "nearest-point error (0.043 mm). Recomputed from the printed coordinates, both "
        "agree to the printed digits. On the machine the P-only tool sits elsewhere, "
        f"{parabola.error[k]:.3f} mm off the curve (no cross-coupling pulls it back), and "
        f"the osculating circle of the reference point misjudges it the other way: "
        f"{mine:.3f} mm. The tolerance (wrong by more than half the contour error) was "
        "chosen after seeing that the P-only tool turns the paper's overestimate into an "
        "underestimate.",
    ]
    sec.text += controlled_text
    sec.figure = _figure(got, controlled, curves, parabola.actual[k], out)
    return sec


def _stats(errors: np.ndarray) -> tuple[float, float, float, float]:
    """Max, mean, root mean square and standard deviation of ``errors``."""
    return (float(errors.max()), float(errors.mean()), float(np.sqrt(np.mean(errors**2))),
            float(errors.std()))


def _cells(stats: tuple[float, ...]) -> str:
    return "/".join(f"{v:.3f}" for v in stats[:3]) + f" (std {stats[3]:.3f})"


def _controlled_rows(sec: Section, controlled: dict[str, _Contour],
                     bezier: _Contour) -> list[str]:
    """Tables 2 and 3's rows: the host's contour controllers (``controlled``, by run key)
    against their baselines, with the text that states the assumptions."""
    got = {CONTOUR_RUNS[key]: _stats(run.error) for key, run in controlled.items()}
    got["bezier", "none"] = _stats(bezier.error)

    def ratios(name: str, baseline: str) -> tuple[tuple[float, float], tuple[float, float]]:
        """(max, mean) ratios CEC / baseline: the paper's and the emulator's."""
        paper, cec = TABLES[name][baseline], TABLES[name]["cec"]
        return ((cec[0] / paper[0], cec[1] / paper[1]),
                (got[name, "cec"][0] / got[name, baseline][0],
                 got[name, "cec"][1] / got[name, baseline][1]))

    paper2, mine2 = ratios("parabola", "vgccc")
    table2 = TABLES["parabola"]
    sec.row("Table 2, parabola: variable-gain CCC against the CEC, max/mean/RMS contour error "
            "(Table 1 plant, 60 mm/s, host sampling 1 ms)",
            f"VGCCC {'/'.join(map(str, table2['vgccc']))} mm, CEC "
            f"{'/'.join(map(str, table2['cec']))} mm; CEC / VGCCC: max {paper2[0]:.2f}, mean "
            f"{paper2[1]:.2f}",
            f"VGCCC {_cells(got['parabola', 'vgccc'])} mm, CEC "
            f"{_cells(got['parabola', 'cec'])} mm; CEC / VGCCC: max {mine2[0]:.2f}, mean "
            f"{mine2[1]:.2f}",
            f"both ratios within a factor {RATIO_TOLERANCE} of the paper's (the absolute "
            "values are not checked)",
            all(1 / RATIO_TOLERANCE <= m / p <= RATIO_TOLERANCE
                for m, p in zip(mine2, paper2, strict=True)), kind="trend")
    paper3, mine3 = ratios("bezier", "none")
    table3 = TABLES["bezier"]
    sec.row("Table 3, Bezier curve: the P controller alone against the CEC, max/mean/RMS "
            "contour error",
            f"P {'/'.join(map(str, table3['none']))} mm, CEC "
            f"{'/'.join(map(str, table3['cec']))} mm; CEC / P: max {paper3[0]:.3f}, mean "
            f"{paper3[1]:.3f} (its text: \"about 5 times\" smaller)",
            f"P {_cells(got['bezier', 'none'])} mm, CEC {_cells(got['bezier', 'cec'])} mm; "
            f"CEC / P: max {mine3[0]:.3f}, mean {mine3[1]:.3f}",
            f"CEC mean at most 1/{TABLE3_FACTOR} of the P controller's (the text's factor), "
            "CEC max below P's",
            mine3[1] <= 1 / TABLE3_FACTOR and mine3[0] < 1, kind="trend")
    return [
        "Tables 2 and 3 run the host's contour controllers (`[contour] controller`, "
        "docs/guide/contour.md) on the same chords: every 1 ms the 8085 reads each axis's "
        "COMMAND and ERROR over the bus and writes its correction to the K3702's "
        "correction-pulse register. The chords carry the exact curve (a cubic Bezier curve; "
        "the parabola's quadratic raised to degree 3), as a G5 spline's chords do, so the "
        "CEC's nearest point and the VGCCC's osculating circle are the curve's. Assumptions "
        "the paper leaves open: the VGCCC's gains are the CEC's PID (Kcp 7, Kci 50/s, "
        "Kcd 0.5 s), so the two differ only in their contour error model; the distributor "
        "applies the PID to the contour error vector component by component (the PID of the "
        "error along the vector while its direction holds), its integral keeping only its "
        "part across the path's tangent (it turns with the path); the derivative is the plain "
        "difference over one sample; the computation takes no time (the paper's PC), the "
        "reads and writes take the 8085's.",
        "RMS is read as the root mean square of the contour error over the samples while the "
        "chords run; the paper's RMS below its mean (Table 2's VGCCC, Table 3's P controller) "
        "cannot be that, so the standard deviation about the mean is shown beside it. The "
        "rows accept on the ratio CEC / baseline: the absolute values depend on what the "
        "paper leaves out (its friction, its interpolator's exact speed, its resolution), "
        "and Table 3's 0.002 mm mean is below half of this emulator's 5 um LSB, where the "
        "encoder's counts and the derivative of a quantised error set the CEC's floor. "
        f"The CEC cuts the Bezier curve's mean contour error {1 / mine3[1]:.0f} times "
        f"(the table: {1 / paper3[1]:.0f} times, the text: about {TABLE3_FACTOR} times).",
    ]


def _figure(got: dict[str, _Contour], controlled: dict[str, _Contour],
            curves: dict[str, Curve], machine_tool: np.ndarray, out: Path) -> str:
    plt = pyplot()
    fig, (a, b, c) = plt.subplots(1, 3, figsize=(14, 4.2))
    for name, run in got.items():
        line = curves[name].at(np.linspace(0.0, 1.0, 2001))
        a.plot(line[:, 0], line[:, 1], "k--", lw=0.6)
        a.plot(run.actual[:, 0], run.actual[:, 1], lw=0.8, label=f"{name}: tool")
        b.plot(run.t, run.error, lw=0.8, label=f"{name}: machine")
        b.plot(run.t, run.model, lw=0.6, ls=":", label=f"{name}: linear model")
    a.set(title="the contour-error paper's curves (dashed) and the tool", xlabel="x (mm)",
          ylabel="y (mm)", aspect="equal")
    a.legend(fontsize=8)
    for key, run in controlled.items():
        name, controller = CONTOUR_RUNS[key]
        b.plot(run.t, run.error, lw=0.8, label=f"{name}: {controller.upper()}")
    b.set(title="contour error (P controller; host's VGCCC and CEC)", xlabel="time (s)",
          ylabel="mm")
    b.legend(fontsize=8)
    curve = curves["parabola"]
    ref, tool = np.array(FIG6B["reference"]), np.array(FIG6B["tool"])
    u_ref = curve.nearest(ref[None, :])[0][0]
    _, (radius, cx, cy) = curve.osculating_estimate(u_ref, tool)
    ring = np.linspace(0, 2 * math.pi, 721)
    line = curve.at(np.linspace(0.0, 0.6, 601))
    foot = curve.at(curve.nearest(tool[None, :])[0])[0]
    c.plot(line[:, 0], line[:, 1], "k", lw=0.8, label="parabola")
    c.plot(cx + radius * np.cos(ring), cy + radius * np.sin(ring), "C1", lw=0.6,
           label=f"osculating circle R {radius:.3f}")
    c.plot(*ref, "ko", ms=4, label="350th reference point")
    c.plot(*tool, "C3s", ms=4, label="tool (paper, variable-gain CCC)")
    c.plot(*machine_tool, "C0^", ms=4, label="tool (machine, P only)")
    c.plot([tool[0], foot[0]], [tool[1], foot[1]], "C2", lw=1.5, label="contour error vector")
    c.set(title="Fig. 6(b) from its printed points", xlabel="x (mm)", ylabel="y (mm)",
          xlim=(5, 17), ylim=(-16, -6), aspect="equal")
    c.legend(fontsize=7)
    return save_figure(fig, out, "contour_error.png")
