"""The ``--plot`` figure: what a motion engineer looks at first.

Six panels: the programmed and the actual path (each block's start marked with its G-code
line); the contour error per block (largest and RMS); and, along the run's time, the contour
error (the report's, :func:`sim.run.contour.contour_errors`), each axis's following error (the
K3702 error counter), the axis and path speeds (position differences over
:data:`SPEED_WINDOW_S` windows, not per-sample encoder counts) against the programmed feed,
and the D/A output. Every time panel marks each block's start with its G-code line. Built by
:func:`figure` (a matplotlib ``Figure``, for tests and notebooks), written by
:func:`write_plot`.
"""

from __future__ import annotations

from functools import reduce
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from firmware_model.firmware import run_feed
from firmware_model.gcode.parser import Arc, Line
from firmware_model.gcode.program import Exponential, Move, Parabola
from sim.run.plot_data import PlotData, plot_data
from sim.run.runner import RunResult

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["SPEED_WINDOW_S", "figure", "programmed_path", "windowed_speed", "write_plot"]

#: The window the speeds are measured over (s): 20 ms, one encoder count in it is
#: 3 mm/min at 1 um per LSB.
SPEED_WINDOW_S = 0.02
#: The gid of the block boundary lines (tests find them by it).
BOUNDARY = "block boundary"

def programmed_path(result: RunResult) -> list[np.ndarray]:
    """The program's moves as polylines (LSB), one array of machine-axis rows ((x, y) or
    (x, y, z)) per move; an arc in its plane, a helix rising along the normal with the angle."""
    pieces = []
    for item in result.job.program.items:
        if isinstance(item, Line):
            pieces.append(np.array([item.start, item.end], dtype=float))
        elif isinstance(item, Arc):
            cx, cy = item.center
            a0, sweep = item.span
            t = a0 + np.linspace(0, -sweep if item.cw else sweep, 720)
            first, second, normal = item.plane_axes
            piece = np.zeros((len(t), len(item.start)))
            piece[:, first] = cx + item.radius * np.cos(t)
            piece[:, second] = cy + item.radius * np.sin(t)
            if normal < len(item.start):
                piece[:, normal] = np.linspace(item.start[normal], item.end[normal], len(t))
            pieces.append(piece)
        elif isinstance(item, Parabola | Exponential):
            pieces.append(item.polyline())
    return pieces


def windowed_speed(cycles: np.ndarray, position: np.ndarray, clock_hz: float,
                   window: int) -> tuple[np.ndarray, np.ndarray]:
    """Speed (LSB/s) as the position difference over ``window`` samples, at the middle of each
    window (s): the times and the speeds (empty with fewer than two samples)."""
    window = min(window, len(cycles) - 1)
    if window < 1:
        return np.zeros(0), np.zeros(0)
    dt = (cycles[window:] - cycles[:-window]) / clock_hz
    return ((cycles[window:] + cycles[:-window]) / 2 / clock_hz,
            (position[window:] - position[:-window]) / dt)


def _mm_axis(ax: Axes, lsb_mm: float) -> None:
    """A second y axis on the right in mm for an axis in LSB."""
    sec = ax.secondary_yaxis("right", functions=(lambda v: v * lsb_mm, lambda v: v / lsb_mm))
    sec.set_ylabel("mm")


def _boundaries(ax: Axes, result: RunResult) -> None:
    """A dashed vertical line at each block's start, labelled with its G-code line."""
    clock = result.report["clock_hz"]
    for block in result.report["blocks"]:
        t = block["start_cycle"] / clock
        ax.axvline(t, color="0.5", ls="--", lw=0.8, gid=BOUNDARY)
        ax.text(t, 0.99, f" N{block['line']}", transform=ax.get_xaxis_transform(),
                va="top", ha="left", fontsize=8, color="0.3")


def _series(ax: Axes, t: np.ndarray, data: PlotData, column: str, **style: object) -> None:
    """One column along the run: its samples, or, when a bucket holds several, each bucket's
    largest value and the band down to its least."""
    low, high = data.envelope(column)
    (line,) = ax.plot(t, high, lw=0.8, **style)
    if data.bucket > 1:
        ax.fill_between(t, low, high, color=line.get_color(), lw=0)


def _code(item: Move) -> str:
    """The G code of a move."""
    if isinstance(item, Parabola | Exponential):
        return item.code
    if isinstance(item, Arc):
        return "G02" if item.cw else "G03"
    return "G00" if item.rapid else "G01"


