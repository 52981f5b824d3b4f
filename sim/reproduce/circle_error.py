"""The motion-errors paper's radius error of a circle: its L16 conditions, the formulas, the
measured arcs.

The steady radius loss of a circle of radius R at speed V through a post-interpolation
accel/decel circuit and the servo is R (1 - |G_acc(jw)| |G(jw)|), w = V / R
(:func:`exact_loss`); the motion-errors paper's eqs (9)/(10) are its second-order terms
(:func:`paper_loss`);
two axes of different gains turn the circle into an ellipse (:func:`mismatch_ellipse`).
:func:`arc_losses` measures the L16 runs of :mod:`~k37.sim.reproduce.motion_errors`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from k37.firmware_model.job import ServoConfig
from k37.sim.reproduce.runs import MACHINE, RunData, Trace
from k37.sim.reproduce.theory import accel_gain, servo_gain, servo_response
from k37.sim.run.ballbar import Ballbar, circle_figures
from k37.sim.study.design import design

__all__ = ["LEVELS", "LINEAR_A", "SETTLE_S", "TM_MOTOR", "TRUNCATION", "ArcLoss", "Condition",
           "arc_losses", "conditions", "exact_loss", "loss_table", "mismatch_ellipse",
           "paper_loss", "run_key", "steady"]

#: Table 1's levels: feed (mm/min), radius (mm), inertia ratio, time constant (s), position
#: gain (1/s; the table's 30000 to 39000 "msec" read as 0.001/s: the usual Kp of 30/s).
LEVELS = {"feed": (1000.0, 1500.0, 2000.0, 2500.0), "radius": (50.0, 100.0, 150.0, 200.0),
          "inertia": (0.3, 0.5, 0.7, 0.9), "tau": (0.015, 0.025, 0.035, 0.045),
          "kp": (30.0, 33.0, 36.0, 39.0)}
#: The inertia ratio sets the drive's velocity lag Tm = TM_MOTOR (1 + ratio) (the lag grows
#: with the inertia it drives): 4 ms at the filters paper's usual 60%.
TM_MOTOR = 0.0025
#: Eq (10)'s A: the moving average's radius loss T^2 V^2 / (24 R) (eq (9)'s is T^2 V^2 / 2R).
LINEAR_A = 12
#: The steady state starts this long after the arc does (6 of the slowest time constant).
SETTLE_S = 0.3
#: Where each circuit's output sits, on average, against its filter while it moves (LSB per
#: axis): the linear circuit's count is the floor of its moving average (the accumulator
#: keeps the fraction, half a pulse on average, until it drains); the exponential circuit's
#: counter feeds the fraction back, and its count has no such offset.
TRUNCATION = {"exponential": 0.0, "linear": -0.5}


@dataclass(frozen=True)
class Condition:
    """One run of the L16 array (Table 2)."""

    feed: float
    radius: float
    inertia: float
    tau: float
    kp: float

    @property
    def tm(self) -> float:
        return TM_MOTOR * (1 + self.inertia)

    @property
    def servo(self) -> ServoConfig:
        return ServoConfig(kp=self.kp, tm=self.tm)


def conditions() -> list[Condition]:
    """The 16 runs of the L16(4^5) array over Table 1's levels."""
    names = tuple(LEVELS)
    return [Condition(*(LEVELS[name][level] for name, level in zip(names, row, strict=True)))
            for row in design("L16", [4] * len(names))]


def exact_loss(shape: str, radius: float, speed: float, kp: float, tm: float,
               tau: float) -> float:
    """The steady radius loss R (1 - |G_acc(jw)| |G(jw)|), w = V / R (any length unit)."""
    w = speed / radius
    return radius * (1 - accel_gain(shape, w, tau) * servo_gain(w, kp, tm))


