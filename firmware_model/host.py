"""The 8085 host: I/O instructions with their T-state timing, over a :class:`ChipsetLink`.

The firmware model never touches the simulation: it issues ``OUT`` and ``IN`` instructions,
spends T-states and waits for interrupts, and :class:`Host8085` turns them into bus cycles
and system clock cycles on a :class:`k37.firmware_model.link.ChipsetLink`. The same firmware code
therefore drives every implementation of the link, and the gaps between bus accesses are
those of a real 8085.
"""

from __future__ import annotations

from dataclasses import dataclass

from k37.firmware_model.link import ChipsetLink, Interrupts
from k37.hdl.chipset.map import chip_register, port
from k37.hdl.common.constants import CHIP_HZ

__all__ = ["T_STATES", "Host8085", "HostTiming"]


@dataclass(frozen=True)
class HostTiming:
    """T-state costs of the firmware's instructions and routines (Intel 8085 data sheet)."""

    #: MVI A,d8 (7) + OUT port (10): write one byte to a chip.
    out_byte: int = 17
    #: IN port (10) + MOV r,A (4): read one byte from a chip.
    in_byte: int = 14
    #: RST vector (12) + PUSH PSW, B, D, H (4 x 12): entering the interrupt routine.
    isr_entry: int = 60
    #: POP H, D, B, PSW (4 x 10) + EI (4) + RET (10): leaving it.
    isr_exit: int = 54
    #: Fetching the next block from memory and preparing its register images
    #: (LHLD/MOV/DAD sequences for 5 registers, about 20 instructions).
    block_setup: int = 200
    #: One turn of a polling loop (IN, ANI, JZ: 10 + 7 + 10).
    poll: int = 27


T_STATES = HostTiming()
#: Timer routines handed to a link at a time in :meth:`Host8085.wait_polling` (a compiled
#: run's sampler pauses it every 10^6 cycles: 50 ticks of 20 ms).
POLL_BATCH = 64