def figure(result: RunResult) -> Figure:
    """The plot of a run as a matplotlib figure (see the module's docstring)."""
    from matplotlib.figure import Figure

    col = {name: k for k, name in enumerate(result.store.columns)}
    axes = result.job.machine.axis_names
    clock = result.report["clock_hz"]
    machine = result.job.machine
    lsb_mm = machine.lsb_mm
    blocks = result.report["blocks"]
    data = plot_data(result.job, [(b["index"], b["start_cycle"]) for b in blocks],
                     result.store)
    s = data.rows
    cycles, t = s[:, 0], s[:, 0] / clock
    fig = Figure(figsize=(15, 14), layout="constrained")
    grid = fig.subplots(3, 2)
    (path_ax, bars), (contour_ax, follow), (speed_ax, dac) = grid
    for ax in (follow, speed_ax, dac):
        ax.sharex(contour_ax)

    for piece in programmed_path(result):
        path_ax.plot(piece[:, 0] * lsb_mm, piece[:, 1] * lsb_mm, color="0.7", lw=3)
    path_ax.plot(s[:, col["x_actual"]] * lsb_mm, s[:, col["y_actual"]] * lsb_mm, color="C0",
                 lw=0.9, label="actual")
    items = {item.index: item for item in result.job.program.items}
    for block in blocks:
        x0, y0 = items[block["index"]].start[:2]
        path_ax.plot(x0 * lsb_mm, y0 * lsb_mm, "k.", ms=5)
        path_ax.annotate(f"N{block['line']}", (x0 * lsb_mm, y0 * lsb_mm), fontsize=8,
                         xytext=(3, 3), textcoords="offset points")
    path_ax.set(title="path: programmed (grey) and actual (blue); dots: block starts"
                      + (" (XY projection)" if len(axes) == 3 else ""),
                xlabel="x (mm)", ylabel="y (mm)")
    path_ax.set_aspect("equal", adjustable="datalim")

    stats = data.blocks
    where = np.arange(len(blocks))
    for shift, k, name in ((-0.2, 0, "max"), (0.2, 1, "RMS")):
        bar = bars.bar(where + shift, [st[k] for st in stats], width=0.4, label=name)
        bars.bar_label(bar, fmt="%.1f", fontsize=8)
    bars.set_xticks(where, [f"N{b['line']}\n{_code(items[b['index']])}" for b in blocks])
    bars.set_xlim(-0.7, len(blocks) - 0.3)
    bars.set(title="contour error per block (from its start to the next block's start)",
             xlabel="block (G-code line)", ylabel="LSB")
    bars.legend()
    _mm_axis(bars, lsb_mm)

    path = result.report["path"]
    _series(contour_ax, t, data, "contour_error", color="C3")
    contour_ax.set(title=f"contour error (max {path['max_contour_error']:.2f} LSB, "
                         f"RMS {path['rms_contour_error']:.2f} LSB)",
                   xlabel="time (s)", ylabel="distance to the programmed path (LSB)")
    _mm_axis(contour_ax, lsb_mm)

    for axis in axes:
        _series(follow, t, data, f"{axis}_error", label=axis)
    follow.set(title="following error (K3702 error counter)", xlabel="time (s)",
               ylabel="command - actual (LSB)")
    follow.legend()
    _mm_axis(follow, lsb_mm)

    period = cycles[1] - cycles[0] if len(s) > 1 else 1.0  # the sampling period (cycles)
    window = max(1, round(SPEED_WINDOW_S * clock / period))
    speeds = {axis: windowed_speed(cycles, s[:, col[f"{axis}_actual"]], clock, window)
              for axis in axes}
    tx = speeds["x"][0]
    for axis in axes:
        speed_ax.plot(tx, machine.mm_per_min(speeds[axis][1]), lw=0.8, label=axis)
    path_speed = reduce(np.hypot, [v for _, v in speeds.values()])
    speed_ax.plot(tx, machine.mm_per_min(path_speed), color="k", lw=1.0, label="path")
    items = result.job.program.items
    feeds = [run_feed(items[b["index"]], machine) for b in blocks]
    for k, block in enumerate(blocks):
        end = block["end_cycle"] if block["end_cycle"] is not None else cycles[-1] if len(s) \
            else block["start_cycle"]
        speed_ax.hlines(feeds[k], block["start_cycle"] / clock,
                        end / clock, colors="0.4", linestyles=":", lw=1.5,
                        label="programmed feed" if k == 0 else None)
    speed_ax.set(title=f"speeds (position change over {window} samples = "
                       f"{window * period / clock * 1e3:g} ms)",
                 xlabel="time (s)", ylabel="mm/min")
    speed_ax.set_ylim(top=1.3 * max([speed_ax.get_ylim()[1], *feeds]))
    speed_ax.legend(fontsize=8, ncols=4, loc="upper center", bbox_to_anchor=(0.5, 0.93))

    for axis in axes:
        _series(dac, t, data, f"{axis}_dac_volts", label=axis)
    dac.set(title="D/A output", xlabel="time (s)", ylabel="V")
    dac.legend()

    for ax in (contour_ax, follow, speed_ax, dac):
        _boundaries(ax, result)
    # the job's name is the user's text: never TeX ("$x$" would be parsed as math)
    fig.suptitle(f"k37 run {result.job.name}: {result.report['status']}: "
                 f"{result.report['reason']}", parse_math=False)
    return fig


def write_plot(result: RunResult, path: Path) -> None:
    """Write :func:`figure` to ``path`` (any format matplotlib writes, by its suffix)."""
    figure(result).savefig(path, dpi=100)
