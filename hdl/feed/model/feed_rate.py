"""Reference model of :class:`k37.hdl.feed.feed_rate.FeedRate`: its register bank, rate multiplier
and dividers composed one cycle at a time (``docs/chips/feed.md``)."""

from __future__ import annotations

from collections.abc import Iterable

from k37.hdl.bus.model.hostbus import RegisterBankModel
from k37.hdl.feed.map.feed_rate import DIVIDER_WIDTH, FA_AXES, FEED_STAGES, fa_register, feed_map
from k37.hdl.feed.model.divider import PhaseDividerModel
from k37.hdl.feed.model.rate_multiplier import RateMultiplierModel

__all__ = ["FeedRateModel"]


class FeedRateModel:
    """Cycle model of a FEED chip built with ``axis_fa``.

    Call :meth:`write` for the host's committing write of the current cycle (if any), then
    :meth:`step`, which returns the chip's outputs of the cycle (``out``, ``fa`` and each
    ``fa_<axis>``) and clocks. :attr:`registers` are the values the chip holds.
    """

    def __init__(self, axis_fa: Iterable[str] = ()):
        self.regmap = feed_map(axis_fa)
        self.axis_fa = tuple(axis for axis in FA_AXES if axis in set(axis_fa))
        self.bank = RegisterBankModel(self.regmap)
        self.rm_clock = PhaseDividerModel(DIVIDER_WIDTH)
        self.rate = RateMultiplierModel(FEED_STAGES)
        #: The addition-clock dividers: ``"fa"`` (FA_INC) and ``"fa_<axis>"``, by output name.
        self.fa_clocks = {"fa": PhaseDividerModel(DIVIDER_WIDTH),
                          **{f"fa_{axis}": PhaseDividerModel(DIVIDER_WIDTH)
                             for axis in self.axis_fa}}
        self._increments = {"fa": "FA_INC",
                            **{f"fa_{axis}": fa_register(axis) for axis in self.axis_fa}}

    @property
    def registers(self) -> dict[str, int]:
        """Every register's value as the chip holds it in the current cycle."""
        return dict(self.bank.values)

    def write(self, name: str, value: int) -> None:
        """The host's committing write of register ``name`` in the current cycle."""
        self.bank.write(name, value)

    def step(self) -> dict[str, int]:
        """One cycle: the outputs of the current cycle, then the clock edge that ends it."""
        values = self.bank.values
        out, _ = self.rate.step(values["FEED"], self.rm_clock.step(values["RM_INC"]))
        outputs = {"out": int(out)}
        for name, clock in self.fa_clocks.items():
            outputs[name] = int(clock.step(values[self._increments[name]]))
        self.bank.clock()
        return outputs
