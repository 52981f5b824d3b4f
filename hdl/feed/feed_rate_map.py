"""The feed-rate generator's registers as the host sees them (:class:`hdl.feed.feed_rate.FeedRate`
implements them)."""

from __future__ import annotations

from hdl.bus.registers import Access, Register, RegisterMap
from hdl.feed.divider_model import FA_INCREMENT
from hdl.feed.rate_multiplier_model import STAGE_BITS

__all__ = ["DIVIDER_WIDTH", "FEED_BITS", "FEED_MAP", "FEED_STAGES"]

#: Width of both phase-accumulator dividers: f = f_clk * increment / 2^24.
DIVIDER_WIDTH = 24
#: Rate multiplier stages: an 18-bit feed word.
FEED_STAGES = 3
#: Width of the feed word: W feed pulses per 2^FEED_BITS input clocks.
FEED_BITS = STAGE_BITS * FEED_STAGES

FEED_MAP = RegisterMap("FEED", 1, (
    Register("FEED", 0x00, 24, Access.RW,
             f"feed word W: the rate multiplier passes W of every 2^{FEED_BITS} input "
             f"clocks", valid=(0, (1 << FEED_BITS) - 1)),
    Register("RM_INC", 0x03, 24, Access.RW,
             "rate-multiplier input clock: f_in = f_clk * RM_INC / 2^24 (0 stops the feed)"),
    Register("FA_INC", 0x06, 24, Access.RW,
             "accel/decel addition clock: fa = f_clk * FA_INC / 2^24 (reset value: the "
             "paper's 109.227 kHz at 1 MHz)", init=FA_INCREMENT),
), doc="Feed-rate generator: an SN7497-style rate multiplier cascade and two phase dividers.")
