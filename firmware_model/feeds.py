"""What the host works out from a program before it runs it: feed words, rates and times,
and the checks that refuse what the hardware cannot run.

A feed (mm/min) becomes FP/s (:meth:`k37.firmware_model.job.MachineConfig.lsb_per_s`) and then the
rate multiplier's word at the input clock the firmware sets (:func:`feed_word`); a word gives
back its feed with :func:`word_feed`. A feed above the K3701's maximum runs at it
(:func:`run_feed`), as a controller clamps it; :func:`clamped_feeds` names the lines.

:func:`check_program` refuses a feed below the rate multiplier's resolution (or, with
``run.strict_feed``, above the interpolator's step rate), an FP budget beyond 24 bits, a dwell
longer than the clock can count. :func:`program_time` is the program's planned machine time,
an upper estimate that the run's default limit follows.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from k37.firmware_model.job import Job, MachineConfig
from k37.firmware_model.motion.program import Dwell, Event, Item, Line, Move, Program
from k37.hdl.feed.map.feed_rate import FEED_BITS
from k37.hdl.feed.rates import BUDGET_WIDTH
from k37.hdl.k3701.block import LATENCY_CIRCULAR, LATENCY_LINEAR, Kind

__all__ = ["BLOCK_HOST_SECONDS", "CYCLE_COUNTER_BITS", "RM_CLOCK_DIVISOR", "SETTLE_SECONDS",
           "FirmwareError", "ProgramTime", "accel_lag_seconds", "block_rate", "check_program",
           "clamped_feeds", "feed_limit", "feed_word", "max_feed_mm_min", "planned_seconds",
           "program_seconds", "program_time", "programmed_feed", "rm_clock_hz", "run_feed",
           "word_feed", "word_rate"]

#: How long the firmware waits for the axes to come into position after the last block.
SETTLE_SECONDS = 5.0

#: Rate-multiplier input clock: one input clock per linear step time, so the FP stream into
#: the K3701 never has two pulses closer than the linear step latency.
RM_CLOCK_DIVISOR = LATENCY_LINEAR
#: The simulation counts system cycles in 64 bits: no dwell may be longer.
CYCLE_COUNTER_BITS = 64


class FirmwareError(ValueError):
    """A program the hardware cannot run; one line naming the block and the problem."""


def rm_clock_hz(machine: MachineConfig) -> float:
    """The rate multiplier's input clock."""
    return machine.clock_hz / RM_CLOCK_DIVISOR


def max_feed_mm_min(machine: MachineConfig, kind: Kind) -> float:
    """The highest feed the K3701 follows: one FP per step latency (``docs/chips/k3701.md``)."""
    latency = LATENCY_LINEAR if kind is Kind.LINEAR else LATENCY_CIRCULAR
    return machine.mm_per_min(machine.clock_hz / latency)


def feed_limit(machine: MachineConfig, kind: Kind) -> float:
    """The feed a faster one is clamped to: the fastest whose rate-multiplier word's rate is
    not above :func:`max_feed_mm_min` (nor the word above its register's largest)."""
    top = machine.lsb_per_s(max_feed_mm_min(machine, kind))
    word = math.floor(top / rm_clock_hz(machine) * (1 << FEED_BITS))
    return word_feed(machine, min(word, (1 << FEED_BITS) - 1))


def feed_word(machine: MachineConfig, feed_mm_min: float) -> int:
    """The rate-multiplier word for a feed: FP/s = f_in * W / 2^FEED_BITS (nearest, and at
    most the register's largest, 2^FEED_BITS - 1)."""
    word = round(machine.lsb_per_s(feed_mm_min) / rm_clock_hz(machine) * (1 << FEED_BITS))
    return min(word, (1 << FEED_BITS) - 1)


def word_rate(machine: MachineConfig, word: int) -> float:
    """The mean FP rate (FP/s) of a rate-multiplier word: f_in * W / 2^FEED_BITS."""
    return rm_clock_hz(machine) * word / (1 << FEED_BITS)


def word_feed(machine: MachineConfig, word: int) -> float:
    """The feed (mm/min) of a rate-multiplier word: the inverse of :func:`feed_word`."""
    return machine.mm_per_min(word_rate(machine, word))


