"""What ``k37 run`` writes: the summary, JSON report, trace CSV, plot and GTKWave file."""

from __future__ import annotations

import csv
import json
import math
import sys
from pathlib import Path

import numpy as np

from firmware_model.gcode import Arc, Line
from sim.run.runner import RunResult
from sim.run.sampler import TRACE_COLUMNS

__all__ = ["summary", "write_gtkw", "write_outputs", "write_plot", "write_trace"]


def summary(result: RunResult) -> str:
    """A few lines for the terminal."""
    r = result.report
    lines = [f"k37 run {result.job.name}: {r['status']} after {r['cycles']:,} cycles "
             f"({r['machine_seconds']:.3f} s machine time, {r['wall_seconds']:.2f} s wall, "
             f"{r['cycles_per_second']:,.0f} cycles/s on {r['backend']}"
             + (f", {r['skipped_cycles']:,} idle cycles skipped" if r["skipped_cycles"] else "")
             + ")",
             f"  blocks {len(r['blocks'])}, contour error max {r['path']['max_contour_error']:.2f}"
             f" LSB, rms {r['path']['rms_contour_error']:.2f} LSB"]
    for axis, a in r["axes"].items():
        lines.append(f"  {axis}: command {a['command']}, actual {a['actual']}, error "
                     f"{a['error']}, max |error| {a['max_abs_error']}")
    lines += [f"  {a['kind']} on axis {a['axis'] or '-'} at cycle {a['cycle']:,}"
              for a in r["alarms"]]
    return "\n".join(lines)


def write_trace(result: RunResult, path: Path) -> None:
    """The samples as CSV, one row per sample, columns :data:`sim.run.TRACE_COLUMNS`."""
    with open(path, "w", newline="") as f:
        out = csv.writer(f)
        out.writerow(TRACE_COLUMNS)
        for row in result.samples:
            out.writerow([f"{v:.4f}" if "volts" in name else int(v)
                          for name, v in zip(TRACE_COLUMNS, row, strict=True)])


def _programmed_path(result: RunResult) -> list[np.ndarray]:
    pieces = []
    for item in result.job.program.items:
        if isinstance(item, Line):
            pieces.append(np.array([item.start, item.end], dtype=float))
        elif isinstance(item, Arc):
            cx, cy = item.start[0] + item.i, item.start[1] + item.j
            radius = math.hypot(item.i, item.j)
            a0 = math.atan2(item.start[1] - cy, item.start[0] - cx)
            a1 = math.atan2(item.end[1] - cy, item.end[0] - cx)
            sweep = (a1 - a0) % (2 * math.pi) if not item.cw else -((a0 - a1) % (2 * math.pi))
            if sweep == 0:
                sweep = -2 * math.pi if item.cw else 2 * math.pi
            t = a0 + np.linspace(0, sweep, 720)
            pieces.append(np.column_stack([cx + radius * np.cos(t), cy + radius * np.sin(t)]))
    return pieces


