# amaranth: UnusedElaboratable=no
"""The registry of exportable blocks: :data:`BLOCKS`, each built from its module on demand.

The registry itself imports no gateware (nor Amaranth): the command line lists the blocks'
names without elaborating anything; :mod:`k37.sim.fpga.export` and :mod:`k37.sim.fpga.synth` build
them. (The first line of this file lets them build a block only to read its signature, without
Amaranth's unused-elaboratable warning.)
"""

from __future__ import annotations

import importlib
import inspect
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

from k37.hdl.board.pins import ulx3s_pins
from k37.hdl.bridge.protocol import DEFAULT_BAUD
from k37.hdl.bus.registers import RegisterMap
from k37.hdl.chipset.identity import chipset_identity
from k37.hdl.common.constants import ALL_AXES, CHIP_HZ

if TYPE_CHECKING:
    from amaranth.lib import wiring

__all__ = ["BLOCKS", "Exportable", "block"]


@dataclass(frozen=True)
class Exportable:
    """One block of the registry: how to build it and which of its ports are chip pins.

    ``factory`` is ``"module:Class"``; ``params`` are constructor arguments (the defaults, the
    paper's values, otherwise); ``top`` marks the chipset top (synthesis reports it as the
    total); ``ice40``: the iCE40 fit check synthesises it (the three-axis builds are the ECP5
    board's); ``cosim``: the co-simulation against a chip's reference model covers it (a block
    made of chips has the system simulation and its own tests instead). The block's own
    ``probes`` name its output ports that are not pins of the chip; its register maps are
    found in its module (every :class:`RegisterMap` there).
    """

    name: str
    factory: str
    title: str
    params: MappingProxyType = field(default_factory=lambda: MappingProxyType({}))
    top: bool = False
    ice40: bool = True
    cosim: bool = True

    def component(self) -> wiring.Component:
        """A new instance of the block."""
        return self._class()(**self.params)

    @property
    def probes(self) -> tuple[str, ...]:
        """The block's observation outputs (the ``probes`` of the instance built with
        ``params``: :class:`k37.hdl.common.observation.Observed`), kept out of the pins."""
        return getattr(self.component(), "probes", ())

    def _module(self):
        return importlib.import_module(self.factory.split(":")[0])

    def _class(self) -> type:
        return getattr(self._module(), self.factory.split(":")[1])

    def parameters(self) -> dict[str, Any]:
        """Every constructor parameter with the value it takes here."""
        from amaranth.lib import wiring

        cls = self._class()
        if cls.__init__ is wiring.Component.__init__:
            return {}
        sig = inspect.signature(cls.__init__)
        return {name: self.params.get(name, p.default) for name, p in sig.parameters.items()
                if name != "self" and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)}

    def chip_selects(self) -> dict[str, tuple[int, RegisterMap]] | None:
        """A chipset top's chips: select and register map of each (its ``chips``)."""
        return getattr(self.component(), "chips", None)

    def register_maps(self) -> list[RegisterMap]:
        """The block's register maps, by chip name: its chips' (a chipset top), its own
        ``regmap`` (a chip built in more than one form), else those defined in or imported by
        its module."""
        component, selects = self.component(), self.chip_selects()
        if selects is not None:
            maps = [m for _, m in selects.values()]
        elif isinstance(getattr(component, "regmap", None), RegisterMap):
            maps = [component.regmap]
        else:
            maps = [v for v in vars(self._module()).values() if isinstance(v, RegisterMap)]
        return sorted({id(m): m for m in maps}.values(), key=lambda rm: rm.chip)


def _params(**kwargs: Any) -> MappingProxyType:
    return MappingProxyType(kwargs)


