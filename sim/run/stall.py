"""A run that stops making progress: while a block runs, no feed pulse and no axis motion
for the block's stall time (:func:`stall_seconds`) ends the run with status ``stalled``,
naming the block and its line."""

from __future__ import annotations

import math

from k37.firmware_model.feeds import feed_word, run_feed, word_rate
from k37.firmware_model.firmware import Firmware
from k37.firmware_model.job import Job
from k37.firmware_model.motion.program import Move
from k37.sim.run.sampler import Sampler

__all__ = ["STALL_SECONDS", "RunStopped", "StallWatch", "stall_seconds"]


class RunStopped(Exception):  # noqa: N818 (not an error: a run ended early)
    """Raised at a sampler's tick to end the run there: its status and why."""

    def __init__(self, status: str, reason: str):
        super().__init__(reason)
        self.status = status
        self.reason = reason



#: A block stalls when, while it runs, no feed pulse enters the K3701 and no axis's encoder
#: count changes for this long, plus what its own feed and accel/decel circuits may leave
#: between two pulses (:func:`stall_seconds`).
STALL_SECONDS = 2.0


def _longest_tau(job: Job) -> float:
    """The longest accel/decel time constant of the job's circuits (s)."""
    machine = job.machine
    return max([machine.tau_s, *(2**bits / job.fa_hz(axis)
                                 for axis, (_, bits) in job.accel_circuits().items())])


def stall_seconds(job: Job, item: Move) -> float:
    """How long block ``item`` of ``job`` may go without a feed pulse or any axis motion
    before the run ends as stalled: :data:`STALL_SECONDS`, plus twice the gap between two
    feed pulses at the block's feed word, plus four of the longest accel/decel time
    constant (an exponential circuit's tail lets its last pulses out about a time constant
    apart)."""
    rate = word_rate(job.machine, feed_word(job.machine, run_feed(item, job.machine)))
    return STALL_SECONDS + 2 / rate + 4 * _longest_tau(job)


class StallWatch:
    """Watches, at the sampler's ticks, that a running block makes progress: a feed pulse
    (the FP total) or an axis's motion (its encoder count) within :func:`stall_seconds`. A
    change is seen at the first tick after it, so a stall is reported between its window and
    its window plus a tick after the last progress."""

    def __init__(self, sampler: Sampler, firmware: Firmware):
        self.sampler = sampler
        self.firmware = firmware
        self._ports = ("fp_total", *(f"{a}__count" for a in firmware.job.machine.axis_names))
        self._seen: tuple[int, ...] = ()
        self._since = 0  # the cycle the last change was seen at
        self._windows: dict[int, int] = {}  # block index -> its stall window (cycles)

    def check(self, cycle: int) -> None:
        """Raise :class:`RunStopped` (``stalled``) if the running block has made no
        progress for its window."""
        now = tuple(self.sampler.get(name) for name in self._ports)
        if now != self._seen:
            self._seen, self._since = now, cycle
            return
        firmware = self.firmware
        item = firmware.item
        if (not isinstance(item, Move) or firmware.stopped or not firmware.blocks
                or firmware.blocks[-1].index != item.index
                or firmware.blocks[-1].end_cycle is not None):
            self._since = cycle  # no block runs: a dwell, an event, the settling, between
            return
        job = firmware.job
        window = self._windows.get(item.index)
        if window is None:
            window = self._windows[item.index] = math.ceil(
                stall_seconds(job, item) * job.machine.clock_hz)
        idle = cycle - max(self._since, firmware.blocks[-1].start_cycle)
        if idle >= window:
            clock = job.machine.clock_hz
            raise RunStopped("stalled", (
                f"stalled in block {item.index} ({job.program.locate(item.line_no)}): no "
                f"feed pulse and no axis motion from cycle {cycle - idle:,} (or before) to "
                f"{cycle:,}, {idle / clock:.3f} s, beyond the block's stall time of "
                f"{window / clock:.3f} s"))
