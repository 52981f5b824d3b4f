"""A :class:`Tracker` follows the tool along a :class:`k37.firmware_model.contour.path.Path`,
sample after sample: each sample's nearest
point is searched from the segment the previous sample was matched on (the tool's progress
is monotone, so an earlier pass of the path is never a candidate) forward over the path that
lies within the previous sample's contour error, twice the tool's travel since then and
:data:`REACH` of the sample's nearest point of that segment (so a full circle's end, where it
started, is not reached from its start); where the sample moved back along that segment (its
move against the segment's direction, cosine below -:data:`BACK`: a next segment that turns
back along it), at least as far past the segment's end as the sample is from that end; the
segments after it only that far along them; and never past the block after the one the
interpolator runs at its cycle (the tool is not ahead of the interpolator). Of equal
distances the furthest segment wins (a retraced stretch hands over to its next segment).
"""

from __future__ import annotations

import numpy as np

from k37.firmware_model.contour.path import LINE, REACH, TIE, Foot, Path
from k37.firmware_model.contour.rowwise import dist2, sum_axes

__all__ = ["BACK", "Tracker"]


#: A row moves back along its segment where its move's cosine to the segment's direction is
#: below minus this.
BACK = 0.5
#: Margin (LSB) on the bound that rules a segment out of a row's window without searching it.
SLACK = 1e-3
#: Rounds of a chunk's fixed-point iteration before its settled rows are taken.
ROUNDS = 4
#: The largest chunk of samples a tracker takes at once.
CHUNK = 8192
#: Rows apart of the samples whose segments are guessed before the rest's.
STRIDE = 64


