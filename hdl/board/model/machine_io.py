"""Reference model of :class:`k37.hdl.board.machine_io.MachineIO`: the board's watchdog, E-stop
and limits, one chipset cycle at a time, and by whole spans of cycles for a simulated board.

In a cycle the model takes what the host puts on the bus (a byte write or read, or nothing),
whether the bridge took a whole frame (the watchdog's feed), the E-stop and limit inputs as
the synchronisers give them and each axis's D/A word, and gives what goes on to the chipset's
bus, the D/A words to the pins, drive-enable and the byte a read of the cycle before returns.
The register semantics are the host bus's (a write commits on its last byte, a read
snapshots on its first: :mod:`k37.hdl.bus.hostbus`).
"""

from __future__ import annotations

from dataclasses import dataclass

from k37.hdl.board.map import (
    BOARD_MAP,
    BOARD_SELECT,
    BOARD_WINDOW,
    DECEL_CTRL_PORT,
    LATCHED,
    STOPPING,
    WATCHDOG_BITS,
)
from k37.hdl.chipset.map import REG_BITS, axis_names

__all__ = ["BusCycle", "MachineIOModel", "MachineIOOutputs", "is_board_port"]

_SILENT_MAX = (1 << WATCHDOG_BITS) - 1
_STATUS = BOARD_MAP["STATUS"]


def is_board_port(address: int) -> bool:
    """Whether the 8-bit port ``address`` is one of the board's (its window of 8 ports)."""
    return address >> (REG_BITS - 2) == (BOARD_SELECT << 2 | BOARD_WINDOW >> 3)


@dataclass(frozen=True)
class BusCycle:
    """One cycle of a host bus: ``w_stb``/``r_stb`` with ``addr`` and ``w_data``."""

    addr: int = 0
    w_data: int = 0
    w_stb: bool = False
    r_stb: bool = False


@dataclass(frozen=True)
class MachineIOOutputs:
    """What the board puts out in a cycle."""

    chip: BusCycle
    dac: tuple[int, ...]
    drive_enable: bool
    r_data: int


class MachineIOModel:
    """The board's machine I/O of an ``axes``-axis board, from reset."""

    def __init__(self, axes: int = 3):
        self.axes = axis_names(axes)
        self.values = {r.name: r.init for r in BOARD_MAP if r.access.writable}
        self.shadow = {r.name: 0 for r in BOARD_MAP if r.nbytes > 1}
        self.snapshot = {r.name: 0 for r in BOARD_MAP if r.nbytes > 1 and r.access.readable}
        self.committed: str | None = None  # the register committed at the last edge
        self.bank_r_data = 0
        self.read_board = False
        #: Cycles since the last whole frame (saturating), the latched STATUS bits and
        #: whether the board's hold write is due.
        self.silent = 0
        self.latched = 0
        self.pending = False

    @property
    def stopping(self) -> bool:
        """A watchdog trip or the E-stop is latched: the drives are stopped."""
        return bool(self.latched & STOPPING)

    def status(self, estop_in: bool) -> int:
        """STATUS as it reads in a cycle with the E-stop input ``estop_in``."""
        fields = {"estop_in": int(estop_in), "drive_enable": int(not self.stopping),
                  "held": int(self.latched != 0)}
        return self.latched | _STATUS.encode(**fields)

    def trips(self) -> bool:
        """Whether the watchdog trips at the edge ending the current cycle."""
        watchdog = self.values["WATCHDOG"]
        return watchdog != 0 and self.silent >= watchdog

    def cycles_to_trip(self) -> int | None:
        """Cycles from the current one until the cycle whose ending edge trips the watchdog, if
        no frame comes (0: this one); None if it is off or already tripped."""
        watchdog = self.values["WATCHDOG"]
        if watchdog == 0 or self.latched & 1:
            return None
        return max(0, watchdog - self.silent)

    def settled(self, estop_n: bool, limit_n: tuple[bool, ...]) -> bool:
        """Whether cycles without a bus access or a frame, with these inputs, change nothing
        but the watchdog's count until it trips: :meth:`skip` may pass them."""
        active = int(not estop_n) << 1 | sum(int(not v) << (2 + k) for k, v in enumerate(limit_n))
        return not self.pending and self.committed is None and active & ~self.latched == 0

    def skip(self, cycles: int) -> None:
        """Pass ``cycles`` cycles that change nothing but the watchdog's count (:meth:`settled`,
        and at most :meth:`cycles_to_trip` of them): as many :meth:`step` calls would."""
        left = self.cycles_to_trip()
        if cycles < 0 or (left is not None and cycles > left):
            raise ValueError(f"cannot skip {cycles} cycles: the watchdog trips after {left}")
        self.silent = min(self.silent + cycles, _SILENT_MAX)

    def step(self, host: BusCycle, feed: bool = False, estop_n: bool = True,
             limit_n: tuple[bool, ...] | None = None, dac: tuple[int, ...] | None = None,
             chip_r_data: int = 0) -> MachineIOOutputs:
        """One cycle: its outputs, then the edge that ends it."""
        limit_n = limit_n if limit_n is not None else (True,) * len(self.axes)
        dac = dac if dac is not None else (0,) * len(self.axes)
        access = host.w_stb or host.r_stb
        hit = is_board_port(host.addr)
        held = self.latched != 0
        inject = self.pending and not access
        if inject:
            chip = BusCycle(DECEL_CTRL_PORT, 1, w_stb=True)
        else:
            forced = held and host.w_stb and host.addr == DECEL_CTRL_PORT
            chip = BusCycle(host.addr, host.w_data | forced, host.w_stb and not hit,
                            host.r_stb and not hit)
        out = MachineIOOutputs(
            chip, tuple(self.values["DAC_ZERO"] if self.stopping else word for word in dac),
            not self.stopping, self.bank_r_data if self.read_board else chip_r_data)

        # the edge
        estop_in = not estop_n
        status = self.status(estop_in)
        set_bits = (int(self.trips()) | int(estop_in) << 1
                    | sum(int(not level) << (2 + k) for k, level in enumerate(limit_n)))
        clear = self.values["CLEAR"] & LATCHED if self.committed == "CLEAR" else 0
        latched = (self.latched & ~clear) | set_bits
        self.pending = (self.pending and not inject) or (latched != 0 and self.latched == 0)
        self.latched = latched
        self.silent = 0 if feed else min(self.silent + 1, _SILENT_MAX)
        self.committed = None
        if host.r_stb:
            self.read_board = hit
        if hit and access:
            self._bank(host, status)
        return out

    def _bank(self, host: BusCycle, status: int) -> None:
        place = BOARD_MAP.at(host.addr & 0x07)
        if place is None:
            if host.r_stb:
                self.bank_r_data = 0
            return
        reg, k = place
        if host.w_stb and reg.access.writable:
            if k < reg.nbytes - 1:
                shadow = self.shadow[reg.name]
                self.shadow[reg.name] = shadow & ~(0xFF << 8 * k) | host.w_data << 8 * k
            else:
                low = self.shadow.get(reg.name, 0)
                self.values[reg.name] = low | host.w_data << 8 * (reg.nbytes - 1)
                self.committed = reg.name
        if host.r_stb:
            if not reg.access.readable:
                self.bank_r_data = 0
            elif k == 0:
                value = status if reg.name == "STATUS" else self.values[reg.name]
                self.bank_r_data = value & 0xFF
                if reg.name in self.snapshot:
                    self.snapshot[reg.name] = value >> 8
            else:
                self.bank_r_data = self.snapshot[reg.name] >> 8 * (k - 1) & 0xFF
