"""The ``--plot`` figure: what a motion engineer looks at first.

Six panels: the programmed and the actual path (block starts dotted, some labelled with their
N-word or G-code line); the contour error per block (largest and RMS); and, along the run's
time, the contour error (the report's, :func:`k37.sim.run.contour.contour_errors`), each
axis's following error (the K3702 error counter), the axis and path speeds (position
differences over :data:`SPEED_WINDOW_S` windows, not per-sample encoder counts) against the
programmed feed, and the D/A output. Built by :func:`figure` (a matplotlib ``Figure``, for tests and
notebooks), written by :func:`write_plot`.

The figure reads the same at any program length:

* the bars show every block of a program of up to :data:`WORST_BLOCKS` blocks; of a longer
  one, the :data:`WORST_BLOCKS` blocks of largest contour error, in program order (that many
  fit the panel's width with legible tick labels);
* the time panels draw a dashed line at every block's start while there are at most
  :data:`MAX_BOUNDARIES` blocks (lines a few millimetres apart); beyond, only at the starts
  of the blocks the bars show, so the curves are never greyed by lines;
* block labels (the program's N-word, ``N30``, else the line, ``line 5``) go to the worst
  blocks first, then the others in program order, each only where it does not overlap one
  already placed (:func:`thin`); at most :data:`MAX_LABELS` per panel;
* every series is one artist (the path, the boundaries, the programmed feed), so drawing
  costs the same for 10 blocks or 10,000.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import reduce
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from k37.firmware_model.feeds import run_feed
from k37.firmware_model.motion.program import Arc, Exponential, Line, Move, Parabola
from k37.sim.run.plot_data import PlotData, plot_data
from k37.sim.run.runner import RunResult

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["MAX_BOUNDARIES", "MAX_LABELS", "SPEED_WINDOW_S", "WORST_BLOCKS", "bars_that_fit",
           "block_code", "figure", "marked_blocks", "programmed_path", "thin", "windowed_speed",
           "write_plot"]

#: The window the speeds are measured over (s): 20 ms, one encoder count in it is
#: 3 mm/min at 1 um per LSB.
SPEED_WINDOW_S = 0.02
#: The gid of the block boundary lines (tests find them by it).
BOUNDARY = "block boundary"
#: The most blocks the per-block bars show (the worst, by their largest contour error);
#: fewer when their labels would not fit the panel's width (:func:`bars_that_fit`).
WORST_BLOCKS = 20
#: The most blocks whose every start a time panel marks with a line.
MAX_BOUNDARIES = 60
#: The most block labels on a panel.
MAX_LABELS = 40
#: The figure's size (inches) and its panels' margins (fractions of the figure): fixed, so
#: that drawing it costs no layout pass.
SIZE = (15.0, 14.0)
MARGINS = {"left": 0.06, "right": 0.94, "top": 0.94, "bottom": 0.05, "wspace": 0.3,
           "hspace": 0.3}
#: The size of the labels' type (points).
LABEL_PT = 8
#: The most points a time series draws (a panel is some 600 pixels wide); each is the
#: envelope of its samples, so no peak is lost.
SERIES_POINTS = 10_000
#: Points of an arc of the programmed path per degree it sweeps (at least 8 per arc).
ARC_POINTS_PER_DEG = 2


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
            n = max(8, round(ARC_POINTS_PER_DEG * np.degrees(sweep)))
            t = a0 + np.linspace(0, -sweep if item.cw else sweep, n)
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


def panel_inches() -> float:
    """The width of one panel (inches)."""
    m = MARGINS
    return SIZE[0] * (m["right"] - m["left"]) / (2 + m["wspace"])


def panel_height_inches() -> float:
    """The height of one panel (inches)."""
    m = MARGINS
    return SIZE[1] * (m["top"] - m["bottom"]) / (3 + 2 * m["hspace"])


def text_inches(chars: int, points: float = LABEL_PT) -> float:
    """The width of a label of ``chars`` characters (inches; 0.6 em a character)."""
    return chars * 0.6 * points / 72


def thin(positions: np.ndarray, order: Sequence[int], gap: float | Sequence[float],
         most: int = MAX_LABELS) -> list[int]:
    """The indices of ``order`` (first the most wanted) whose ``positions`` (one coordinate
    per row, or a 1-D array) are, in some coordinate, at least ``gap`` (one per coordinate,
    or one for all) from every index kept before them: labels that do not overlap; at most
    ``most`` of them."""
    pos = np.asarray(positions, dtype=float).reshape(len(positions), -1)
    gaps = np.broadcast_to(np.asarray(gap, dtype=float), pos.shape[1:])
    kept: list[int] = []
    for k in order:
        if len(kept) >= most:
            break
        if not kept or np.all(np.any(np.abs(pos[kept] - pos[k]) >= gaps, axis=1)):
            kept.append(k)
    return kept


def bars_that_fit(names: Sequence[str]) -> int:
    """How many bar groups fit a panel's width with tick labels as long as the longest of
    ``names`` (in 7-point type), at most :data:`WORST_BLOCKS`."""
    longest = max(map(len, names), default=1) + 1.5
    return max(1, min(WORST_BLOCKS, int(panel_inches() / text_inches(longest, 7))))


def marked_blocks(peaks: Sequence[float], most: int = WORST_BLOCKS
                  ) -> tuple[list[int], list[int]]:
    """Which blocks (by position in the report) the figure singles out, from their largest
    contour errors: the bars' (every block up to ``most``, else the ``most`` of largest
    error, in program order) and the labels' wish list (those first, worst first, then the
    others in program order), for :func:`thin`."""
    n = len(peaks)
    worst = sorted(range(n), key=lambda k: (-peaks[k], k))
    top = worst[:most]
    chosen = set(top)
    return sorted(top), top + [k for k in range(n) if k not in chosen]


def _boundaries(ax: Axes, starts: np.ndarray, lines: Sequence[int], wanted: Sequence[int],
                names: Sequence[str], span: tuple[float, float]) -> None:
    """Dashed vertical lines at the block starts ``lines`` (s) (one artist), and the labels
    of ``wanted`` (most wanted first) that fit without overlapping."""
    if len(lines):
        ax.vlines(starts[lines], 0, 1, transform=ax.get_xaxis_transform(), colors="0.5",
                  linestyles="--", lw=0.8, gid=BOUNDARY)
    width = max(span[1] - span[0], 1e-12)
    gap = text_inches(max(map(len, names), default=1) + 1) / panel_inches()
    for k in sorted(thin((starts - span[0]) / width, wanted, gap)):
        ax.text(starts[k], 0.99, f" {names[k]}", transform=ax.get_xaxis_transform(),
                va="top", ha="left", fontsize=LABEL_PT, color="0.3")


def _series(ax: Axes, t: np.ndarray, data: PlotData, column: str, **style: object) -> None:
    """One column along the run: its samples, or, when a bucket holds several (at most
    :data:`SERIES_POINTS` buckets), each bucket's largest value and the band down to its
    least."""
    firsts, low, high, bucket = data.coarse(column, SERIES_POINTS)
    (line,) = ax.plot(t[firsts], high, lw=0.8, **style)
    if bucket > 1:
        ax.fill_between(t[firsts], low, high, color=line.get_color(), lw=0)


def block_code(item: Move) -> str:
    """The G code of a move."""
    if isinstance(item, Parabola | Exponential):
        return item.code
    if isinstance(item, Arc):
        return "G02" if item.cw else "G03"
    return "G00" if item.rapid else "G01"


def _path_panel(ax: Axes, result: RunResult, data: PlotData, starts: np.ndarray,
                wanted: Sequence[int], names: Sequence[str]) -> None:
    """The programmed path (one line, its moves separated by gaps), the actual path, a dot at
    each block's start and the labels that fit."""
    lsb_mm = result.job.machine.lsb_mm
    col = {name: k for k, name in enumerate(result.store.columns)}
    pieces = programmed_path(result)
    if pieces:
        gap = np.full((1, 2), np.nan)
        path = np.vstack([part for piece in pieces for part in (piece[:, :2], gap)])
        ax.plot(path[:, 0] * lsb_mm, path[:, 1] * lsb_mm, color="0.7", lw=3)
    s = data.rows
    ax.plot(s[:, col["x_actual"]] * lsb_mm, s[:, col["y_actual"]] * lsb_mm, color="C0",
            lw=0.9, label="actual")
    many = len(starts) > MAX_BOUNDARIES
    ax.plot(starts[:, 0] * lsb_mm, starts[:, 1] * lsb_mm, "k.", ms=2 if many else 5)
    extent = np.ptp(np.vstack([starts, *(p[:, :2] for p in pieces)]), axis=0).max() \
        if len(starts) else 0.0
    # a label's width and height as fractions of the path's longer side, which fills the
    # panel's shorter side at most
    side = min(panel_inches(), panel_height_inches())
    gap = (text_inches(max(map(len, names), default=1) + 1) / side, 1.6 * LABEL_PT / 72 / side)
    for k in thin(starts / max(extent, 1e-12), wanted, gap):
        x0, y0 = starts[k] * lsb_mm
        ax.plot(x0, y0, "k.", ms=5)
        ax.annotate(names[k], (x0, y0), fontsize=LABEL_PT, xytext=(3, 3),
                    textcoords="offset points")
    ax.set(title="path: programmed (grey) and actual (blue); dots: block starts"
                 + (" (XY projection)" if len(result.job.machine.axis_names) == 3 else ""),
           xlabel="x (mm)", ylabel="y (mm)")
    ax.set_aspect("equal", adjustable="datalim")