def write_plot(result: RunResult, path: Path) -> None:
    """Programmed vs actual path, magnified radial error (arcs), axis speeds, DAC volts."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    s = result.samples
    clock = result.report["clock_hz"]
    lsb_mm = result.job.machine.lsb_mm
    fig, axes = plt.subplots(2, 2, figsize=(12, 10))
    ax = axes[0][0]
    for piece in _programmed_path(result):
        ax.plot(piece[:, 0] * lsb_mm, piece[:, 1] * lsb_mm, color="0.6", lw=2)
    ax.plot(s[:, 3] * lsb_mm, s[:, 4] * lsb_mm, color="C0", lw=0.8, label="actual")
    ax.set(title="path (grey: programmed)", xlabel="x (mm)", ylabel="y (mm)")
    ax.set_aspect("equal", adjustable="datalim")

    ax = axes[0][1]
    arcs = [it for it in result.job.program.items if isinstance(it, Arc)]
    if arcs:
        arc = arcs[0]
        cx, cy = arc.start[0] + arc.i, arc.start[1] + arc.j
        radius = math.hypot(arc.i, arc.j)
        ang = np.degrees(np.arctan2(s[:, 4] - cy, s[:, 3] - cx))
        err = np.hypot(s[:, 3] - cx, s[:, 4] - cy) - radius
        ax.plot(ang, err, ".", ms=2)
        ax.set(title=f"radial error of the first arc (R = {radius:.0f} LSB)",
               xlabel="angle (deg)", ylabel="actual radius - R (LSB)")
    else:
        ax.text(0.5, 0.5, "no arc in the program", ha="center", transform=ax.transAxes)
        ax.set_axis_off()

    t = s[:, 0] / clock
    ax = axes[1][0]
    if len(s) > 1:
        dt = np.diff(t)
        for col, name in ((3, "x"), (4, "y")):
            speed = result.job.machine.mm_per_min(np.diff(s[:, col]) / dt)
            ax.plot(t[1:], speed, label=f"{name}")
    ax.set(title="axis speeds", xlabel="time (s)", ylabel="mm/min")
    ax.legend()
    ax = axes[1][1]
    ax.plot(t, s[:, 7], label="x")
    ax.plot(t, s[:, 8], label="y")
    ax.set(title="D/A output", xlabel="time (s)", ylabel="volts")
    ax.legend()
    fig.suptitle(f"k37 run {result.job.name}: {result.report['status']}")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


#: Signals of the GTKWave save file, grouped per chip and axis: (group, names).
GTKW_GROUPS = (
    ("host bus", ("bus__addr", "bus__w_stb", "bus__w_data", "bus__r_stb", "bus__r_data",
                  "irq_interp", "irq_alarm")),
    ("feed", ("fp", "fp_total")),
    ("K3701", ("step_x_pos", "step_x_neg", "step_y_pos", "step_y_neg")),
    ("K3702 x", ("x__command", "x__error", "x__dac", "x__alarm_n")),
    ("K3702 y", ("y__command", "y__error", "y__dac", "y__alarm_n")),
    ("plant x", ("x__count",)),
    ("plant y", ("y__count",)),
)


def vcd_signals(path: Path) -> dict[str, int]:
    """Every ``scope.name`` a VCD file declares, with its width in bits."""
    names: dict[str, int] = {}
    scopes: list[str] = []
    with open(path) as f:
        for line in f:
            words = line.split()
            if not words:
                continue
            if words[0] == "$scope":
                scopes.append(words[2])
            elif words[0] == "$upscope":
                scopes.pop()
            elif words[0] == "$var":
                names[".".join([*scopes, words[4]])] = int(words[2])
            elif words[0] == "$enddefinitions":
                break
    return names


def write_gtkw(vcd: Path, path: Path) -> list[str]:
    """A GTKWave save file for ``vcd`` showing the chips' main signals, grouped.

    Each listed name is looked up among the signals the VCD declares (by its last name
    component, the shortest path winning), so the file names only existing signals.
    Returns the signals written.
    """
    declared = vcd_signals(vcd)
    lines = [f'[dumpfile] "{vcd.resolve()}"', "[timestart] 0"]
    written = []
    for group, names in GTKW_GROUPS:
        found = []
        for name in names:
            match = [d for d in declared if d.rsplit(".", 1)[-1] == name]
            if match:
                found.append(min(match, key=len))
        if not found:
            continue
        lines.append(f"@800200\n-{group}")
        for sig in found:
            lines.append(f"@{'28' if declared[sig] == 1 else '22'}\n{sig}")
        lines.append(f"@1000200\n-{group}")
        written += found
    path.write_text("\n".join(lines) + "\n")
    return written


def write_outputs(result: RunResult, *, json_path: str | None, trace: Path | None,
                  plot: Path | None, gtkw: Path | None, vcd: Path | None,
                  quiet: bool = False) -> None:
    """Write every output the command line asked for."""
    if json_path == "-":
        json.dump(result.report, sys.stdout, indent=2)
        print()
    elif json_path:
        Path(json_path).write_text(json.dumps(result.report, indent=2) + "\n")
    if trace:
        write_trace(result, trace)
    if plot:
        write_plot(result, plot)
    if gtkw:
        if vcd is None:
            raise ValueError("--gtkw needs --vcd")
        write_gtkw(vcd, gtkw)
    if not quiet and json_path != "-":
        print(summary(result))
