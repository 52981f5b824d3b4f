"""The KM3702's registers as the host sees them (:class:`k37.hdl.k3702.chip.K3702` implements
them)."""

from __future__ import annotations

from k37.hdl.bus.registers import Access, Field, Register, RegisterMap

__all__ = ["COUNTER_WIDTH", "K3702_MAP"]

#: Width of the command and error counters (two's complement, -2^23..2^23-1).
COUNTER_WIDTH = 24

_COUNTER = ("Read: snapshot of the running counter, taken when byte 0 is read. Write: load "
            "the counter in the cycle after the last byte (counts of that cycle are added to "
            "the loaded value).")

K3702_MAP = RegisterMap("K3702", 1, (
    Register("COMMAND", 0x00, 24, Access.RW,
             f"command counter: +COM counts up, -COM down. {_COUNTER}", signed=True),
    Register("ERROR", 0x03, 24, Access.RW,
             f"error counter: +COM and -FB add, -COM and +FB subtract; actual position = "
             f"COMMAND - ERROR. {_COUNTER}", signed=True),
    Register("POSITION_ZONE", 0x06, 24, Access.RW,
             "W: STATUS.in_position while |ERROR| <= W (reads back)"),
    Register("ALARM_ZONE", 0x09, 24, Access.RW,
             "A: alarm (ALARM pin low, interrupt on entry) while |ERROR| > A; A >= 0x800000 "
             "never alarms (reads back)", init=0xFFFFFF),
    Register("DAC_BITS", 0x0C, 8, Access.RW,
             "N: width of the offset-binary D/A word; an out-of-range write is ignored and "
             "sets STATUS.bad_config (reads back)", init=12, valid=(8, 16)),
    Register("STATUS", 0x0D, 8, Access.R, "flags of the error counter as it stands",
             after_reset=0x01, fields=(
        Field("in_position", 0, 1, "|ERROR| <= W (position zone)"),
        Field("negative", 1, 1, "ERROR < 0"),
        Field("sat_pos", 2, 1, "+SAT: ERROR > 2^(N-1) - 1, the D/A word is clamped to 2^N - 1"),
        Field("sat_neg", 3, 1, "-SAT: ERROR < -2^(N-1), the D/A word is clamped to 0"),
        Field("alarm", 4, 1, "|ERROR| > A (alarm zone; the ALARM pin is its complement)"),
        Field("irq", 5, 1, "alarm interrupt: set on entering the alarm zone, held until "
                           "CMD.ack"),
        Field("bad_config", 6, 1, "a DAC_BITS write outside 8..16 was ignored (sticky until "
                                  "CMD.clear)"),
    )),
    Register("CMD", 0x0E, 8, Access.W,
             "commands, acted on at the falling edge of the cycle after the write", fields=(
                 Field("clear_command", 0, 1, "clear the command counter (that cycle's counts "
                                              "are added after the clear)"),
                 Field("clear_error", 1, 1, "clear the error counter (likewise)"),
                 Field("ack", 2, 1, "acknowledge (clear) the alarm interrupt; an entry into the "
                                    "alarm zone in the same cycle wins"),
                 Field("clear", 3, 1, "clear STATUS.bad_config"),
             )),
    Register("CORRECT", 0x0F, 8, Access.W,
             "K37 extension, correction pulses: writing c adds c to both COMMAND and ERROR at "
             "the falling edge of the cycle after the write, as c +COM pulses (or -c -COM "
             "pulses) from the host would; the axis's actual position COMMAND - ERROR is "
             "unchanged and the D/A word moves by c. A host's contour controller acts on the "
             "axis through it; never written, the chip is the 1983 one", signed=True),
), doc="Position controller: command and error counters, D/A word, zones and alarm; K37's "
    "correction-pulse register CORRECT.")
