"""The simulated board's machine I/O: the watchdog, E-stop and limits of
:class:`k37.hdl.board.model.machine_io.MachineIOModel` between ``k37 serve``'s bridge and the
simulated machine.

:class:`BoardIO` is the bridge model's target (:class:`k37.hdl.bridge.model.Target`): a bus
access to the board's ports goes to the model's registers (a machine cycle in which the
chipset's bus is idle), every other one on to the machine, and time passes on both. The model
steps one cycle at a time where something happens (a board register written, a trip, the
board's hold write) and skips the spans between. The board's own hold write (DECEL CTRL) goes
on the machine's bus as the gateware's does. A stopped drive is modelled on the plant: its
velocity command is zero (the plant's gain and feedforward set to 0), so the motor comes to
rest by its own lag; the D/A word the plant sees stays the K3702's, where a board's pins
carry DAC_ZERO. :class:`InputChange` schedules the inputs by machine cycle (``k37 serve
--estop-at``, ``--limit``): a bench's E-stop pressed or limit switch opened at a known time.
"""

from __future__ import annotations

from dataclasses import dataclass

from k37.firmware_model.job import Job
from k37.firmware_model.link import Interrupts
from k37.hdl.board.model.machine_io import BusCycle, MachineIOModel, is_board_port
from k37.sim.backends.contract import Backend
from k37.sim.link.simulated import SimulatedLink
from k37.sim.machine.servo import axis_port
from k37.sim.run.runner import configure_plants

__all__ = ["BoardIO", "InputChange", "check_changes"]

_IDLE = BusCycle()


@dataclass(frozen=True, order=True)
class InputChange:
    """At machine cycle ``cycle`` (since the board was reset) the input ``name`` (``estop``
    or an axis's name, for its limit) becomes ``active`` (pressed, the switch open) or
    released."""

    cycle: int
    name: str
    active: bool = True

    def __str__(self) -> str:
        what = "the E-stop" if self.name == "estop" else f"the {self.name.upper()} limit"
        done = ("pressed" if self.name == "estop" else "hit") if self.active else "released"
        return f"{what} {done} at cycle {self.cycle:,}"


def check_changes(job: Job, changes: tuple[InputChange, ...]) -> None:
    """Raise ValueError unless every change is of an input ``job``'s board has."""
    names = ("estop", *job.machine.axis_names)
    for change in changes:
        if change.name not in names:
            raise ValueError(f"{change.name!r}: not an input of the {job.machine.axes}-axis "
                             f"board (estop, limits {', '.join(job.machine.axis_names)})")


class BoardIO:
    """The board's machine I/O on the simulated machine of ``job`` (``link`` over
    ``backend``); :attr:`estop_n` and :attr:`limit_n` are its inputs (True: released),
    taken at each machine cycle the bridge runs."""

    def __init__(self, link: SimulatedLink, backend: Backend, job: Job,
                 changes: tuple[InputChange, ...] = ()):
        self.link = link
        self.backend = backend
        self.job = job
        self.model = MachineIOModel(job.machine.axes)
        self.estop_n = True
        self.limit_n = (True,) * job.machine.axes
        check_changes(job, changes)
        #: The scheduled input changes still to come, the next first.
        self.changes = sorted(changes)
        self._feed = False
        self._driving = True
        self._chip_byte = 0

    @property
    def cycle(self) -> int:
        return self.link.cycle

    def frame(self) -> None:
        """A whole frame came: the watchdog is fed in the next machine cycle."""
        self._feed = True

    def interrupts(self) -> Interrupts:
        return self.link.interrupts()

    def write(self, address: int, data: int) -> None:
        self._step(BusCycle(address, data, w_stb=True))

    def read(self, address: int) -> int:
        self._step(BusCycle(address, r_stb=True))
        return self.model.bank_r_data if is_board_port(address) else self._chip_byte

    def idle(self, cycles: int) -> None:
        self._run(cycles, wait=False)

    def wait_interrupt(self, max_cycles: int) -> int:
        return self._run(max_cycles, wait=True)

    def unattended(self) -> int:
        """Run the machine on as a board does with no host, until an armed watchdog trips and
        the board has held the feed; the cycles run (0 if the watchdog is off or tripped)."""
        ran = 0
        # (a frame's feed not yet taken restarts the count once)
        while (left := self.model.cycles_to_trip()) is not None:
            self.idle(left + 2)  # the tripping edge, then the hold write
            ran += left + 2
        return ran

    def seconds_to_trip(self, clock_hz: float) -> float | None:
        """Machine seconds until an armed watchdog trips if no frame comes; None if off."""
        left = self.model.cycles_to_trip()
        return None if left is None else left / clock_hz

    def _apply_changes(self) -> int | None:
        """Take the scheduled input changes due by this cycle; the cycles to the next one
        (None: none to come)."""
        changes = self.changes
        while changes and changes[0].cycle <= self.cycle:
            change = changes.pop(0)
            if change.name == "estop":
                self.estop_n = not change.active
            else:
                k = self.job.machine.axis_names.index(change.name)
                self.limit_n = (*self.limit_n[:k], not change.active, *self.limit_n[k + 1:])
        return changes[0].cycle - self.cycle if changes else None

    def _step(self, host: BusCycle) -> None:
        """One machine cycle of the board and the machine."""
        self._apply_changes()
        feed, self._feed = self._feed, False
        out = self.model.step(host, feed, self.estop_n, self.limit_n)
        chip = out.chip
        if chip.w_stb:
            self.link.write(chip.addr, chip.w_data)
        elif chip.r_stb:
            self._chip_byte = self.link.read(chip.addr)
        else:
            self.link.idle(1)
        self._drives()

    def _run(self, cycles: int, wait: bool) -> int:
        """``cycles`` machine cycles without bus access (up to an interrupt if ``wait``); the
        cycles run."""
        done = 0
        model = self.model
        while done < cycles:
            span = min((cycles - done, *(n for n in (model.cycles_to_trip(),
                                                     self._apply_changes()) if n is not None)))
            if self._feed or span == 0 or not model.settled(self.estop_n, self.limit_n):
                self._step(_IDLE)
                done += 1
                if wait and self.link.interrupts().any():
                    break
                continue
            if wait:
                ran = self.link.wait_interrupt(span)
            else:
                self.link.idle(span)
                ran = span
            model.skip(ran)
            done += ran
            if wait and (ran < span or self.link.interrupts().any()):
                break
        return done

    def _drives(self) -> None:
        """Follow drive-enable: a stopped drive's velocity command is zero."""
        driving = not self.model.stopping
        if driving == self._driving:
            return
        self._driving = driving
        if driving:
            configure_plants(self.backend, self.job)
        else:
            for axis in self.job.machine.axis_names:
                for name in ("gain", "kf"):
                    self.backend.set(axis_port(axis, name), 0)
