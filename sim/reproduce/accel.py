"""Experiment 1: the exponential accel/decel curve (Photos 1 and 2).

The line run under FP control at the high feed: the FP rate into the K3701 against a
first-order lag of the FP count, and the X axis's D/A voltage in the closed loop against that
lag through the servo.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from k37.firmware_model.feeds import word_feed
from k37.firmware_model.job import AXES
from k37.firmware_model.motion.program import Line
from k37.sim.machine.plant_model import DAC_VOLTS
from k37.sim.reproduce.markdown import Section, pct, pyplot, save_figure
from k37.sim.reproduce.paper import FEED_HIGH, PAPER_TAU_S
from k37.sim.reproduce.runs import MACHINE, SERVO, RunData, Specs, Trace
from k37.sim.reproduce.theory import E63, fp_rate, hardware_tau, lag, servo

__all__ = ["section"]


def _crossing(t: np.ndarray, v: np.ndarray, level: float) -> float:
    """The first time ``v`` reaches ``level`` (linear interpolation between samples)."""
    k = int(np.argmax(v >= level))
    if v[k] < level or k == 0:
        return math.nan
    return float(t[k - 1] + (level - v[k - 1]) * (t[k] - t[k - 1]) / (v[k] - v[k - 1]))


def section(runs: dict[str, RunData], specs: Specs, out: Path) -> Section:
    """Experiment 1's rows, text and figure ``accel.png``."""
    sec = Section(1, "Exponential acceleration (Photos 1 and 2)", ("line",))
    machine = MACHINE["pre"]
    run = Trace(runs["line"], machine.clock_hz)
    item = specs["line"].move(Line)
    fi, tau = fp_rate(machine, FEED_HIGH), hardware_tau(machine)
    # Theory: the circuit is a first-order lag of the FP count (``docs/chips/accel.md``); the gate
    # passes the block's budget at the rate fi; the long axis takes Xe / FP steps per FP.
    fed = fi * np.clip(run.t, 0, item.plan.fp / fi)
    delivered = lag(run.t, fed, tau)
    tm, rate = run.rate("fp_total", 0.02)
    rate_model = np.interp(tm, run.t, (fed - delivered) / tau)
    t63 = _crossing(tm, rate, E63 * fi)
    sec.row("accel/decel output reaches 63% of its final rate (Photo 1)",
            f"about 300 ms (tau = 2^15 / 109.227 kHz = {1e3 * PAPER_TAU_S:.0f} ms)",
            f"{1e3 * t63:.1f} ms at fi = {fi:.0f} FP/s (feed word {FEED_HIGH})",
            "within 3% of 300 ms", abs(t63 - PAPER_TAU_S) <= 0.03 * PAPER_TAU_S, kind="number")
    deviation = np.abs(rate - rate_model).max() / fi
    sec.row("output rate follows fi (1 - exp(-t/tau)) up and the exponential decay down",
            "equation (1), an exponential curve",
            f"largest deviation {pct(deviation)} of fi (20 ms windows)",
            "within 3% of fi at every sample", deviation <= 0.03, kind="number")

    scale_v = DAC_VOLTS / (1 << (machine.dac_bits - 1))
    half = 1 << (machine.dac_bits - 1)
    volts = {}
    for axis, share in zip(AXES, (item.block.xe, item.block.ye), strict=True):
        command = delivered * share / item.plan.fp
        error = command - servo(run.t, command, SERVO.kp, SERVO.tm)
        volts[axis] = np.clip(np.round(error), -half, half - 1) * scale_v
    steady = fi * item.block.xe / item.plan.fp / SERVO.kp * scale_v
    measured = run["x_dac_volts"]
    dac63 = _crossing(run.t, measured, E63 * steady)
    dac_dev = np.abs(measured - volts["x"]).max() / steady
    sec.row("closed-loop D/A voltage follows the accel/decel curve (Photo 2)",
            "the accel/decel curve seen at the D/A with the encoder feedback on",
            f"X: peak {measured.max():.3f} V (model {volts['x'].max():.3f} V; v / Kp at the "
            f"full feed {steady:.3f} V), 63% of that at {1e3 * dac63:.0f} ms; largest "
            f"deviation from the model {pct(dac_dev)}",
            "within 5% of the steady voltage at every sample", dac_dev <= 0.05, kind="trend")

    sec.text += [
        f"The paper ran the accel/decel circuit with n = 15 and fa = 109.227 kHz and read the "
        f"time constant off the D/A output: 63% of the steady state at about 300 ms (Photo 1, "
        f"the feedback disconnected), and showed the accel/decel curve again with the encoder "
        f"feedback on (Photo 2). The emulator runs a line of ({item.block.xe}, "
        f"{item.block.ye}) LSB under FP control at the feed word {FEED_HIGH} "
        f"(F{word_feed(machine, FEED_HIGH):.2f} mm/min, {fi:.0f} FP/s); its budget of "
        f"{item.plan.fp} FP keeps the feed on for {item.plan.fp / fi:.2f} s, then the "
        f"circuit drains. Photo 1 is read as the circuit's output rate (the FP rate into the "
        f"K3701, counted on the gateware); without feedback the D/A of a K3702 would show the "
        f"accumulated command, not a rate. Photo 2 is the X axis's D/A voltage in the closed "
        f"loop, which is the following error: speed / Kp.",
        "The model curves (dashed) are a first-order lag of the FP count with tau = 2^15 / fa "
        "and the servo's G(s) = Kp / (s (1 + s Tm) + Kp), computed independently of the run.",
    ]
    plt = pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.8))
    a.plot(tm, rate / 1e3, lw=1, label="emulator (FP into the K3701)")
    a.plot(tm, rate_model / 1e3, "k--", lw=0.8, label="fi (1 - exp(-t/tau)), then decay")
    a.axhline(E63 * fi / 1e3, color="C3", lw=0.6)
    a.axvline(PAPER_TAU_S, color="C3", lw=0.6)
    a.annotate(f"63% at {1e3 * t63:.0f} ms", (t63, E63 * fi / 1e3), xytext=(0.45, 0.35 * fi / 1e3),
               arrowprops={"arrowstyle": "->"})
    a.set(title="Photo 1: accel/decel output rate", xlabel="time (s)", ylabel="kFP/s")
    a.legend(fontsize=8)
    for axis, colour in zip(AXES, ("C0", "C1"), strict=True):
        b.plot(run.t, run[f"{axis}_dac_volts"], color=colour, lw=1, label=f"{axis} (emulator)")
        b.plot(run.t, volts[axis], "k--", lw=0.8)
    b.set(title="Photo 2: D/A voltage, closed loop (dashed: model)", xlabel="time (s)",
          ylabel="volts")
    b.legend(fontsize=8)
    sec.figure = save_figure(fig, out, "accel.png")
    return sec
