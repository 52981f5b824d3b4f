"""The board's own registers as the host sees them: the watchdog and the machine I/O
(:class:`k37.hdl.board.machine_io.MachineIO` implements them; no Amaranth here).

The board answers in a window of chip select 6 that the DECEL chip leaves free (A4 = 1, A3 = 0:
ports 0xd0-0xd7), the way chip select 7 holds two chips; the chipset does not decode it, so a
chipset without the board (a run in process) simply has nothing there.
"""

from __future__ import annotations

from k37.hdl.bus.registers import Access, Field, Register, RegisterMap
from k37.hdl.chipset.map import CHIP_SELECTS, REG_BITS, axis_names, port

__all__ = ["BOARD_MAP", "BOARD_SELECT", "BOARD_WINDOW", "DECEL_CTRL_PORT", "LATCHED",
           "STOPPING", "WATCHDOG_BITS", "board_port", "limit_mask"]

#: Width of the WATCHDOG register: up to 16.7 s at the chipset's 1 MHz.
WATCHDOG_BITS = 24
#: The chip select the board shares, and the board's window inside its 32 ports.
BOARD_SELECT = CHIP_SELECTS["DECEL"][0]
BOARD_WINDOW = 0x10
#: The port the board writes to hold the feed (the DECEL chip's CTRL, its ``hold`` bit).
DECEL_CTRL_PORT = port("DECEL", "CTRL")

_LIMITS = tuple(Field(f"limit_{axis}", 2 + k, 1,
                      f"latched: the {axis.upper()} limit input was active")
                for k, axis in enumerate(axis_names(3)))

BOARD_MAP = RegisterMap("BOARD", 1, (
    Register("WATCHDOG", 0x00, WATCHDOG_BITS, Access.RW,
             "Watchdog time in chipset cycles: when this many cycles pass without a whole "
             "frame from the host (any command; a frame answered with an error is none), the "
             "watchdog trips. 0: off (reads back)"),
    Register("DAC_ZERO", 0x03, 16, Access.RW,
             "The D/A word of 0 V, put out on every axis while the board stops the drives "
             "(2^(N-1) for the K3702's N-bit word; the reset value is the K3702's reset N = 12; "
             "reads back)", init=1 << 11),
    Register("STATUS", 0x05, 8, Access.R,
             "Why the board holds: the latched bits stay set until cleared by CLEAR",
             after_reset=0x40, fields=(
                 Field("watchdog", 0, 1, "latched: the watchdog tripped"),
                 Field("estop", 1, 1, "latched: the E-stop input was active"),
                 *_LIMITS,
                 Field("estop_in", 5, 1, "the E-stop input is active now"),
                 Field("drive_enable", 6, 1, "the drive-enable output is high (no watchdog or "
                                             "E-stop latched)"),
                 Field("held", 7, 1, "a latched bit is set: the board holds the feed"),
             )),
    Register("CLEAR", 0x06, 8, Access.W,
             "Write 1 to a latched STATUS bit to clear it (write-1-to-clear); a bit whose "
             "input is still active stays set. Same bits as STATUS 4:0", fields=(
                 Field("watchdog", 0, 1, "clear the watchdog bit"),
                 Field("estop", 1, 1, "clear the E-stop bit"),
                 *(Field(f.name, f.offset, 1, f"clear the {f.name} bit") for f in _LIMITS),
             )),
), doc="The board's watchdog and machine I/O (not a chip of the chipset: the FPGA board's "
       "own, at ports 0xd0-0xd6). On a watchdog trip or the E-stop input the board holds "
       "the feed (it writes the DECEL chip's CTRL.hold), puts DAC_ZERO out on every axis "
       "and drops drive-enable; on a limit input it holds the feed only, the drives keeping "
       "the axes where they stop.")

#: STATUS bits that are latched (CLEAR's bits), and those that stop the drives.
LATCHED = 0x1F
STOPPING = 0x03


def board_port(register: str, byte: int = 0) -> int:
    """The 8085 I/O port of byte ``byte`` of the board's ``register``."""
    reg = BOARD_MAP[register]
    if not 0 <= byte < reg.nbytes:
        raise ValueError(f"BOARD {register} has {reg.nbytes} byte(s), not byte {byte}")
    return BOARD_SELECT << REG_BITS | BOARD_WINDOW | (reg.addr + byte)


def limit_mask(axes: int) -> int:
    """The STATUS bits of the limits of an ``axes``-axis board."""
    return sum(1 << (2 + k) for k in range(len(axis_names(axes))))

