"""Experiment 5: the linear and circular paths under FP control (Photos 5 and 6).

The line of experiment 1 against the programmed line, and the FP-control circle of
experiment 4 closing exactly at its start.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from k37.firmware_model.job import AXES
from k37.firmware_model.motion.program import Line
from k37.sim.reproduce.markdown import Section, pyplot, save_figure
from k37.sim.reproduce.path_error import Circle
from k37.sim.reproduce.runs import MACHINE, RunData, Specs, Trace

__all__ = ["section"]


def section(runs: dict[str, RunData], circles: dict[str, Circle], specs: Specs,
            out: Path) -> Section:
    """Experiment 5's rows, text and figure ``fp_control.png``."""
    sec = Section(5, "Linear and circular paths under FP control (Photos 5 and 6)",
                  ("line", "pre_circle"))
    run = Trace(runs["line"], MACHINE["pre"].clock_hz)
    xe, ye = specs["line"].move(Line).end
    x, y = run["x_actual"], run["y_actual"]
    along = (x * xe + y * ye) / math.hypot(xe, ye)
    off = (x * ye - y * xe) / math.hypot(xe, ye)
    final = runs["line"].report["axes"]
    at_end = [final[a]["actual"] for a in AXES] == [xe, ye]
    sec.row("linear interpolation (Photo 5)", "a straight line",
            f"largest distance from the programmed line {np.abs(off).max():.2f} LSB; ends at "
            f"({final['x']['actual']}, {final['y']['actual']})",
            f"within 2 LSB (0.5 LSB of the steps' staircase + 1 encoder count); ends at "
            f"({xe}, {ye}) exactly", np.abs(off).max() <= 2 and at_end, kind="trend")
    circle = circles["pre_circle"]
    axes = runs["pre_circle"].report["axes"]
    closed = all(axes[a][k] == 0 for a in AXES for k in ("command", "actual", "error"))
    ends = ", ".join(f"{a}: command {axes[a]['command']}, actual {axes[a]['actual']}, error "
                     f"{axes[a]['error']}" for a in AXES)
    sec.row("circular interpolation (Photo 6)", "a circle",
            f"ends {ends}; radial error only the servo's ({circle.worst:.1f} LSB, row 4d)",
            "closes exactly at its start (0, 0)", closed, kind="trend")
    sec.text += [
        "Photos 5 and 6 show a line and a circle run under FP control. The emulator's are the "
        f"line of experiment 1 ({xe}, {ye}) LSB and the FP-control circle of experiment 4. "
        "Both axes have the same servo, so the lag of the servo runs along the line and "
        "takes nothing off it; the circle loses only the servo's steady-state radius (shown "
        "magnified here).",
    ]
    plt = pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.8))
    a.plot(along, off, lw=0.6)
    a.set(title=f"Photo 5: distance from the line to ({xe}, {ye})",
          xlabel="position along the line (LSB)", ylabel="LSB", ylim=(-2.5, 2.5))
    b.plot(circle.angle, circle.radial, lw=0.8, label="emulator")
    b.plot(circle.angle, circle.model, "k--", lw=0.8, label="R (1 - |G(jw)|) at its speed")
    b.set(title=f"Photo 6: radial error, R = {circle.radius}", xlabel="angle (deg)",
          ylabel="LSB")
    b.legend(fontsize=8)
    sec.figure = save_figure(fig, out, "fp_control.png")
    return sec