def paper_loss(shape: str, radius: float, speed: float, kp: float, tau: float,
               tm: float = 0.0) -> float:
    """Eqs (9)/(10): V^2 / (2 R Kp^2) + T^2 V^2 / (2 A R), A = 1 (exponential) or 12 (linear);
    ``tm`` > 0 multiplies the servo term by (1 - 2 Kp Tm), the drive's velocity lag."""
    a = LINEAR_A if shape == "linear" else 1
    return speed**2 / (2 * radius) * ((1 - 2 * kp * tm) / kp**2 + tau**2 / a)


def mismatch_ellipse(shape: str, radius: float, speed: float, kps: tuple[float, float],
                     tm: float, tau: float) -> Ballbar:
    """The steady circle (CCW) of two axes with the gains ``kps``: its ballbar figures."""
    w = speed / radius
    phase = np.linspace(0, 2 * math.pi, 720, endpoint=False)
    gain = accel_gain(shape, w, tau)
    x, y = (radius * gain * np.real(servo_response(w, kp, tm) * np.exp(1j * (phase - shift)))
            for kp, shift in zip(kps, (0, math.pi / 2), strict=True))
    return circle_figures(phase / w, x, y, radius)


def run_key(shape: str, k: int) -> str:
    return f"s001_{shape}_{k + 1:02d}"


def steady(run: RunData, center: tuple[float, float]) -> tuple[np.ndarray, ...]:
    """Times, positions round ``center`` (LSB) and command path speed (LSB/s) of the arc's
    steady part: from SETTLE_S after its start to its end."""
    trace = Trace(run, MACHINE["post"].clock_hz)
    keep = (trace.t >= SETTLE_S) & (trace["cycle"] <= run.report["blocks"][0]["end_cycle"])
    dt = trace.t[1] - trace.t[0]
    speed = np.hypot(np.gradient(trace["x_command"]), np.gradient(trace["y_command"])) / dt
    return (trace.t[keep], trace["x_actual"][keep] - center[0],
            trace["y_actual"][keep] - center[1], speed[keep])


@dataclass(frozen=True)
class ArcLoss:
    """An L16 run's steady radius loss (LSB, positive inward) and its speed (LSB/s)."""

    condition: Condition
    loss: float
    speed: float

    def exact(self, shape: str) -> float:
        c = self.condition
        return exact_loss(shape, 1000 * c.radius, self.speed, c.kp, c.tm, c.tau)

    def paper(self, shape: str, tm: float = 0.0) -> float:
        c = self.condition
        return paper_loss(shape, 1000 * c.radius, self.speed, c.kp, c.tau, tm)


def arc_losses(runs: dict[str, RunData], shape: str) -> list[ArcLoss]:
    """The L16 runs of one filter shape, measured round their centres (moved by the
    circuit's :data:`TRUNCATION`)."""
    out = []
    for k, c in enumerate(conditions()):
        shift = TRUNCATION[shape]
        _, x, y, speed = steady(runs[run_key(shape, k)], (shift - 1000 * c.radius, shift))
        out.append(ArcLoss(c, -float(np.mean(np.hypot(x, y) - 1000 * c.radius)),
                        float(np.sqrt(np.mean(speed**2)))))
    return out


def loss_table(arcs: dict[str, list[ArcLoss]]) -> str:
    """Every L16 run: its levels, and each filter's radius loss against the formulas (LSB)."""
    lines = ["| run | F (mm/min) | R (mm) | inertia | T (ms) | Kp (1/s) | exponential: "
             "emulator / exact / eq (9) | linear: emulator / exact / eq (10) |",
             "|---|---|---|---|---|---|---|---|"]
    for k, (e, lin) in enumerate(zip(*arcs.values(), strict=True)):
        c = e.condition
        cells = [f"{a.loss:.2f} / {a.exact(shape):.2f} / {a.paper(shape):.2f}"
                 for shape, a in (("exponential", e), ("linear", lin))]
        lines.append(f"| {k + 1} | {c.feed:g} | {c.radius:g} | {c.inertia:.0%} | "
                     f"{1e3 * c.tau:g} | {c.kp:g} | {cells[0]} | {cells[1]} |")
    return "\n".join(lines)
