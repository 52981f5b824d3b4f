"""The feed-rate generator's registers as the host sees them
(:class:`k37.hdl.feed.feed_rate.FeedRate` implements them)."""

from __future__ import annotations

from collections.abc import Iterable

from k37.hdl.bus.registers import Access, Register, RegisterMap
from k37.hdl.feed.rates import FA_INCREMENT, STAGE_BITS

__all__ = ["DIVIDER_WIDTH", "FA_AXES", "FEED_BITS", "FEED_MAP", "FEED_MAP_AXIS_FA", "FEED_STAGES",
           "fa_register", "feed_map"]

#: Width of every phase-accumulator divider: f = f_clk * increment / 2^24.
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

#: The axes a FEED chip can give an addition clock of their own, and the address of each one's
#: increment register (free addresses above FA_INC: the plain chip's registers stay put).
FA_AXES = {"x": 0x09, "y": 0x0C, "z": 0x0F}


def fa_register(axis: str) -> str:
    """The name of axis ``axis``'s own addition-clock register (``FA_INC_X``, ...)."""
    return f"FA_INC_{axis.upper()}"


def _fa_axis(axis: str) -> Register:
    return Register(fa_register(axis), FA_AXES[axis], 24, Access.RW,
                    f"per-axis fa build: {axis.upper()}'s own addition clock fa_{axis} = f_clk * "
                    f"{fa_register(axis)} / 2^24, for its post-interpolation accel/decel circuit "
                    "(reset value: FA_INC's)", init=FA_INCREMENT)


def feed_map(axis_fa: Iterable[str] = ()) -> RegisterMap:
    """The register map of a FEED chip built with an addition clock of its own for each axis in
    ``axis_fa`` (none: :data:`FEED_MAP`)."""
    axes = tuple(axis_fa)
    for axis in axes:
        if axis not in FA_AXES:
            raise ValueError(f"axis_fa: no axis {axis!r}; axes are {', '.join(FA_AXES)}")
    if not axes:
        return FEED_MAP
    return RegisterMap("FEED", 1, (*FEED_MAP.registers,
                                   *(_fa_axis(axis) for axis in FA_AXES if axis in axes)),
                       doc=_AXIS_FA_DOC)


_AXIS_FA_DOC = ("Feed-rate generator: an SN7497-style rate multiplier cascade and two phase "
                "dividers. The per-axis fa build (`[machine.x] accel_fa_hz`, ...) adds a "
                "divider, and its increment register FA_INC_X, FA_INC_Y or FA_INC_Z, for each "
                "axis whose accel/decel circuit has its own addition clock.")

#: The FEED chip with every axis's own addition clock: the superset of every build's map
#: (what the host addresses and the register docs list).
FEED_MAP_AXIS_FA = feed_map(FA_AXES)
