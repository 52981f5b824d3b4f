"""The contour error: distance of each sampled actual position to the programmed path (in the
plane on two axes, in space on three: a helix's normal axis is expected to rise in proportion
to the angle swept)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import reduce

import numpy as np

from k37.firmware_model.job import Job
from k37.firmware_model.motion.program import Arc, Line
from k37.sim.run.sampler import CHUNK_ROWS, SampleStore

__all__ = ["BlockStart", "contour_errors", "contour_summary"]

#: A block that ran: its index in the program (dwells counted) and the cycle it started.
BlockStart = tuple[int, int]


def _norm(v: np.ndarray) -> np.ndarray:
    """The length of each row of ``v`` (hypot over its columns)."""
    return reduce(np.hypot, v.T)


def _segment_distance(p: np.ndarray, a: tuple[int, ...], b: tuple[int, ...]) -> np.ndarray:
    d = np.array(b, dtype=float) - np.array(a, dtype=float)
    rel = p - np.array(a, dtype=float)
    length2 = float(d @ d)
    t = np.zeros(len(p)) if length2 == 0 else np.clip(rel @ d / length2, 0.0, 1.0)
    return _norm(rel - np.outer(t, d))


def _arc_distance(p: np.ndarray, item: Arc) -> np.ndarray:
    first, second, normal = item.plane_axes
    rel = p[:, [first, second]] - np.array(item.center, dtype=float)
    a0, sweep = item.span
    ang = np.arctan2(rel[:, 1], rel[:, 0])
    off = (ang - a0) % (2 * math.pi) if not item.cw else (a0 - ang) % (2 * math.pi)
    on_arc = np.abs(np.hypot(rel[:, 0], rel[:, 1]) - item.radius)
    if normal < p.shape[1]:  # three axes: the normal axis against the helix at that angle
        rise = (item.end[normal] - item.start[normal]) * np.minimum(off, sweep) / sweep
        on_arc = np.hypot(on_arc, p[:, normal] - (item.start[normal] + rise))
    ends = np.minimum(_norm(p - np.array(item.start, dtype=float)),
                      _norm(p - np.array(item.end, dtype=float)))
    return np.where(off <= sweep, on_arc, ends)


def _distance(item: Line | Arc, p: np.ndarray) -> np.ndarray:
    """Distance of each point of ``p`` to the move ``item`` (a line, an arc or a curve)."""
    if isinstance(item, Line):
        if item.curve is not None:  # a spline's chord: the exact curve
            return item.curve.distances(p)
        return _segment_distance(p, item.start, item.end)
    if isinstance(item, Arc):
        return _arc_distance(p, item)
    return item.distances(p)


def contour_errors(job: Job, blocks: Sequence[BlockStart], samples: np.ndarray) -> np.ndarray:
    """Distance of each sample's actual position to the programmed path (LSB).

    ``blocks`` are the blocks that ran, in order (the firmware's records, or the report's).
    A sample is compared with the block running at its cycle and its neighbours (a lagging
    axis is still on the block before).
    """
    moves = list(job.program.moves)
    if not len(samples) or not moves or not blocks:
        return np.zeros(0)
    n = job.machine.axes
    cycles, pts = samples[:, 0], samples[:, 1 + n:1 + 2 * n]  # the actual positions
    move_of = {it.index: k for k, it in enumerate(moves)}
    block_move = np.array([move_of[index] for index, _ in blocks])
    running = np.searchsorted([start for _, start in blocks], cycles, side="right") - 1
    # Each sample against the move of the block running at its cycle and of its neighbours,
    # as (sample, move) pairs grouped by move (one stable sort: linear in the samples and
    # the moves, where a mask per move would be their product).
    samples_of, move = [], []
    for shift in (-1, 0, 1):
        idx = running + shift
        valid = np.flatnonzero((idx >= 0) & (idx < len(block_move)))
        samples_of.append(valid)
        move.append(block_move[idx[valid]])
    samples_of, move = np.concatenate(samples_of), np.concatenate(move)
    order = np.argsort(move, kind="stable")
    samples_of, move = samples_of[order], move[order]
    best = np.full(len(pts), np.inf)
    for group in np.split(np.arange(len(move)), np.flatnonzero(np.diff(move)) + 1):
        if len(group):
            near = samples_of[group]
            best[near] = np.minimum(best[near], _distance(moves[move[group[0]]], pts[near]))
    # Samples before the first block: distance to the start point.
    before = ~np.isfinite(best)
    best[before] = _norm(pts[before] - np.array(moves[0].start, dtype=float))
    return best


def contour_summary(job: Job, blocks: Sequence[BlockStart], store: SampleStore,
                    leaf: int = CHUNK_ROWS) -> tuple[float, float]:
    """The largest and the root-mean-square contour error of the samples in ``store`` (LSB),
    reading at most ``leaf`` samples at a time.

    The sum of squares is split as numpy's pairwise summation splits one array (halves rounded
    down to a multiple of 8) down to ranges of at most ``leaf`` samples, each summed by numpy:
    the mean is the one ``np.mean`` gives for the whole run's errors at once, bit for bit.
    """
    peak = 0.0

    def total(start: int, stop: int) -> float:
        nonlocal peak
        if stop - start <= leaf:
            errors = contour_errors(job, blocks, store.read(start, stop))
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
