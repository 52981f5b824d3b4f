"""Feed-rate generator: the rate multiplier, its input-clock divider and the fa divider.

The host sets the feed word and the two dividers through :data:`FEED_MAP`; the blocks inside
are :class:`hdl.feed.rate_multiplier.RateMultiplier` and :class:`hdl.feed.divider.PhaseDivider`,
each tested against its own reference model.
"""

from amaranth.hdl import Module
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out, connect, flipped

from hdl.bus.hostbus import HostBus, RegisterBank
from hdl.common.observation import FreeRunning, Observed, PhaseAccumulator, StrobeCounter
from hdl.feed.divider import PhaseDivider
from hdl.feed.feed_rate_map import DIVIDER_WIDTH, FEED_BITS, FEED_MAP, FEED_STAGES
from hdl.feed.rate_multiplier import RateMultiplier

__all__ = ["FeedRate"]

class FeedRate(Observed, wiring.Component):
    """Feed pulses at ``f_clk * RM_INC / 2^24 * FEED / 2^18`` and the fa clock enable.

    Members
    -------
    bus : In(HostBus(FEED_MAP.addr_width))
        Host interface; a register write takes effect from the cycle after its last byte.
    out : Out(1)
        Feed pulses (rate multiplier output), one cycle each; the BRM input clock is the
        RM_INC divider's registered strobe, and the BRM output follows it combinationally.
    fa : Out(1)
        Accel/decel addition clock enable (registered).

    Simulation only (see :mod:`hdl.common.observation`)
    --------------------------------------------
    free_running : FreeRunning
        Both dividers run on for ever and the rate multiplier counts the input clock's
        strobes; its pulses matter only where the parent gates them (no ``quiet``: nothing
        here waits for an event).
    """

    bus: In(HostBus(FEED_MAP.addr_width))
    out: Out(1)
    fa: Out(1)

    #: The divider whose strobe is ``fa`` (a parent's accumulators count its strobes).
    FA_CLOCK = "fa_clock"

    @property
    def free_running(self) -> FreeRunning:
        """See "Simulation only" above."""
        return self.declare()

    @classmethod
    def declare(cls) -> FreeRunning:
        """The free-running declaration of any FEED chip (no instance needed: a parent
        declares it before it builds the chip)."""
        return FreeRunning(
            accumulators=(PhaseAccumulator("rm_clock", DIVIDER_WIDTH),
                          PhaseAccumulator(cls.FA_CLOCK, DIVIDER_WIDTH)),
            counters=(StrobeCounter("rate", FEED_BITS, clock="rm_clock"),))

    def elaborate(self, platform) -> Module:
        m = Module()
        m.submodules.regs = regs = RegisterBank(FEED_MAP)
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
        return m
