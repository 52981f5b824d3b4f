"""Feed-rate generator: the rate multiplier, its input-clock divider and the fa divider(s).

The host sets the feed word and the dividers through :func:`~k37.hdl.feed.map.feed_rate.feed_map`;
the blocks inside are :class:`k37.hdl.feed.rate_multiplier.RateMultiplier` and
:class:`k37.hdl.feed.divider.PhaseDivider`, each tested against its own reference model, and the
chip against :class:`k37.hdl.feed.model.feed_rate.FeedRateModel`.
"""

from collections.abc import Iterable

from amaranth.hdl import Module
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out, connect, flipped

from k37.hdl.bus.hostbus import HostBus, RegisterBank
from k37.hdl.common.observation import FreeRunning, Observed, PhaseAccumulator, StrobeCounter
from k37.hdl.feed.divider import PhaseDivider
from k37.hdl.feed.map.feed_rate import (
    DIVIDER_WIDTH,
    FA_AXES,
    FEED_BITS,
    FEED_STAGES,
    fa_register,
    feed_map,
)
from k37.hdl.feed.rate_multiplier import RateMultiplier

__all__ = ["FeedRate"]

class FeedRate(Observed, wiring.Component):
    """Feed pulses at ``f_clk * RM_INC / 2^24 * FEED / 2^18`` and the fa clock enable.

    Parameters
    ----------
    axis_fa : iterable of str
        The axes (of ``"x"``, ``"y"``, ``"z"``) that get an addition clock of their own: a
        divider each, set by its register ``FA_INC_X``, ... (the per-axis fa build; none, the
        default: the plain chip, one fa).

    Members
    -------
    bus : In(HostBus(regmap.addr_width))
        Host interface; a register write takes effect from the cycle after its last byte.
    out : Out(1)
        Feed pulses (rate multiplier output), one cycle each; the BRM input clock is the
        RM_INC divider's registered strobe, and the BRM output follows it combinationally.
    fa : Out(1)
        Accel/decel addition clock enable (registered).
    fa_x, fa_y, fa_z : Out(1), per-axis fa build
        The addition clock enable of each axis in ``axis_fa`` (registered).

    Simulation only (see :mod:`k37.hdl.common.observation`)
    --------------------------------------------
    free_running : FreeRunning
        Every divider runs on for ever and the rate multiplier counts the input clock's
        strobes; its pulses matter only where the parent gates them (no ``quiet``: nothing
        here waits for an event).
    """

    #: The divider whose strobe is ``fa`` (a parent's accumulators count its strobes).
    FA_CLOCK = "fa_clock"

    def __init__(self, axis_fa: Iterable[str] = ()):
        self.regmap = feed_map(axis_fa)
        #: The axes with an addition clock of their own, in axis order.
        self.axis_fa = tuple(axis for axis in FA_AXES if axis in set(axis_fa))
        super().__init__({"bus": In(HostBus(self.regmap.addr_width)), "out": Out(1),
                          "fa": Out(1), **{f"fa_{axis}": Out(1) for axis in self.axis_fa}})

    @classmethod
    def fa_clock(cls, axis: str | None = None) -> str:
        """The divider whose strobe is axis ``axis``'s own addition clock (None: the shared
        ``fa``'s)."""
        return cls.FA_CLOCK if axis is None else f"{cls.FA_CLOCK}_{axis}"

    @property
    def free_running(self) -> FreeRunning:
        """See "Simulation only" above."""
        return self.declare(self.axis_fa)

    @classmethod
    def declare(cls, axis_fa: Iterable[str] = ()) -> FreeRunning:
        """The free-running declaration of a FEED chip with ``axis_fa`` (no instance needed:
        a parent declares it before it builds the chip)."""
        axes = tuple(axis for axis in FA_AXES if axis in set(axis_fa))
        return FreeRunning(
            accumulators=(PhaseAccumulator("rm_clock", DIVIDER_WIDTH),
                          PhaseAccumulator(cls.FA_CLOCK, DIVIDER_WIDTH),
                          *(PhaseAccumulator(cls.fa_clock(axis), DIVIDER_WIDTH)
                            for axis in axes)),
            counters=(StrobeCounter("rate", FEED_BITS, clock="rm_clock"),))

    def elaborate(self, platform) -> Module:
        m = Module()
        m.submodules.regs = regs = RegisterBank(self.regmap)
        m.submodules.rm_clock = rm_clock = PhaseDivider(DIVIDER_WIDTH)
        m.submodules[self.FA_CLOCK] = fa_clock = PhaseDivider(DIVIDER_WIDTH)
        m.submodules.rate = rate = RateMultiplier(FEED_STAGES)
        connect(m, flipped(self.bus), regs.bus)
        m.d.comb += [
            regs.feed.r_data.eq(regs.feed.w_data),
            regs.rm_inc.r_data.eq(regs.rm_inc.w_data),
            regs.fa_inc.r_data.eq(regs.fa_inc.w_data),
            rm_clock.increment.eq(regs.rm_inc.w_data),
            fa_clock.increment.eq(regs.fa_inc.w_data),
            rate.word.eq(regs.feed.w_data),
            rate.clk_en.eq(rm_clock.stb),
            self.out.eq(rate.out),
            self.fa.eq(fa_clock.stb),
        ]
        for axis in self.axis_fa:
            m.submodules[self.fa_clock(axis)] = clock = PhaseDivider(DIVIDER_WIDTH)
            reg = getattr(regs, fa_register(axis).lower())
            m.d.comb += [reg.r_data.eq(reg.w_data), clock.increment.eq(reg.w_data),
                         getattr(self, f"fa_{axis}").eq(clock.stb)]
        return m
