"""The contour error: distance of each sampled actual position to the programmed path (in the
plane on two axes, in space on three), measured by the path geometry the host's contour
controllers use (:mod:`k37.firmware_model.contour.path`), along the tool's own progress."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from k37.firmware_model.contour.path import Path
from k37.firmware_model.contour.tracker import Tracker
from k37.firmware_model.job import Job
from k37.sim.run.sampler import CHUNK_ROWS, SampleStore

__all__ = ["BlockStart", "ContourMeter", "contour_errors", "contour_summary"]

#: A block that ran: its index in the program (dwells counted) and the cycle it started.
BlockStart = tuple[int, int]


class ContourMeter:
    """The contour errors of one run's samples, given in order in as many chunks as wanted.

    ``blocks`` are the blocks that ran, in order (the firmware's records, or the report's).
    Each sample is measured against the stretch of path the tool is on
    (:class:`k37.firmware_model.contour.tracker.Tracker`), never past the block after the one
    running at its cycle; a sample before the first block, against the start point.
    """

    def __init__(self, job: Job, blocks: Sequence[BlockStart]):
        moves = job.program.moves
        self.axes = job.machine.axes
        self.start = np.array(moves[0].start, dtype=float) if moves else None
        self.tracker = Tracker(Path(moves, self.axes)) if moves and blocks else None
        move_of = {it.index: k for k, it in enumerate(moves)}
        self.block_move = np.array([move_of[index] for index, _ in blocks], dtype=int)
        self.block_start = np.array([start for _, start in blocks])

    def errors(self, samples: np.ndarray) -> np.ndarray:
        """Distance of each sample's actual position to the programmed path (LSB); none when
        the program has no move or no block ran."""
        if not len(samples) or self.tracker is None:
            return np.zeros(0)
        n = self.axes
        pts = np.asarray(samples[:, 1 + n:1 + 2 * n], dtype=float)  # the actual positions
        running = np.searchsorted(self.block_start, samples[:, 0], side="right") - 1
        first = int(np.searchsorted(running, 0))  # the samples before the first block: in order
        errors = np.empty(len(pts))
        errors[:first] = np.sqrt(((pts[:first] - self.start) ** 2).sum(axis=1))
        limit = np.minimum(self.block_move[running[first:]] + 1, len(self.tracker.path.moves) - 1)
        errors[first:] = self.tracker.track(pts[first:], limit).distance
        return errors


def contour_errors(job: Job, blocks: Sequence[BlockStart], samples: np.ndarray) -> np.ndarray:
    """Distance of each of a run's samples' actual position to the programmed path (LSB):
    :meth:`ContourMeter.errors` of all of them at once."""
    return ContourMeter(job, blocks).errors(samples)


def contour_summary(job: Job, blocks: Sequence[BlockStart], store: SampleStore,
                    leaf: int = CHUNK_ROWS) -> tuple[float, float]:
    """The largest and the root-mean-square contour error of the samples in ``store`` (LSB),
    reading at most ``leaf`` samples at a time, in order.

    The sum of squares is split as numpy's pairwise summation splits one array (halves rounded
    down to a multiple of 8) down to ranges of at most ``leaf`` samples, each summed by numpy:
    the mean is the one ``np.mean`` gives for the whole run's errors at once, bit for bit.
    """
    peak = 0.0
    meter = ContourMeter(job, blocks)

    def total(start: int, stop: int) -> float:
        nonlocal peak
        if stop - start <= leaf:
            errors = meter.errors(store.raw(start, stop))  # the cycles and positions
            if not errors.size:  # no block ran: no contour
                return 0.0
            peak = max(peak, float(errors.max()))
            return np.add.reduce(errors**2)
        half = (stop - start) // 2
        half -= half % 8
        return total(start, start + half) + total(start + half, stop)

    if not store.rows:
        return 0.0, 0.0
    square_sum = total(0, store.rows)
    return peak, float(math.sqrt(square_sum / store.rows))
