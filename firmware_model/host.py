"""The 8085 host: I/O instructions with their T-state timing, over a :class:`ChipsetLink`.

The firmware model never touches the simulation: it issues ``OUT`` and ``IN`` instructions,
spends T-states and waits for interrupts, and :class:`Host8085` turns them into bus cycles
and system clock cycles on a :class:`firmware_model.link.ChipsetLink`. The same firmware code
therefore drives every implementation of the link, and the gaps between bus accesses are
those of a real 8085.
"""

from __future__ import annotations

from dataclasses import dataclass

from firmware_model.link import ChipsetLink, Interrupts
from hdl.chipset_map import chip_register, port

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


class Host8085:
    """An 8085 at ``host_hz`` driving the chipset through ``link`` at ``clock_hz``.

    Time is kept exactly: T-states convert to system cycles with the fraction carried over,
    and an I/O instruction's bus cycle is the last system cycle of the instruction.
    """

    def __init__(self, link: ChipsetLink, *, host_hz: float = 3.072e6, clock_hz: float = 1e6,
                 timing: HostTiming = T_STATES):
        if not host_hz > 0:
            raise ValueError(f"host clock must be > 0 Hz, not {host_hz!r}")
        self.link = link
        self.timing = timing
        self.cycles_per_t = clock_hz / host_hz
        self._owed = 0.0
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
        reg = chip_register(chip, register)
        word = self.read(chip, register)
        return {f.name: f.decode(word) for f in reg.fields}

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
