"""Progress of a run against the program's planned length, and a printer for it.

Before the run, each item's planned machine time is known (:func:`planned_seconds`: a block's
FP count at its feed word's rate, a dwell's time), so a run's place in the program is the
planned time of the items done plus the part of the running one done (its FP received, or its
dwell time passed). The runner computes a :class:`Progress` at the sampler's ticks only: no cost
per cycle or per sample.
"""

from __future__ import annotations

import itertools
import sys
from dataclasses import dataclass
from typing import TextIO

from k37.firmware_model.feeds import planned_seconds
from k37.firmware_model.job import Job
from k37.firmware_model.motion.program import Dwell, Item

__all__ = ["ProgramPlan", "Progress", "ProgressPrinter"]


@dataclass(frozen=True)
class Progress:
    """Where a run stands."""

    #: System clock cycles simulated.
    cycle: int
    #: The part of the program's planned machine time done, 0 to 1.
    fraction: float
    #: G-code line of the item running (None before the first).
    line: int | None
    #: Wall-clock seconds since the run began.
    wall: float
    clock_hz: float

    @property
    def eta(self) -> float | None:
        """Wall-clock seconds left, at the pace so far (None before any progress)."""
        if self.fraction <= 0:
            return None
        return self.wall * (1 - self.fraction) / self.fraction

    def text(self) -> str:
        """One line: percent of the program, line, machine time, ETA."""
        line = "" if self.line is None else f", line {self.line}"
        eta = "" if self.eta is None else f", ETA {_duration(self.eta)}"
        return (f"k37 run: {100 * self.fraction:5.1f}% of the program{line}, "
                f"{self.cycle / self.clock_hz:.3f} s machine time{eta}")


def _duration(seconds: float) -> str:
    minutes, secs = divmod(round(seconds), 60)
    return f"{minutes} min {secs:02d} s" if minutes else f"{secs} s"


class ProgramPlan:
    """The planned machine time of each item of a job's program."""

    def __init__(self, job: Job):
        self.clock_hz = job.machine.clock_hz
        rates: dict = {}
        seconds = [planned_seconds(item, job.machine, rates) for item in job.program.items]
        self.seconds = seconds
        #: Planned seconds of the items before each one.
        self.before = [0.0, *itertools.accumulate(seconds)]
        self.total = self.before[-1]

    def progress(self, item: Item | None, done: float, cycle: int, wall: float) -> Progress:
        """The progress with ``item`` running, ``done`` (0 to 1) of it behind."""
        if item is None:
            return Progress(cycle, 0.0, None, wall, self.clock_hz)
        part = self.seconds[item.index] * min(1.0, max(0.0, done))
        fraction = (self.before[item.index] + part) / self.total if self.total else 1.0
        return Progress(cycle, fraction, item.line_no, wall, self.clock_hz)

    def dwell_done(self, item: Dwell, cycles: int) -> float:
        """The part of dwell ``item`` done after ``cycles`` cycles of it."""
        planned = item.seconds * self.clock_hz
        return cycles / planned if planned else 1.0


class ProgressPrinter:
    """Shows :class:`Progress` on ``stream``: on a terminal one line refreshed in place (every
    0.5 s at most), else a plain line every ``interval`` seconds (default 5)."""

    def __init__(self, stream: TextIO = sys.stderr, *, interval: float | None = None):
        self.stream = stream
        self.tty = stream.isatty()
        self.interval = interval if interval is not None else 0.5 if self.tty else 5.0
        self._shown_at: float | None = None

    def __call__(self, progress: Progress) -> None:
        if progress.wall < (self._shown_at or 0.0) + self.interval:
            return
        self._shown_at = progress.wall
        if self.tty:
            print(f"\r{progress.text()}\x1b[K", end="", file=self.stream, flush=True)
        else:
            print(progress.text(), file=self.stream, flush=True)

    def finish(self) -> None:
        """End the refreshed line, if one was shown."""
        if self.tty and self._shown_at is not None:
            print(file=self.stream, flush=True)