def planned_seconds(item: Item, machine: MachineConfig,
                    rates: dict[tuple[float, Kind], float] | None = None) -> float:
    """How long ``item`` is planned to take: a dwell's time, a block's FP at its feed word's
    rate (the accel/decel circuit's lag not counted). ``rates``: :func:`block_rate`'s."""
    if isinstance(item, Dwell):
        return item.seconds
    if isinstance(item, Event):
        return 0.0
    return item.plan.fp / block_rate(item, machine, rates)


def block_rate(item: Move, machine: MachineConfig,
               rates: dict[tuple[float, Kind], float] | None = None) -> float:
    """The FP rate (FP/s) of the feed word a move runs at (:func:`run_feed`). ``rates``: the
    rates found so far, by programmed feed and block kind (a program repeats its feeds)."""
    key = (programmed_feed(item, machine), item.block.kind)
    rate = None if rates is None else rates.get(key)
    if rate is None:
        rate = word_rate(machine, feed_word(machine, run_feed(item, machine)))
        if rates is not None:
            rates[key] = rate
    return rate


#: The host's own time per block in :func:`program_seconds` (loading the K3701, the feed and
#: the budget over the bus: about 0.3 ms at 3.072 MHz, rounded up).
BLOCK_HOST_SECONDS = 0.001


def accel_lag_seconds(machine: MachineConfig, fp: int, rate: float) -> float:
    """How long after its last FP entered a block of ``fp`` FP at ``rate`` FP/s ends when the
    FP pass the accel/decel circuit (``machine.accel = "pre"``): an exponential circuit holds
    at most m = min(fp, rate tau) pulses, which leave one per tau / k when k are left, the
    last after about tau (ln m + 0.58); 0 for other placements (the K3701 then ends a block
    with its last FP) and empty blocks. An upper estimate, tau (1 + ln m), which also covers
    the linear and bell circuits."""
    if machine.accel != "pre" or fp == 0:
        return 0.0
    tau = machine.tau_s
    return tau * (1 + math.log(max(1.0, min(fp, rate * tau))))


@dataclass(frozen=True)
class ProgramTime:
    """A program's planned machine time (s), by what it is spent on."""

    #: The blocks' FP at their feed words' rates (:func:`planned_seconds`).
    moving: float
    #: The dwells (G04).
    dwells: float
    #: The ends of the blocks behind the accel/decel circuit (:func:`accel_lag_seconds`),
    #: the host's time per block (:data:`BLOCK_HOST_SECONDS`) and the settling at the end
    #: (:data:`SETTLE_SECONDS`).
    stops: float

    @property
    def total(self) -> float:
        return self.moving + self.dwells + self.stops


def program_time(job: Job) -> ProgramTime:
    """The program's planned machine time, an upper estimate, by part (:class:`ProgramTime`)."""
    machine = job.machine
    moving = dwells = 0.0
    stops = SETTLE_SECONDS
    rates: dict[tuple[float, Kind], float] = {}
    for item in job.program.items:
        if isinstance(item, Dwell):
            dwells += item.seconds
        elif not isinstance(item, Event):
            rate = block_rate(item, machine, rates)
            moving += item.plan.fp / rate  # planned_seconds
            stops += accel_lag_seconds(machine, item.plan.fp, rate) + BLOCK_HOST_SECONDS
    return ProgramTime(moving, dwells, stops)


def program_seconds(job: Job) -> float:
    """The program's planned machine time, an upper estimate: each block's FP at its feed
    word's rate (:func:`planned_seconds`), its end behind the accel/decel circuit
    (:func:`accel_lag_seconds`) and the host's time (:data:`BLOCK_HOST_SECONDS`), the dwells,
    and the settling at the end (:data:`SETTLE_SECONDS`)."""
    return program_time(job).total


def _where(item: Item, program: Program) -> str:
    return program.locate(item.line_no)


def programmed_feed(item: Move, machine: MachineConfig) -> float:
    """The feed a move is programmed at (mm/min): its F word, or the machine's rapid feed for
    G00."""
    if isinstance(item, Line) and item.rapid:
        return machine.rapid_mm_min
    assert item.feed_mm_min is not None
    return item.feed_mm_min


