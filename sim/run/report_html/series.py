"""The time series of the ``--html`` report at several resolutions, extremes kept.

A run's samples are read once into :data:`FINEST` buckets at most (:func:`k37.sim.run.
plot_data.plot_data`: each bucket's least and largest value, the contour error included).
Level 0 is those buckets; each next level merges :data:`MERGE` buckets of the one before
(least of the least, largest of the largest) until a level has at most :data:`COARSEST`
buckets. The page draws, for the visible time range, the finest level with at most 3,000
buckets in it (a few per pixel of the plot's width), as a line through each bucket's least
and largest value: no peak is lost at any zoom, and zooming in reaches level 0 (single
samples while a run has at most :data:`FINEST` samples).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from k37.firmware_model.job import MachineConfig
from k37.sim.run.plot import SPEED_WINDOW_S, windowed_speed
from k37.sim.run.plot_data import PlotData

__all__ = ["COARSEST", "FINEST", "MERGE", "Levels", "levels"]

#: The most buckets of level 0 (a 5-million-sample run: 77 samples a bucket).
FINEST = 1 << 16
#: Buckets of one level merged into one of the next.
MERGE = 4
#: The most buckets of the coarsest level.
COARSEST = 4096


@dataclass(frozen=True)
class Levels:
    """The series of a run, by name, at every level: ``low[name][k]`` and ``high[name][k]``
    are level ``k``'s least and largest values per bucket; ``time`` the start of each bucket
    of level 0 (s; level ``k``'s bucket ``j`` starts at ``time[j * MERGE**k]``);
    ``samples_per_bucket`` at level 0."""

    time: np.ndarray
    low: dict[str, list[np.ndarray]]
    high: dict[str, list[np.ndarray]]
    samples_per_bucket: int


def _pyramid(low: np.ndarray, high: np.ndarray) -> tuple[list[np.ndarray], list[np.ndarray]]:
    lows, highs = [low], [high]
    while len(lows[-1]) > COARSEST:
        firsts = np.arange(0, len(lows[-1]), MERGE)
        lows.append(np.minimum.reduceat(lows[-1], firsts))
        highs.append(np.maximum.reduceat(highs[-1], firsts))
    return lows, highs


def speeds(data: PlotData, machine: MachineConfig, clock_hz: float) -> dict[str, np.ndarray]:
    """Each axis's and the path's speed (mm/min) at each bucket's first sample: the position
    change over :data:`k37.sim.run.plot.SPEED_WINDOW_S` (at least one bucket), as the
    ``--plot`` figure measures it."""
    rows = data.rows
    cycles = rows[:, 0]
    if len(rows) < 2:
        return {f"{name}_speed": np.zeros(len(rows)) for name in (*machine.axis_names, "path")}
    period = cycles[1] - cycles[0]
    window = max(1, round(SPEED_WINDOW_S * clock_hz / period))
    out, squares = {}, np.zeros(len(rows))
    for axis in machine.axis_names:
        at, v = windowed_speed(cycles, rows[:, data.columns.index(f"{axis}_actual")], clock_hz,
                               window)
        speed = np.interp(cycles / clock_hz, at, v)
        out[f"{axis}_speed"] = machine.mm_per_min(speed)
        squares += speed**2
    out["path_speed"] = machine.mm_per_min(np.sqrt(squares))
    return out


def levels(data: PlotData, machine: MachineConfig, clock_hz: float,
           columns: Sequence[str]) -> Levels:
    """The :class:`Levels` of ``columns`` (of ``data``'s, and the speeds of :func:`speeds`)."""
    extra = speeds(data, machine, clock_hz)
    low: dict[str, list[np.ndarray]] = {}
    high: dict[str, list[np.ndarray]] = {}
    for name in columns:
        if name in extra:
            lo = hi = extra[name]
        else:
            lo, hi = data.envelope(name)
        low[name], high[name] = _pyramid(lo, hi)
    return Levels(data.rows[:, 0] / clock_hz if len(data.rows) else np.zeros(0), low, high,
                  data.bucket)
