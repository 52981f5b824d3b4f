# amaranth: UnusedElaboratable=no
"""The chipset as a Wishbone target: the chips on an SoC's bus, at the addresses of their map.

The Wishbone address is the chipset's host-bus address: the 8085 I/O port of
:func:`k37.hdl.chipset.map.port` (chip select << 5 | register address), one byte per address,
so a CPU's driver uses the register maps and their byte order unchanged. (The first line of this
file lets the wrapper be built for its signature alone, without Amaranth's unused-elaboratable
warning for the chipset it holds.)
"""

from __future__ import annotations

from amaranth.hdl import Module
from amaranth.lib import wiring
from amaranth.lib.wiring import In, connect, flipped

from k37.hdl.bus.registers import RegisterMap
from k37.hdl.bus.wishbone import WishboneBus, WishboneTarget
from k37.hdl.chipset.chip import Chipset

__all__ = ["WishboneChipset"]


class WishboneChipset(wiring.Component):
    """A :class:`~k37.hdl.chipset.chip.Chipset` behind a
    :class:`~k37.hdl.bus.wishbone.WishboneTarget`: every port of the chipset but its host bus,
    and an 8-bit Wishbone classic bus in its place.

    Each register byte is one Wishbone transfer of two cycles (the access in the first, the
    acknowledge with a read's byte in the second); the chipset runs on the bus's clock, which
    stands for the paper's 1 MHz (its rates and latencies count its cycles).

    Parameters
    ----------
    axes : int
        2 or 3.
    **chipset : dict
        The chipset's other parameters (``accel``, ``accel_shape``...).

    Members
    -------
    wb : In(WishboneBus(8))
        The Wishbone bus; address = chip select (3 bits) and register (5 bits).
    irq_interp : Out(1)
        K3701 data request.
    irq_alarm : Out(1)
        Either K3702's alarm interrupt.
    x, y : Out(AxisPins())
        The axes (and ``z`` on three axes), as :class:`~k37.hdl.chipset.chip.Chipset`'s.
    """

    def __init__(self, axes: int = 2, **chipset):
        #: The chipset inside (its probes are observable in simulation).
        self.chipset = Chipset(axes=axes, **chipset)
        members = dict(self.chipset.signature.members)
        del members["bus"]
        super().__init__({"wb": In(WishboneBus(8)), **members})

    @property
    def chips(self) -> dict[str, tuple[int, RegisterMap]]:
        """The chip select and register map of each chip (the chipset's)."""
        return self.chipset.chips

    @property
    def probes(self) -> tuple[str, ...]:
        """The chipset's observation outputs, not pins."""
        return self.chipset.probes

    def elaborate(self, platform) -> Module:
        m = Module()
        m.submodules.chipset = chipset = self.chipset
        m.submodules.target = target = WishboneTarget(8)
        connect(m, flipped(self.wb), target.wb)
        connect(m, target.bus, chipset.bus)
        for name, member in self.signature.members.items():
            if name == "wb":
                continue
            if member.is_signature:
                connect(m, flipped(getattr(self, name)), getattr(chipset, name))
            else:
                m.d.comb += getattr(self, name).eq(getattr(chipset, name))
        return m