class Tracker:
    """The tool's progress along ``path``: :meth:`track` takes the samples in order, in as
    many calls as wanted (the matched segment carries over).

    Each sample's window depends on the previous sample's segment and distance only, so a
    chunk of samples is solved at once by a fixed-point iteration: a guessed segment per row
    (from the tool's own segment for every row, or, after a chunk that guess settled half of
    or less, from the interpolator's block as many samples before as the tool last entered a
    segment after the interpolator entered its block, and back; on to the next segment as
    long as the row's nearest point of it is its end), every row's window from the guess for
    the row before it, then each row's segment and distance handed on as the next row's, only the
    rows whose inputs changed computed again; the rows up to the first whose inputs still
    changed are the ones the sample-by-sample rule gives, bit for bit (the first row's inputs
    are the tracker's own), and the next chunk starts after them."""

    def __init__(self, path: Path):
        self.path = path
        self.segment = 0
        #: The last sample's position and its distance to the path (none yet).
        self.last: np.ndarray | None = None
        self.error = 0.0
        #: Samples from the interpolator entering a block to the tool entering its segment.
        self.delay = 0

    def track(self, p: np.ndarray, limit: np.ndarray) -> Foot:
        """The nearest points of positions ``p`` (rows, in sample order), each searched in
        its window from the previous sample's segment, never past ``limit`` (per row: the
        last segment the tool may be on)."""
        p = np.asarray(p, dtype=float)
        n = len(p)
        out = Foot(np.empty(n, dtype=int), np.empty(n), np.empty_like(p), np.empty(n))
        if not n:
            return out
        step = np.empty_like(p)  # the move from the row before (the first: from the last sample)
        step[0] = p[0] - (p[0] if self.last is None else self.last)
        step[1:] = p[1:] - p[:-1]
        twice = 2 * np.sqrt(sum_axes(step * step))  # twice the length of each row's move
        limit = np.asarray(limit)
        i, size, delayed = 0, 64, False
        while i < n:
            rows = slice(i, min(n, i + size))
            if delayed:
                guess = limit[np.clip(np.arange(rows.start, rows.stop) - self.delay, 0, n - 1)] - 1
            else:
                guess = np.full(rows.stop - rows.start, self.segment)
            found, done = self._chunk(p[rows], step[rows], twice[rows], limit[rows], guess)
            if 2 * done <= rows.stop - rows.start:  # a poor guess: try the other one next
                delayed = not delayed
            part = slice(i, i + done)
            out.segment[part], out.param[part] = found.segment[:done], found.param[:done]
            out.point[part], out.distance[part] = found.point[:done], found.distance[:done]
            if found.segment[done - 1] != self.segment:  # when the tool entered its segment
                r = int(np.searchsorted(found.segment[:done], found.segment[done - 1]))
                self.delay = i + r - int(np.searchsorted(limit, found.segment[r] + 1))
            self.segment = int(found.segment[done - 1])
            self.last, self.error = p[i + done - 1].copy(), float(found.distance[done - 1])
            size = min(CHUNK, 2 * size) if done == rows.stop - i else max(64, 2 * done)
            i += done
        return out

    def _chunk(self, p: np.ndarray, step: np.ndarray, twice: np.ndarray, limit: np.ndarray,
               guess: np.ndarray) -> tuple[Foot, int]:
        """The nearest points of a chunk of rows, from a ``guess`` of each row's previous
        segment, and how many of them are settled (at least one)."""
        c, n = self.segment, len(p)
        ones = np.ones(n)
        here = self._advance(p, limit, np.maximum(guess, c), ones)
        # Each row handed the segment guessed for the row before it.
        guess = np.concatenate([[c], here.segment[:-1]])
        rows = np.flatnonzero(guess != here.segment)
        if len(rows):
            _put(here, rows, self._here(guess[rows], p[rows], ones[rows]))
        error = np.concatenate([[self.error], here.distance[:-1]])
        found = self._window(p, step, twice, limit, here, error)
        if n == 1:  # the first row's inputs are the tracker's own
            return found, 1
        everything, rounds = np.arange(n), 0
        while True:
            segment = np.concatenate([[c], found.segment[:-1]])
            handed = np.concatenate([[self.error], found.distance[:-1]])
            moved = segment != here.segment
            changed = moved | (handed != error)
            if not changed.any():
                return found, n
            if rounds == ROUNDS:
                return found, int(np.argmax(changed))
            rounds += 1
            error = handed
            if moved.any():
                rows = np.flatnonzero(moved)
                _put(here, rows, self._here(segment[rows], p[rows], ones[rows]))
                # A row computed again after one that moved: handed the distance on its new
                # segment (each row's error stays the one its window is computed with).
                after = rows[rows < n - 1] + 1
                after = after[changed[after]]
                error[after] = here.distance[after - 1]
            rows = everything[changed]
            _put(found, rows, self._window(p[rows], step[rows], twice[rows], limit[rows],
                                           _take(here, rows), error[rows]))

    def _advance(self, p: np.ndarray, limit: np.ndarray, guess: np.ndarray, ones: np.ndarray
                 ) -> Foot:
        """Each row's nearest point on its guessed segment: from ``guess`` (never before the
        previous row's), the first whose end is not the row's nearest point of it, never past
        ``limit``."""
        if len(p) > 4 * STRIDE:  # every STRIDE-th row's first: the rows after it are as far
            coarse = self._advance(p[::STRIDE], limit[::STRIDE], guess[::STRIDE],
                                   ones[::STRIDE]).segment
            guess = np.maximum(guess, np.repeat(coarse, STRIDE)[:len(p)])
        here = self._here(np.maximum.accumulate(guess), p, ones)
        while True:
            past = (here.param == 1.0) & (here.segment < limit)
            if not past.any():
                return here
            segment = np.maximum.accumulate(here.segment + past)
            rows = np.flatnonzero(segment != here.segment)
            _put(here, rows, self._here(segment[rows], p[rows], ones[rows]))

    def _here(self, segment: np.ndarray, p: np.ndarray, ones: np.ndarray) -> Foot:
        u, q = self.path.feet(segment, p, ones)
        return Foot(segment, u, q, np.sqrt(dist2(q, p)))

    def _window(self, p: np.ndarray, step: np.ndarray, twice: np.ndarray, limit: np.ndarray,
                here: Foot, error: np.ndarray) -> Foot:
        """The nearest point of each row ``p`` in its window: from its segment (``here``,
        its nearest point there) forward as far as ``error`` (the previous row's distance),
        ``twice`` its travel (the length of ``step``, its move since the previous row) and
        :data:`REACH` past that nearest point; where the row moved back along its segment
        (a next segment that turns back along it), at least as far past the segment's end
        as the row is from that end; never past ``limit``."""
        path = self.path
        c = here.segment
        table = path.table
        reach = path.ends[c] - (1 - here.param) * path.lengths[c] + error + twice + REACH
        direction = path.directions(c, here.param)
        # (Halving twice the travel is exact: -BACK / 2 times it is -BACK times the travel.)
        norm = table.norm[c]  # a line's; the rest's computed
        if table.only != LINE:
            turning = np.flatnonzero(table.kind[c] != LINE)
            norm[turning] = np.sqrt(sum_axes(direction[turning] * direction[turning]))
        back = sum_axes(step * direction) < -BACK / 2 * twice * norm
        if back.any():
            gone = np.sqrt(dist2(p[back] - path.table.start[c[back]], path.table.d[c[back]]))
            reach[back] = np.maximum(reach[back], path.ends[c[back]] + gone + twice[back] + REACH)
        last = np.minimum(np.searchsorted(path.ends, reach), len(path.ends) - 1)
        last = np.maximum(np.minimum(last, limit), c)
        best = Foot(c.copy(), here.param.copy(), here.point.copy(), here.distance.copy())
        for onward in range(1, int((last - c).max(initial=0)) + 1):
            rows = np.flatnonzero(c + onward <= last)
            if len(rows) == len(p):  # every row (the first segment on, mostly): no copies
                k, ahead, farthest = c + onward, p, reach
            else:
                k, ahead, farthest = c[rows] + onward, p[rows], reach[rows]
            length = path.lengths[k]
            # The segments after the first only as far along them as the reach.
            top = farthest - path.ends[k - 1]
            top /= path.divisors[k]
            np.clip(top, 0.0, 1.0, out=top)
            top[length == 0] = 1.0
            # A line's, an arc's or a helix's points that far along it are no farther from its
            # start than that: the rows it cannot come close enough for are not searched on it.
            gap = np.sqrt(dist2(ahead, table.start[k])) - top * length
            held = best.distance[rows]
            near = gap <= held + TIE + SLACK
            if table.curves:
                near |= table.curve[k]
            rows, k, top, ahead, held = rows[near], k[near], top[near], ahead[near], held[near]
            u, q = path.feet(k, ahead, top)
            d = np.sqrt(dist2(q, ahead))
            take = d <= held + TIE
            _put(best, rows[take], Foot(k[take], u[take], q[take], d[take]))
        return best


def _take(foot: Foot, rows: np.ndarray) -> Foot:
    return Foot(foot.segment[rows], foot.param[rows], foot.point[rows], foot.distance[rows])


def _put(foot: Foot, rows: np.ndarray, part: Foot) -> None:
    foot.segment[rows], foot.param[rows] = part.segment, part.param
    foot.point[rows], foot.distance[rows] = part.point, part.distance
