"""The ULX3S board (Lattice ECP5): the board top on its pins, through amaranth-boards.

Needs the ``fpga`` extra (``amaranth-boards``). :func:`platform` gives the board's Amaranth
platform with the expansion-connector pins of :func:`k37.hdl.board.pins.ulx3s_pins` added;
:class:`OnBoard` is the elaboratable its ``prepare``/``build`` takes.
"""

from __future__ import annotations

from amaranth.build import Attrs, Pins, Resource
from amaranth.hdl import ClockDomain, Elaboratable, Module
from amaranth.lib import io
from amaranth.lib.cdc import ResetSynchronizer
from amaranth_boards.ulx3s import ULX3S_25F_Platform, ULX3S_85F_Platform

from k37.hdl.board.pins import BoardPin, ulx3s_pins
from k37.hdl.board.top import BoardTop

__all__ = ["PLATFORMS", "OnBoard", "platform"]

#: The ULX3S variants by part.
PLATFORMS = {"ulx3s-25f": ULX3S_25F_Platform, "ulx3s-85f": ULX3S_85F_Platform}


def _resource(pin: BoardPin) -> tuple[str, int]:
    return pin.resource or (f"k37_{pin.signal}", 0)


def platform(board: str, axes: int = 3):
    """The Amaranth platform of ``board`` (a key of :data:`PLATFORMS`) with the connector
    pins of an ``axes``-axis top added (3.3 V; inputs pulled up)."""
    if board not in PLATFORMS:
        raise ValueError(f"board must be one of {', '.join(PLATFORMS)}, not {board!r}")
    plat = PLATFORMS[board]()
    plat.add_resources([
        Resource(_resource(pin)[0], 0, Pins(pin.connector_pin, dir=pin.direction,
                                            conn=("gpio", 0)),
                 Attrs(IO_TYPE="LVCMOS33", **({"PULLMODE": "DOWN" if pin.pull_down else "UP"}
                                               if pin.direction == "i" else {})))
        for pin in ulx3s_pins(axes) if pin.connector_pin is not None])
    return plat


class OnBoard(Elaboratable):
    """A :class:`~k37.hdl.board.top.BoardTop` of the ULX3S's pins, each port on its pin.

    The ``sync`` domain runs from the board's 25 MHz oscillator; the ``reset`` pin (a button)
    resets it through a :class:`~amaranth.lib.cdc.ResetSynchronizer` (asserted at once,
    released two clock edges after the button).
    """

    def __init__(self, axes: int = 3, **params):
        self.pins = ulx3s_pins(axes)
        self.top = BoardTop(self.pins, axes=axes, **params)

    def elaborate(self, platform) -> Module:
        if platform.default_clk_frequency != self.top.core.clock_hz:
            raise ValueError(f"the board clock is {platform.default_clk_frequency:g} Hz, the "
                             f"top's {self.top.core.clock_hz} Hz")
        m = Module()
        requested = {}

        def buffer(name: str, direction: str, key: tuple[str, int]) -> io.Buffer:
            res = requested.get(key) or requested.setdefault(
                key, platform.request(*key, dir="-"))
            if key == ("uart", 0):
                res = res.rx if direction == "i" else res.tx
            m.submodules[f"{name}_buffer"] = buf = io.Buffer(direction, res)
            return buf

        m.domains.sync = sync = ClockDomain()
        clk = buffer("clk", "i", (platform.default_clk, 0))
        m.d.comb += sync.clk.eq(clk.i)
        m.submodules.top = top = self.top
        for pin in self.pins:
            buf = buffer(pin.signal, pin.direction, _resource(pin))
            if pin.signal == "reset":
                m.submodules.reset_sync = ResetSynchronizer(buf.i, domain="sync")
            elif pin.direction == "i":
                m.d.comb += getattr(top, pin.signal).eq(buf.i)
            else:
                m.d.comb += buf.o.eq(getattr(top, pin.signal))
        return m
