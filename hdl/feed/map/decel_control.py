"""The decel (FP budget) control's registers as the host sees them
(:class:`k37.hdl.feed.decel_control.DecelControl` implements them)."""

from __future__ import annotations

from k37.hdl.bus.registers import Access, Field, Register, RegisterMap
from k37.hdl.feed.rates import BUDGET_WIDTH

__all__ = ["DECEL_MAP"]

DECEL_MAP = RegisterMap("DECEL", 1, (
    Register("BUDGET", 0x00, BUDGET_WIDTH, Access.W,
             "FP budget of the next block, 0..2^24-1; the committing (last) byte loads "
             "REMAINING, effective in the cycle after it"),
    Register("REMAINING", 0x03, BUDGET_WIDTH, Access.R,
             "FP still to pass (snapshot when byte 0 is read)", after_reset=0),
    Register("CTRL", 0x06, 8, Access.RW, "control (reads back)", fields=(
        Field("hold", 0, 1, "1: close the gate at once (stop feed), keeping REMAINING; "
                            "0: open it again"),
    )),
    Register("STATUS", 0x07, 8, Access.R, "status", after_reset=0x01, fields=(
        Field("spent", 0, 1, "REMAINING is 0: the whole budget has passed (also after reset)"),
        Field("open", 1, 1, "input pulses pass now (not spent and not held)"),
    )),
), doc="Decel control: the FP budget gate between the rate multiplier and the accel/decel "
       "circuit.")
