"""The 8085 host firmware, following the paper's flow chart (Fig. 10).

Main line: clear all status, set the mode, initialise the interpolator and the position
controllers, then for each block: take it, load it, start it and wait. The interrupt routine
serves the K3701's data request (the block ended: next block) and the K3702's alarm (stop
the feed, report). All chip access goes through :class:`k37.firmware_model.host.Host8085`, so
every register access costs the 8085's T-states and the firmware runs unchanged on every
simulation backend.

Before anything is loaded, :func:`k37.firmware_model.feeds.check_program` refuses what the
hardware cannot do; each block's feed becomes the rate multiplier's word there
(:mod:`k37.firmware_model.feeds`).

While the 8085 waits for a block's end, its timer interrupt (every :data:`TIMER_TICK_SECONDS`)
polls both encoders' status: the encoder interface has no interrupt line (``docs/chips/encoder.md``:
a line fault is a flag), so this is how a broken line is seen while the axes move rather than
only at the next block end. Any encoder fault stops the feed and the program, as an alarm
does.

With a contour controller (``[contour]``, :mod:`k37.firmware_model.contour`) the timer ticks every
``contour.period_ms`` instead, and its routine also reads each axis's COMMAND and ERROR
counters, computes the correction and writes its change to each K3702's CORRECT register
(correction pulses, at most 127 a write); after the last block the host takes the corrections
back before it waits for the axes to settle.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

from k37.firmware_model.contour.controllers import ContourController
from k37.firmware_model.feeds import (
    SETTLE_SECONDS,
    check_program,
    feed_word,
    rm_clock_hz,
    run_feed,
)
from k37.firmware_model.host import Host8085
from k37.firmware_model.job import Job
from k37.firmware_model.motion.program import Dwell, Event, Item, Move
from k37.hdl.chipset.map import chip_register, port
from k37.hdl.feed.map.feed_rate import DIVIDER_WIDTH, fa_register
from k37.hdl.feed.rates import increment_for
from k37.hdl.k3701.map import block_registers
from k37.hdl.k3702.map import K3702_MAP

__all__ = ["AlarmEvent", "BlockObserver", "BlockRecord", "EventRecord", "Firmware"]

#: The encoder faults the firmware reads in an encoder's STATUS.
ENCODER_FAULTS = ("line_fault_a", "line_fault_b", "quad_error")


@dataclass
class BlockRecord:
    """What the firmware knows of one block (filled in as it runs)."""

    index: int
    line: int
    kind: str
    start_cycle: int
    fp_budget: int
    feed_word: int
    end_cycle: int | None = None


class BlockObserver(Protocol):
    """Trace points of the firmware: where a logic analyser would trigger.

    Called when a block is about to be loaded and when its data request has been read; what
    an observer measures there (the simulation's pulse counters) never reaches the firmware.
    """

    def block_started(self, record: BlockRecord) -> None: ...

    def block_ended(self, record: BlockRecord) -> None: ...


@dataclass
class AlarmEvent:
    """An alarm or fault the firmware saw."""

    axis: str | None
    cycle: int
    kind: str


@dataclass
class EventRecord:
    """A word with no hardware here (:class:`k37.firmware_model.motion.program.Event`) and the cycle
    the firmware reached it at."""

    event: Event
    cycle: int


class Firmware:
    """The host program of Fig. 10, run against the chipset through ``host``.

    :meth:`run` executes a whole program and returns when it ended, an alarm stopped it, or
    ``max_cycles`` ran out; ``blocks`` and ``alarms`` say what happened, and ``events`` the
    cycle each of the program's events (words with no hardware here) was reached at.
    """

    def __init__(self, host: Host8085, job: Job, *, budget_offset: int = 0,
                 observer: BlockObserver | None = None):
        check_program(job)
        self.host = host
        self.job = job
        self.observer = observer
        #: Added to every block's exact FP budget: the paper's hazard (``docs/chips/decel.md``) made
        #: reproducible. 0 for normal operation.
        self.budget_offset = budget_offset
        self.blocks: list[BlockRecord] = []
        self.alarms: list[AlarmEvent] = []
        self.events: list[EventRecord] = []
        self.stopped = False
        self.timed_out = False
        #: The program item running (None before the first) and the cycle it began.
        self.item: Item | None = None
        self.item_cycle = 0
        contour = job.contour
        #: The contour controller (None: none) and the corrections the axes hold (LSB).
        self.contour = None if not contour.enabled else ContourController(
            contour, job.program.moves, job.machine.axes, contour.period_ms / 1000)
        self.held = [0] * job.machine.axes

    # -- initialisation ----------------------------------------------------------------------

    def initialise(self) -> None:
        """Clear all status, set the mode, initialise the interpolator and controllers."""
        host, machine = self.host, self.job.machine
        host.command("K3701", ack=1, clear=1)
        host.write("DECEL", "CTRL", 0)
        host.write("FEED", "FEED", 0)
        host.write("FEED", "RM_INC", increment_for(rm_clock_hz(machine), width=DIVIDER_WIDTH,
                                                   f_clk=machine.clock_hz))
        host.write("FEED", "FA_INC", increment_for(machine.accel_fa_hz, width=DIVIDER_WIDTH,
                                                   f_clk=machine.clock_hz))
        for axis in self.job.fa_axes():  # the per-axis fa build's own clocks
            host.write("FEED", fa_register(axis), increment_for(
                self.job.fa_hz(axis), width=DIVIDER_WIDTH, f_clk=machine.clock_hz))
        for axis in machine.axis_names:
            ctrl, enc = f"K3702_{axis.upper()}", f"ENCODER_{axis.upper()}"
            host.write(enc, "FILTER", machine.encoder_filter)
            host.command(enc, clear=1)
            host.write(ctrl, "DAC_BITS", machine.dac_bits)
            host.write(ctrl, "POSITION_ZONE", machine.in_position)
            host.write(ctrl, "ALARM_ZONE", machine.alarm_limit)
            host.command(ctrl, clear_command=1, clear_error=1, ack=1, clear=1)

    # -- the main line -----------------------------------------------------------------------

    def run(self, max_cycles: int) -> None:
        """Initialise, then execute every block of the program (Fig. 10's main loop)."""
        self.limit = max_cycles
        self.initialise()
        for item in self.job.program.items:
            if self.stopped or self.host.cycle >= self.limit:
                break
            self.item, self.item_cycle = item, self.host.cycle
            if isinstance(item, Dwell):
                self._dwell(item)
            elif isinstance(item, Event):  # no hardware: recorded, nothing is accessed
                self.events.append(EventRecord(item, self.host.cycle))
            else:
                self._block(item)
        if not self.stopped and self.host.cycle < self.limit:
            self._correct([0] * len(self.held))  # the corrections taken back
            self._settle()
        self.timed_out = self.host.cycle >= self.limit and not self.stopped

    def _dwell(self, item: Dwell) -> None:
        # A delay loop on the 8085: the chipset runs on, nothing is accessed; the run's
        # cycle limit cuts it short.
        t_states = round(item.seconds * self.host_hz)
        self.host.work(t_states, max_cycles=self.limit - self.host.cycle)

    @property
    def host_hz(self) -> float:
        return self.job.machine.clock_hz / self.host.cycles_per_t

    def _block(self, item: Move) -> None:
        host, machine = self.host, self.job.machine
        host.work(host.timing.block_setup)
        block = item.block
        word = feed_word(machine, run_feed(item, machine))
        budget = max(0, item.plan.fp + self.budget_offset)
        record = BlockRecord(item.index, item.line_no, block.kind.name.lower(),
                             host.cycle, budget, word)
        self.blocks.append(record)
        if self.observer is not None:
            self.observer.block_started(record)
        # Load the interpolator, start it, then open the feed with the exact FP budget.
        for register, value in block_registers(block, machine.axes).items():
            host.write("K3701", register, value)
        host.command("K3701", start=1, ack=1)
        host.write("FEED", "FEED", word)
        host.write("DECEL", "BUDGET", budget)
        self._wait_block_end(record)

    def _wait_block_end(self, record: BlockRecord) -> None:
        """Wait for interrupts; serve them until the K3701's data request ends the block. The
        timer interrupt wakes the host at every tick (multiples of the tick since reset)."""
        if self.contour is not None:
            self._wait_contour(record)
            return
        host = self.host
        tick = max(1, round(TIMER_TICK_SECONDS * self.job.machine.clock_hz))
        chips = self._encoder_chips()
        status = chip_register(chips[0], "STATUS")
        ports = tuple(port(chip, "STATUS", k) for chip in chips for k in range(status.nbytes))
        faults = status.to_bytes(status.encode(**dict.fromkeys(ENCODER_FAULTS, 1)))
        while record.end_cycle is None and not self.stopped:
            left = self.limit - host.cycle
            if left <= 0:
                return
            # The timer's routine (entry, the encoders' STATUS, exit) at each tick on the way.
            read = host.wait_polling(left, tick, ports, tuple(faults) * len(chips))
            if read is not None:
                n = status.nbytes
                self._encoder_faults({chip: status.from_bytes(read[k * n:(k + 1) * n])
                                      for k, chip in enumerate(chips)})
                host.work(host.timing.isr_exit)
            elif host.interrupts().any():
                self._interrupt(record)

    def _wait_contour(self, record: BlockRecord) -> None:
        """:meth:`_wait_block_end` with a contour controller: its timer ticks every period
        (multiples of the period since reset) into :meth:`_contour_sample`."""
        host = self.host
        period = max(1, round(self.job.contour.period_ms / 1000 * self.job.machine.clock_hz))
        while record.end_cycle is None and not self.stopped:
            left = self.limit - host.cycle
            if left <= 0:
                return
            to_tick = period - host.cycle % period
            waited = host.wait_interrupt(min(left, to_tick))
            if host.interrupts().any():
                self._interrupt(record)
            elif waited == to_tick and host.cycle < self.limit:
                self._contour_sample()

    def _contour_sample(self) -> None:
        """The contour timer's routine: the encoders' STATUS (their faults stop the program),
        each axis's reference (COMMAND less the correction it holds) and actual position
        (COMMAND - ERROR), then the new corrections."""
        host = self.host
        assert self.contour is not None and self.item is not None
        host.work(host.timing.isr_entry)
        statuses = {chip: host.read(chip, "STATUS") for chip in self._encoder_chips()}
        reference, actual = [], []
        for axis, held in zip(self.job.machine.axis_names, self.held, strict=True):
            chip = f"K3702_{axis.upper()}"
            command, error = host.read(chip, "COMMAND"), host.read(chip, "ERROR")
            reference.append(command - held)
            actual.append(command - error)
        self._correct([round(float(c)) for c in
                       self.contour.correction(self.item.index, reference, actual)])
        self._encoder_faults(statuses)
        host.work(host.timing.isr_exit)

    def _correct(self, target: list[int]) -> None:
        """Bring each axis's held correction to ``target`` (LSB, limited to half the D/A
        range: beyond it the D/A word is saturated anyway) by CORRECT writes."""
        limit = 1 << (self.job.machine.dac_bits - 1)
        low, high = _CORRECT.bounds
        for k, axis in enumerate(self.job.machine.axis_names):
            change = max(-limit, min(limit, target[k])) - self.held[k]
            self.held[k] += change
            while change:
                step = max(low, min(high, change))
                self.host.write(f"K3702_{axis.upper()}", "CORRECT", step)
                change -= step

    def _interrupt(self, record: BlockRecord | None) -> None:
        """The interrupt routine: alarm first (stop the feed), then the data request."""
        host = self.host
        host.work(host.timing.isr_entry)
        for axis in self.job.machine.axis_names:
            chip = f"K3702_{axis.upper()}"
            if host.status(chip)["irq"]:
                host.write("DECEL", "CTRL", 1)          # stop feed at once
                host.command(chip, ack=1)
                self.alarms.append(AlarmEvent(axis, host.cycle, "alarm"))
                self.stopped = True
        status = host.status("K3701")
        if status["irq"]:
            host.command("K3701", ack=1)
            if record is not None:
                self._close(record, status)
        host.work(host.timing.isr_exit)

    def _close(self, record: BlockRecord, status: dict[str, int]) -> None:
        host = self.host
        record.end_cycle = host.cycle
        if self.observer is not None:
            self.observer.block_ended(record)
        if status["error"]:
            self.alarms.append(AlarmEvent(None, host.cycle, "interpolator_error"))
            self.stopped = True
        if status["overrun"]:
            self.alarms.append(AlarmEvent(None, host.cycle, "fp_overrun"))
            host.command("K3701", clear=1)
        self._check_encoders()

    def _encoder_chips(self) -> tuple[str, ...]:
        return tuple(f"ENCODER_{axis.upper()}" for axis in self.job.machine.axis_names)

    def _check_encoders(self) -> None:
        """Read every encoder's STATUS, then handle their faults (:meth:`_encoder_faults`)."""
        host = self.host
        self._encoder_faults({chip: host.read(chip, "STATUS") for chip in self._encoder_chips()})

    def _encoder_faults(self, statuses: dict[str, int]) -> None:
        """The encoders' STATUS words, as read: a fault (the position is no longer known)
        stops the feed at once, then the faulted encoders' flags are cleared; the program
        stops."""
        host = self.host
        faulted = []
        for (chip, word), axis in zip(statuses.items(), self.job.machine.axis_names,
                                      strict=True):
            status = chip_register(chip, "STATUS").decode(word)
            flags = [flag for flag in ENCODER_FAULTS if status[flag]]
            self.alarms.extend(AlarmEvent(axis, host.cycle, f"encoder_{flag}") for flag in flags)
            if flags:
                faulted.append(chip)
        if not faulted:
            return
        if not self.stopped:
            host.write("DECEL", "CTRL", 1)  # stop feed at once
        for chip in faulted:
            host.command(chip, clear=1)
        self.stopped = True

    def _settle(self) -> None:
        """After the last block: poll until both axes hold the programmed end, in position."""
        host = self.host
        target = self.job.program.final_position
        deadline = host.cycle + round(SETTLE_SECONDS * self.job.machine.clock_hz)
        while host.cycle < min(deadline, self.limit):
            if host.interrupts().alarm:
                self._interrupt(None)
                return
            done = True
            for axis, goal in zip(self.job.machine.axis_names, target, strict=True):
                chip = f"K3702_{axis.upper()}"
                if not host.status(chip)["in_position"] or host.read(chip, "COMMAND") != goal:
                    done = False
                    break
            if done:
                self._check_encoders()
                return
            host.work(SETTLE_POLL_T_STATES, max_cycles=self.limit - host.cycle)
        if host.cycle < self.limit:
            self.alarms.append(AlarmEvent(None, host.cycle, "settle_timeout"))


#: The K3702's correction-pulse register (K37's extension).
_CORRECT = K3702_MAP["CORRECT"]
#: The settle loop's delay between polls (about 1 ms at 3.072 MHz).
SETTLE_POLL_T_STATES = 3072
#: The host's timer tick (50 Hz, a mains-rate timer), on which it polls the encoders while a
#: block runs.
TIMER_TICK_SECONDS = 0.02