def run_feed(item: Move, machine: MachineConfig) -> float:
    """The feed a move runs at (mm/min): :func:`programmed_feed`, clamped to
    :func:`feed_limit` where it is above the K3701's maximum (``run.strict_feed`` refuses
    such a feed instead: :func:`check_program`)."""
    feed = programmed_feed(item, machine)
    if feed > max_feed_mm_min(machine, item.block.kind):
        return feed_limit(machine, item.block.kind)
    return feed


def clamped_feeds(job: Job) -> list[str]:
    """One warning naming every line whose feed :func:`run_feed` clamps (none: empty)."""
    machine, program = job.machine, job.program
    lines: dict[str, list[int]] = {}
    for item in program.moves:
        kind = item.block.kind
        if programmed_feed(item, machine) > max_feed_mm_min(machine, kind):
            lines.setdefault(_block_name(kind), []).append(item.line_no)
    if not lines:
        return []
    kinds = [(name, limit) for name, limit in
             ((_block_name(k), feed_limit(machine, k)) for k in Kind) if name in lines]
    return [f"{program.locate(min(min(v) for v in lines.values()))}: feeds above the K3701's "
            f"maximum run at it: "
            + "; ".join(f"{_line_list(lines[name])} at {limit:.2f} mm/min (the maximum for "
                        f"{name}s)" for name, limit in kinds)
            + " (run.strict_feed = true refuses them)"]


def _block_name(kind: Kind) -> str:
    return {Kind.LINEAR: "line", Kind.CIRCULAR: "arc"}.get(kind, f"{kind.name.lower()} block")


def _line_list(lines: list[int]) -> str:
    """``lines 3, 5-7`` of sorted line numbers, runs joined."""
    runs: list[list[int]] = []
    for line in sorted(set(lines)):
        if runs and line == runs[-1][-1] + 1:
            runs[-1].append(line)
        else:
            runs.append([line])
    text = ", ".join(str(r[0]) if len(r) == 1 else f"{r[0]}-{r[-1]}" for r in runs)
    return f"line{'s' if len(lines) > 1 else ''} {text}"


def check_program(job: Job) -> None:
    """Refuse, before anything is loaded, every block the hardware cannot run."""
    machine, program = job.machine, job.program
    for item in program.items:
        if isinstance(item, Dwell):
            counter = 2**CYCLE_COUNTER_BITS / machine.clock_hz
            if not item.seconds < counter:
                raise FirmwareError(
                    f"{_where(item, program)}: G04 P: the dwell is longer than the simulated "
                    f"clock can count (2^{CYCLE_COUNTER_BITS} cycles, {counter:.3g} s at "
                    f"{machine.clock_hz / 1e6:g} MHz)")
            continue
        if isinstance(item, Event):
            continue
        feed = programmed_feed(item, machine)
        limit = max_feed_mm_min(machine, item.block.kind)
        if feed > limit and job.run.strict_feed:
            what = {Kind.LINEAR: "a line", Kind.CIRCULAR: "an arc",
                    Kind.EXPONENTIAL: "an exponential"}.get(
                item.block.kind, f"a {item.block.kind.name.lower()} block")
            rapid = isinstance(item, Line) and item.rapid
            where, word = _where(item, program), "machine.rapid_mm_min"
            if not rapid and item.feed_source is not None:
                line, col, word = item.feed_source
                where = program.locate(line, col)
            raise FirmwareError(
                f"{where}: feed {feed:g} mm/min is above the K3701's maximum for {what}, "
                f"{math.floor(limit * 100) / 100:.2f} mm/min (one step per "
                f"{item.block.latency} cycles at {machine.clock_hz / 1e6:g} MHz; the block at "
                f"line {item.line_no}): lower {word}, or raise machine.clock_hz or "
                f"machine.lsb_mm (run.strict_feed = false clamps it to the maximum)")
        if feed_word(machine, feed) < 1:
            raise FirmwareError(f"{_where(item, program)}: feed {feed:g} mm/min is below the "
                                f"rate multiplier's resolution, {word_feed(machine, 1):.3g} "
                                f"mm/min")
        if item.plan.fp >= 1 << BUDGET_WIDTH:
            raise FirmwareError(f"{_where(item, program)}: the block needs {item.plan.fp} FP, "
                                f"more than the 24-bit budget register holds")
