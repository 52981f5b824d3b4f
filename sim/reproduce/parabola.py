"""Experiment 7: the contour-error paper's parabola as one hardware parabola block against G01
chords.

The contour-error paper tracks the parabola y = (x - 15)^2 / 15 - 15
(mm). The KM3701 has a parabolic mode (the system paper, section 2 (1)): here the whole curve is one
G06 block, and the same curve cut into G01 chords runs at the same feed on the same machine
(FP control). Both are measured against the true parabola: the interpolated (command) path,
the actual path, the FP the host loads and the run time.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from k37.firmware_model.motion.program import Line, Parabola
from k37.sim.reproduce.markdown import Section, pyplot, save_figure
from k37.sim.reproduce.runs import MACHINE, PARABOLA_FEED, RunData, Specs, Trace

__all__ = ["section"]


@dataclass(frozen=True)
class _Result:
    """One program's run against the true parabola."""

    command: float      # largest distance of the command path (LSB)
    actual: float       # largest distance of the actual path (LSB)
    rms: float          # RMS distance of the actual path (LSB)
    fp: int             # FP loaded, all blocks
    seconds: float      # first block's start to the last block's end
    blocks: int
    end: tuple[int, int]


def _measure(run: RunData, curve: Parabola, clock_hz: float) -> _Result:
    trace = Trace(run, clock_hz)
    blocks = run.report["blocks"]
    command = np.column_stack([trace["x_command"], trace["y_command"]])
    actual = np.column_stack([trace["x_actual"], trace["y_actual"]])
    moving = (trace.t >= 0) & (trace["cycle"] <= blocks[-1]["end_cycle"])
    on_actual = curve.distances(actual[moving])
    axes = run.report["axes"]
    return _Result(float(curve.distances(command[moving]).max()), float(on_actual.max()),
                   float(np.sqrt(np.mean(on_actual**2))), sum(b["fp_budget"] for b in blocks),
                   (blocks[-1]["end_cycle"] - blocks[0]["start_cycle"]) / clock_hz,
                   len(blocks), (axes["x"]["command"], axes["y"]["command"]))


def section(runs: dict[str, RunData], specs: Specs, out: Path) -> Section:
    """Experiment 7's rows, text and figure ``parabola.png``."""
    sec = Section(7, "Parabolic interpolation: the contour-error paper's parabola, one G06 "
                     "block against G01 chords", ("parabola", "parabola_chords"))
    clock = MACHINE["pre"].clock_hz
    curve = specs["parabola"].move(Parabola)
    chords = [item for item in specs["parabola_chords"].job().program.items
              if isinstance(item, Line)]
    hw = _measure(runs["parabola"], curve, clock)
    cut = _measure(runs["parabola_chords"], curve, clock)
    sec.row("the K3701's parabolic interpolation (the system paper's section 2 (1)) on the "
            "contour-error paper's parabola",
            "parabolic interpolation is possible (no figure)",
            f"one G06 block: command path within {hw.command:.2f} LSB of the true parabola, "
            f"ends at {hw.end}",
            f"within 0.5 LSB + 1 encoder count; ends at {curve.end} exactly",
            hw.command <= 1.5 and hw.end == curve.end, kind="trend")
    sec.row("parabola block against G01 chords at the same feed "
            f"(F{PARABOLA_FEED:g})",
            "no figure (the contour-error paper tracks this parabola with its own controller)",
            f"contour error max {hw.actual:.1f} LSB (RMS {hw.rms:.1f}), {hw.fp} FP, "
            f"{hw.seconds:.2f} s vs {len(chords)} chords: max {cut.actual:.1f} LSB (RMS "
            f"{cut.rms:.1f}), command path {cut.command:.1f} LSB off, {cut.fp} FP, "
            f"{cut.seconds:.2f} s",
            "the parabola block's contour error and run time below the chords'",
            hw.actual < cut.actual and hw.seconds < cut.seconds, kind="quoted")
    sec.text += [
        "The parabola of the contour-error paper, y = (x - 15)^2 / 15 - 15 mm from (0, 0) to "
        "(30, 0), runs "
        "as one G06 block (I15 J-15: the vertex, where the tangent is parallel to the chord) "
        f"and as {len(chords)} G01 chords of equal X, both at F{PARABOLA_FEED:g} under "
        "FP control. The chords' command path is off the curve by their sagitta, and each "
        "chord is a block of its own: the FP budget gate closes at each block's end and the "
        "accel/decel circuit drains (tau = 300 ms) before the next block starts, so the "
        "chords stop the axes between blocks. The parabola block is one block: one "
        "acceleration, one deceleration.",
    ]
    plt = pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.8))
    for key, label in (("parabola", "G06 block"), ("parabola_chords", "G01 chords")):
        trace = Trace(runs[key], clock)
        a.plot(trace["x_actual"] / 1000, trace["y_actual"] / 1000, lw=0.8, label=label)
        b.plot(trace.t, curve.distances(np.column_stack([trace["x_actual"],
                                                         trace["y_actual"]])),
               lw=0.8, label=label)
    line = curve.polyline()
    a.plot(line[:, 0] / 1000, line[:, 1] / 1000, "k--", lw=0.6, label="true parabola")
    a.set(title="the contour-error paper's parabola", xlabel="x (mm)", ylabel="y (mm)")
    a.legend(fontsize=8)
    b.set(title="distance of the actual path to the parabola", xlabel="time (s)",
          ylabel="LSB")
    b.legend(fontsize=8)
    sec.figure = save_figure(fig, out, "parabola.png")
    return sec
