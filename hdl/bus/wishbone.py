"""The chips' host bus behind a Wishbone classic (B4) target: the chips on an SoC's bus.

:class:`WishboneBus` is an 8-bit Wishbone classic bus with byte granularity, its members named
and directed as ``amaranth_soc.wishbone.Signature(addr_width=..., data_width=8,
granularity=8)``'s (no optional features), so ``wiring.connect`` joins it to an amaranth-soc
initiator or decoder. :class:`WishboneTarget` turns its cycles into the chips' one-byte
:class:`~k37.hdl.bus.hostbus.HostBus` accesses: the host bus's register semantics (the last byte
of a register commits it, reading byte 0 snapshots it) are the chips' own, unchanged.
"""

from __future__ import annotations

from amaranth.hdl import Module, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from k37.hdl.bus.hostbus import HostBus

__all__ = ["WishboneBus", "WishboneTarget"]


class WishboneBus(wiring.Signature):
    """An 8-bit Wishbone classic bus, initiator's view (the names of amaranth-soc's).

    Members
    -------
    adr : Out(addr_width)
        Address of the byte.
    dat_w : Out(8)
        Write data.
    dat_r : In(8)
        Read data, valid in the cycle ``ack`` is high.
    sel : Out(1)
        Byte select (one byte lane; a cycle with it low transfers nothing but is acknowledged).
    cyc : Out(1)
        Bus cycle in progress.
    stb : Out(1)
        Strobe: a transfer is requested.
    we : Out(1)
        Write enable: the transfer is a write.
    ack : In(1)
        Acknowledge: the transfer ends at the clock edge that ends this cycle.
    """

    def __init__(self, addr_width: int):
        if not isinstance(addr_width, int) or addr_width < 1:
            raise TypeError(f"addr_width must be a positive integer, not {addr_width!r}")
        self.addr_width = addr_width
        super().__init__({
            "adr": Out(addr_width), "dat_w": Out(8), "dat_r": In(8), "sel": Out(1),
            "cyc": Out(1), "stb": Out(1), "we": Out(1), "ack": In(1),
        })

    def __eq__(self, other: object) -> bool:
        return isinstance(other, WishboneBus) and other.addr_width == self.addr_width

    def __hash__(self) -> int:
        return hash(("WishboneBus", self.addr_width))

    def __repr__(self) -> str:
        return f"WishboneBus({self.addr_width})"


class WishboneTarget(wiring.Component):
    """A Wishbone classic target that makes each transfer one host-bus access.

    A transfer requested in cycle *t* (``cyc``, ``stb`` and ``sel`` high, ``ack`` low) is the
    host-bus access of cycle *t* (``w_stb`` or ``r_stb`` for that one cycle); ``ack`` is high
    in cycle *t* + 1, with a read's byte on ``dat_r`` (the chips show it then). Every transfer
    takes two cycles, an initiator that keeps ``stb`` high starting the next one in *t* + 2; a
    transfer is never made twice. A transfer with ``sel`` low is acknowledged without an
    access. An initiator that drops ``cyc`` or ``stb`` in cycle *t* + 1 sees no ``ack`` (the
    access of cycle *t* is made all the same).

    Parameters
    ----------
    addr_width : int
        Width of the address (the chips' bus's).

    Members
    -------
    wb : In(WishboneBus(addr_width))
        The Wishbone bus, target side.
    bus : Out(HostBus(addr_width))
        The chips' host bus, initiator side.
    """

    def __init__(self, addr_width: int):
        super().__init__({"wb": In(WishboneBus(addr_width)), "bus": Out(HostBus(addr_width))})

    def elaborate(self, platform) -> Module:
        m = Module()
        wb, bus = self.wb, self.bus
        ack = Signal()
        request = wb.cyc & wb.stb & ~ack
        access = request & wb.sel
        m.d.sync += ack.eq(request)
        m.d.comb += [
            wb.ack.eq(ack & wb.cyc & wb.stb),
            wb.dat_r.eq(bus.r_data),
            bus.addr.eq(wb.adr),
            bus.w_data.eq(wb.dat_w),
            bus.w_stb.eq(access & wb.we),
            bus.r_stb.eq(access & ~wb.we),
        ]
        return m
