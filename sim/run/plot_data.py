"""What the ``--plot`` figure draws, read from a run's sample store chunk by chunk, so that a
plot's memory is bounded by :data:`PLOT_BUCKETS`, not by the run's length.

The samples are cut into at most :data:`PLOT_BUCKETS` buckets of consecutive samples. Each
bucket keeps its first sample (for the path and the speeds) and the least and the largest
value of every column and of the contour error in it (an envelope: no peak is lost, however
long the run). With :data:`PLOT_BUCKETS` samples or fewer a bucket is one sample and the
envelope is the samples themselves. The contour error per block (largest, RMS) is summed over
every sample, exactly.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from k37.firmware_model.job import Job
from k37.sim.run.contour import BlockStart, ContourMeter
from k37.sim.run.sampler import CHUNK_ROWS, SampleStore

__all__ = ["PLOT_BUCKETS", "BlockContour", "PlotData", "plot_data"]

#: The most buckets a plot draws per series.
PLOT_BUCKETS = 100_000


class BlockContour:
    """Largest and RMS contour error of each block (LSB) over its samples, from its start to
    the next block's start (its dwell and settle included), summed chunk by chunk."""

    def __init__(self, starts: Sequence[int]):
        self.starts = np.asarray(starts)
        self.peak = np.zeros(len(starts))
        self.squares = np.zeros(len(starts))
        self.count = np.zeros(len(starts), dtype=np.int64)

    def add(self, cycles: np.ndarray, errors: np.ndarray) -> None:
        """The samples at ``cycles`` with contour errors ``errors``."""
        owner = np.searchsorted(self.starts, cycles, side="right") - 1
        mine = owner >= 0
        owner, errors = owner[mine], errors[mine]
        np.maximum.at(self.peak, owner, errors)
        np.add.at(self.squares, owner, errors**2)
        self.count += np.bincount(owner, minlength=len(self.starts))

    def stats(self) -> list[tuple[float, float]]:
        """(largest, RMS) of each block; (0, 0) for a block without samples."""
        return [(float(p), float(np.sqrt(s / n))) if n else (0.0, 0.0)
                for p, s, n in zip(self.peak, self.squares, self.count, strict=True)]


@dataclass(frozen=True)
class PlotData:
    """A run's samples as a plot draws them.

    ``bucket``: samples per bucket (1: every sample); ``rows``: the first sample of each
    bucket (the store's columns); ``low``, ``high``: each bucket's least and largest value of
    ``columns`` (the store's, then ``contour_error``); ``blocks``: (largest, RMS) contour error
    of each block; ``samples``: the samples read.
    """

    columns: tuple[str, ...]
    bucket: int
    rows: np.ndarray
    low: np.ndarray
    high: np.ndarray
    blocks: list[tuple[float, float]]
    samples: int

    def envelope(self, column: str) -> tuple[np.ndarray, np.ndarray]:
        """The least and largest value of ``column`` per bucket."""
        k = self.columns.index(column)
        return self.low[:, k], self.high[:, k]

    def coarse(self, column: str, most: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        """:meth:`envelope` of ``column`` merged, whole buckets at a time, into at most ``most``
        (a panel needs a few per pixel, not a hundred): the index in ``rows`` of each merged
        bucket's first bucket, its least and its largest value, and the samples it holds."""
        low, high = self.envelope(column)
        merge = max(1, -(-len(low) // max(1, most)))
        if merge == 1:
            return np.arange(len(low)), low, high, self.bucket
        firsts = np.arange(0, len(low), merge)
        return (firsts, np.minimum.reduceat(low, firsts), np.maximum.reduceat(high, firsts),
                self.bucket * merge)


def plot_data(job: Job, blocks: Sequence[BlockStart], store: SampleStore,
              buckets: int | None = None) -> PlotData:
    """Read ``store`` once, in chunks of whole buckets, into a :class:`PlotData` of at most
    ``buckets`` buckets (default :data:`PLOT_BUCKETS`)."""
    bucket = max(1, -(-store.rows // (buckets or PLOT_BUCKETS)))
    step = bucket * max(1, CHUNK_ROWS // bucket)
    per_block = BlockContour([start for _, start in blocks])
    meter = ContourMeter(job, blocks)
    rows, low, high = [], [], []
    for start in range(0, store.rows, step):
        chunk = store.read(start, start + step)
        errors = meter.errors(chunk)
        if not errors.size:
            errors = np.zeros(len(chunk))
        per_block.add(chunk[:, 0], errors)
        values = np.column_stack([chunk, errors])
        firsts = np.arange(0, len(chunk), bucket)
        rows.append(chunk[firsts])
        low.append(np.minimum.reduceat(values, firsts))
        high.append(np.maximum.reduceat(values, firsts))
    columns = (*store.columns, "contour_error")
    width = len(columns)
    return PlotData(columns, bucket, np.vstack(rows) if rows else np.zeros((0, width - 1)),
                    np.vstack(low) if low else np.zeros((0, width)),
                    np.vstack(high) if high else np.zeros((0, width)),
                    per_block.stats(), store.rows)