def _bars_panel(ax: Axes, result: RunResult, data: PlotData, shown: Sequence[int],
                codes: Sequence[str], names: Sequence[str]) -> None:
    """The largest and RMS contour error of the blocks ``shown``."""
    total = len(data.blocks)
    where = np.arange(len(shown))
    for shift, k, name in ((-0.2, 0, "max"), (0.2, 1, "RMS")):
        bar = ax.bar(where + shift, [data.blocks[b][k] for b in shown], width=0.4, label=name)
        ax.bar_label(bar, fmt="%.1f", fontsize=7, rotation=90 if len(shown) > 10 else 0,
                     padding=2)
    ax.set_xticks(where, [f"{names[b]}\n{codes[b]}" for b in shown], fontsize=7)
    ax.set_xlim(-0.7, len(shown) - 0.3)
    ax.set_ylim(top=1.25 * max([ax.get_ylim()[1], 1e-9]))
    if len(shown) == total:
        title = "contour error per block (from its start to the next block's start)"
    else:
        title = f"contour error per block (the {len(shown)} worst of {total:,}, by max)"
    ax.set(title=title, xlabel="block (N-word or G-code line), in program order", ylabel="LSB")
    ax.legend(loc="upper right")
    _mm_axis(ax, result.job.machine.lsb_mm)