class Host8085:
    """An 8085 at ``host_hz`` driving the chipset through ``link`` at ``clock_hz``.

    Time is kept exactly: T-states convert to system cycles with the fraction carried over,
    and an I/O instruction's bus cycle is the last system cycle of the instruction.
    """

    def __init__(self, link: ChipsetLink, *, host_hz: float = 3.072e6, clock_hz: float = CHIP_HZ,
                 timing: HostTiming = T_STATES):
        if not host_hz > 0:
            raise ValueError(f"host clock must be > 0 Hz, not {host_hz!r}")
        self.link = link
        self.timing = timing
        self.cycles_per_t = clock_hz / host_hz
        self._owed = 0.0
        #: The read-only timer routines computed ahead (:meth:`_routines`), by where they start.
        self._routine_cache: tuple[tuple[int, float] | None, list[int],
                                   list[tuple[float, float]]] = (None, [], [])
        self.t_states = 0

    def _advance(self, t_states: int) -> int:
        """Account ``t_states``; returns the whole system cycles they complete."""
        self.t_states += t_states
        self._owed += t_states * self.cycles_per_t
        whole = int(self._owed)
        self._owed -= whole
        return whole

    def work(self, t_states: int, max_cycles: int | None = None) -> None:
        """Spend ``t_states`` without bus activity (computation, loop overhead).

        A delay loop passes ``max_cycles``, the system cycles the run has left: it stops there
        (the run is over), however long it was meant to be.
        """
        cycles = self._advance(t_states)
        if max_cycles is not None:
            cycles = min(cycles, max(0, max_cycles))
        if cycles:
            self.link.idle(cycles)

    def _io_cycles(self, t_states: int) -> None:
        # The instruction's bus cycle is its last system cycle; at a 3.072 MHz host and a
        # 1 MHz chipset clock every I/O instruction spans at least three system cycles.
        cycles = self._advance(t_states)
        if cycles > 1:
            self.link.idle(cycles - 1)

    def out(self, address: int, value: int) -> None:
        """``OUT address`` with ``value`` in A."""
        if not 0 <= value <= 0xFF:
            raise ValueError(f"OUT {address:#04x}: {value} is not a byte")
        self._io_cycles(self.timing.out_byte)
        self.link.write(address, value)

    def inp(self, address: int) -> int:
        """``IN address``: the byte read."""
        self._io_cycles(self.timing.in_byte)
        return self.link.read(address)

    def write(self, chip: str, register: str, value: int) -> None:
        """Write a whole register, LSB first (its last byte commits it)."""
        reg = chip_register(chip, register)
        if not reg.access.writable:
            raise ValueError(f"{chip} {register} is read-only")
        for k, byte in enumerate(reg.to_bytes(value)):
            self.out(port(chip, register, k), byte)

    def read(self, chip: str, register: str) -> int:
        """Read a whole register, LSB first (its first byte snapshots it)."""
        reg = chip_register(chip, register)
        if not reg.access.readable:
            raise ValueError(f"{chip} {register} is write-only")
        data = [self.inp(port(chip, register, k)) for k in range(reg.nbytes)]
        return reg.from_bytes(data)

    def command(self, chip: str, register: str = "CMD", **fields: int) -> None:
        """Write a command register from named fields (``host.command("K3701", start=1)``)."""
        reg = chip_register(chip, register)
        self.write(chip, register, reg.encode(**fields))

    def status(self, chip: str, register: str = "STATUS") -> dict[str, int]:
        """Read a status register and decode its fields."""
        return chip_register(chip, register).decode(self.read(chip, register))

    def wait_polling(self, max_cycles: int, period: int, ports: tuple[int, ...],
                     stops: tuple[int, ...]) -> list[int] | None:
        """Wait (halted) for an interrupt, at most ``max_cycles`` system cycles, while a timer
        interrupts every ``period`` cycles (its ticks at multiples of ``period`` since reset)
        into a routine that only reads: entry, ``IN`` from each of ``ports``, exit.

        A tick is served if the wait up to it saw no interrupt and ``max_cycles`` had not run
        out; a routine runs to its end. Returns None once an interrupt input is high after a
        wait or ``max_cycles`` ran out; or the bytes of a routine that read a byte with any
        bit of its port's ``stops`` mask set, right after its reads (the caller handles them,
        then leaves with ``work(timing.isr_exit)``).

        A link that runs such waits itself (``wait_polling``, e.g. a compiled simulation) is
        given batches of routines, with the system cycles of each from the host's T-state
        clock; it gives the same bus cycles at the same system cycles as this host's own loop.
        """
        if not ports or len(stops) != len(ports):
            raise ValueError("a polling routine reads at least one port, with a mask each")
        native = getattr(self.link, "wait_polling", None)
        end = self.cycle + max_cycles
        due = False  # a routine is due at once (the link paused at its tick)
        while native is not None:
            ticks = (end - self.cycle) // period + 1  # at most, before the end
            idles, phases = self._routines(len(ports), min(POLL_BATCH, ticks))
            result = native(end - self.cycle, period, ports, stops, idles, due)
            if result is None:
                break  # the link cannot: the host's own loop serves the rest
            done, read, more = result
            t_routine = self.timing.isr_entry + len(ports) * self.timing.in_byte
            self.t_states += done * (t_routine + self.timing.isr_exit)
            if read is not None:
                self.t_states += t_routine
                self._owed = phases[done][0]
                return read
            if done:
                self._owed = phases[done - 1][1]
                _, ahead, ahead_phases = self._routine_cache
                self._routine_cache = ((len(ports), self._owed),
                                       ahead[done * (len(ports) + 1):], ahead_phases[done:])
            if not more:
                return None
            due = more == 2
        while (left := end - self.cycle) > 0:
            to_tick = period - self.cycle % period
            waited = self.wait_interrupt(min(left, to_tick))
            if self.interrupts().any():
                return None
            if waited == to_tick and self.cycle < end:
                self.work(self.timing.isr_entry)
                read = [self.inp(address) for address in ports]
                if any(byte & mask for byte, mask in zip(read, stops, strict=True)):
                    return read
                self.work(self.timing.isr_exit)
        return None

    def _routines(self, reads: int, count: int) -> tuple[list[int], list[tuple[float, float]]]:
        """The next ``count`` read-only timer routines (``reads`` INs each) from the host's
        T-state phase now, as :meth:`work` and :meth:`inp` would spend them: their idle
        cycles, ``reads`` + 1 a routine (before each read's bus cycle, then after the last),
        and each one's phase after its reads and after its exit. The host's state is
        unchanged; the routines are remembered while its phase is where they start (the next
        wait goes on with them)."""
        key = (reads, self._owed)
        if self._routine_cache[0] != key:
            self._routine_cache = (key, [], [])
        _, idles, phases = self._routine_cache
        owed = phases[-1][1] if phases else self._owed
        entry_t, in_t, exit_t = (t_states * self.cycles_per_t for t_states in (
            self.timing.isr_entry, self.timing.in_byte, self.timing.isr_exit))
        idle = idles.append
        for _ in range(count - len(phases)):
            owed += entry_t
            entry = int(owed)
            owed -= entry
            for _ in range(reads):  # an IN: its bus cycle is its last system cycle
                owed += in_t
                whole = int(owed)
                owed -= whole
                idle(entry + whole - 1 if whole else entry)
                entry = 0
            after_reads = owed
            owed += exit_t
            whole = int(owed)
            owed -= whole
            idle(whole)
            phases.append((after_reads, owed))
        return idles[:count * (reads + 1)], phases[:count]

    def wait_interrupt(self, max_cycles: int) -> int:
        """Wait (interrupts enabled, the CPU halted) until an interrupt input goes high, at
        most ``max_cycles`` system cycles; the cycles waited."""
        return self.link.wait_interrupt(max_cycles)

    def interrupts(self) -> Interrupts:
        """RIM: the interrupt inputs' levels."""
        return self.link.interrupts()

    @property
    def cycle(self) -> int:
        return self.link.cycle