#: Every exportable block, in the order the files are written; ``top=True`` marks the
#: chipset tops (the two-axis one first: synthesis reports it as the total).
BLOCKS: tuple[Exportable, ...] = (
    Exportable("k3701", "k37.hdl.k3701.chip:K3701", "KM3701 two-axis interpolator"),
    Exportable("k3702", "k37.hdl.k3702.chip:K3702", "KM3702 position controller (one axis)"),
    Exportable("encoder", "k37.hdl.encoder.chip:EncoderInterface", "encoder interface (one axis)"),
    Exportable("accel_decel", "k37.hdl.accel.exponential:AccelDecel",
               "exponential accel/decel, pre-interpolation (FP) form"),
    Exportable("accel_decel_axis", "k37.hdl.accel.exponential:AccelDecel",
               "exponential accel/decel, post-interpolation (signed, one axis) form",
               params=_params(bidirectional=True)),
    Exportable("accel_linear", "k37.hdl.accel.linear:AccelLinear",
               "linear accel/decel (moving average over T), pre-interpolation (FP) form"),
    Exportable("accel_linear_axis", "k37.hdl.accel.linear:AccelLinear",
               "linear accel/decel, post-interpolation (signed, one axis) form",
               params=_params(bidirectional=True)),
    Exportable("accel_bell", "k37.hdl.accel.bell:AccelBell",
               "bell accel/decel (linear then exponential), pre-interpolation (FP) form"),
    Exportable("accel_bell_axis", "k37.hdl.accel.bell:AccelBell",
               "bell accel/decel, post-interpolation (signed, one axis) form",
               params=_params(bidirectional=True)),
    Exportable("rate_multiplier", "k37.hdl.feed.rate_multiplier:RateMultiplier",
               "cascaded SN7497-style binary rate multiplier (feedrate)"),
    Exportable("divider", "k37.hdl.feed.divider:PhaseDivider",
               "phase-accumulator clock-enable divider"),
    Exportable("decel_control", "k37.hdl.feed.decel_control:DecelControl",
               "decel control (FP budget gate)"),
    Exportable("feed_rate", "k37.hdl.feed.feed_rate:FeedRate",
               "feed-rate generator (rate multiplier and its two dividers on the host bus)"),
    Exportable("feed_rate_axis_fa", "k37.hdl.feed.feed_rate:FeedRate",
               "feed-rate generator, per-axis fa build (an addition clock for each axis)",
               params=_params(axis_fa=ALL_AXES)),
    Exportable("chipset", "k37.hdl.chipset.chip:Chipset", "two-axis chipset top", top=True,
               cosim=False),
    Exportable("k3701_3axis", "k37.hdl.k3701.chip:K3701",
               "KM3701 three-axis build (3-D lines, planes, helices, parabolas, exponentials)",
               params=_params(axes=3), ice40=False),
    Exportable("chipset_3axis", "k37.hdl.chipset.chip:Chipset",
               "three-axis chipset top (machine.axes = 3)", params=_params(axes=3), top=True,
               ice40=False, cosim=False),
    Exportable("chipset_wishbone", "k37.hdl.chipset.wishbone:WishboneChipset",
               "two-axis chipset behind an 8-bit Wishbone classic target (for an SoC's bus)",
               ice40=False, cosim=False),
    Exportable("bridge", "k37.hdl.bridge.chip:UartBridge",
               "UART host bridge of the three-axis chipset (the board's, at 125 kBd)",
               params=_params(cycles_per_bit=CHIP_HZ // DEFAULT_BAUD,
                              identity=chipset_identity(axes=3)), ice40=False, cosim=False),
    Exportable("board_ulx3s", "k37.hdl.board.top:BoardTop",
               "ULX3S board top: three-axis chipset, clock enable, UART bridge, sigma-delta D/As",
               params=_params(pins=ulx3s_pins(3)), ice40=False, cosim=False),
)


def block(name: str) -> Exportable:
    """The registry entry called ``name``."""
    for entry in BLOCKS:
        if entry.name == name:
            return entry
    raise ValueError(f"unknown block {name!r}; blocks are {', '.join(b.name for b in BLOCKS)}")