def _speed_panel(ax: Axes, result: RunResult, data: PlotData) -> None:
    """Axis and path speeds against the programmed feed (one step line)."""
    machine = result.job.machine
    clock = result.report["clock_hz"]
    blocks = result.report["blocks"]
    col = {name: k for k, name in enumerate(result.store.columns)}
    s = data.rows
    cycles = s[:, 0]
    period = cycles[1] - cycles[0] if len(s) > 1 else 1.0  # the sampling period (cycles)
    window = max(1, round(SPEED_WINDOW_S * clock / period))
    speeds = {axis: windowed_speed(cycles, s[:, col[f"{axis}_actual"]], clock, window)
              for axis in machine.axis_names}
    # speeds averaged over 20 ms windows: every few-th of them draws the same curves
    every = max(1, -(-len(s) // SERIES_POINTS))
    tx = speeds["x"][0][::every]
    for axis in machine.axis_names:
        ax.plot(tx, machine.mm_per_min(speeds[axis][1][::every]), lw=0.8, label=axis)
    path_speed = reduce(np.hypot, [v[::every] for _, v in speeds.values()])
    ax.plot(tx, machine.mm_per_min(path_speed), color="k", lw=1.0, label="path")
    items = result.job.program.items
    feeds = [run_feed(items[b["index"]], machine) for b in blocks]
    last = cycles[-1] if len(s) else 0
    ends = [b["end_cycle"] if b["end_cycle"] is not None else max(last, b["start_cycle"])
            for b in blocks]
    if blocks:
        ax.hlines(feeds, [b["start_cycle"] / clock for b in blocks],
                  np.array(ends) / clock, colors="0.4", linestyles=":", lw=1.5,
                  label="programmed feed")
    ax.set(title=f"speeds (position change over {window} samples = "
                 f"{window * period / clock * 1e3:g} ms)", xlabel="time (s)", ylabel="mm/min")
    ax.set_ylim(top=1.3 * max([ax.get_ylim()[1], *feeds]))
    ax.legend(fontsize=8, ncols=4, loc="upper center", bbox_to_anchor=(0.5, 0.93))


def figure(result: RunResult) -> Figure:
    """The plot of a run as a matplotlib figure (see the module's docstring)."""
    from matplotlib.figure import Figure

    axes = result.job.machine.axis_names
    clock = result.report["clock_hz"]
    lsb_mm = result.job.machine.lsb_mm
    blocks = result.report["blocks"]
    data = plot_data(result.job, [(b["index"], b["start_cycle"]) for b in blocks],
                     result.store)
    t = data.rows[:, 0] / clock
    fig = Figure(figsize=SIZE)
    fig.subplots_adjust(**MARGINS)
    grid = fig.subplots(3, 2)
    (path_ax, bars), (contour_ax, follow), (speed_ax, dac) = grid
    for ax in (follow, speed_ax, dac):
        ax.sharex(contour_ax)

    items = {item.index: item for item in result.job.program.items}
    names = [result.job.program.label(b["line"]) for b in blocks]
    codes = [block_code(items[b["index"]]) for b in blocks]
    shown, wanted = marked_blocks([peak for peak, _ in data.blocks], bars_that_fit(names))
    starts_xy = np.array([items[b["index"]].start[:2] for b in blocks], dtype=float)
    _path_panel(path_ax, result, data, starts_xy.reshape(-1, 2), wanted, names)
    _bars_panel(bars, result, data, shown, codes, names)

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
    follow.legend(loc="lower right")
    _mm_axis(follow, lsb_mm)

    _speed_panel(speed_ax, result, data)

    for axis in axes:
        _series(dac, t, data, f"{axis}_dac_volts", label=axis)
    dac.set(title="D/A output", xlabel="time (s)", ylabel="V")
    dac.legend(loc="lower right")

    starts = np.array([b["start_cycle"] / clock for b in blocks])
    lines = list(range(len(blocks))) if len(blocks) <= MAX_BOUNDARIES else shown
    labels = wanted if len(blocks) <= MAX_BOUNDARIES else wanted[:len(shown)]
    span = (float(t[0]), float(t[-1])) if len(t) > 1 else (0.0, 1.0)
    for ax in (contour_ax, follow, speed_ax, dac):
        _boundaries(ax, starts, lines, labels, names, span)
    if len(blocks) > MAX_BOUNDARIES:
        contour_ax.set_title(contour_ax.get_title()[:-1] + f"; dashed: {len(shown)} worst "
                             f"blocks' starts)")
    # the job's name is the user's text: never TeX ("$x$" would be parsed as math)
    fig.suptitle(f"k37 run {result.job.name}: {result.report['status']}: "
                 f"{result.report['reason']}", parse_math=False)
    return fig


def write_plot(result: RunResult, path: Path) -> None:
    """Write :func:`figure` to ``path`` (any format matplotlib writes, by its suffix)."""
    figure(result).savefig(path, dpi=100)
