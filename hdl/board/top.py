# amaranth: UnusedElaboratable=no
"""The board's top, any board: the chipset, its clock enable and the UART host bridge.

Its ports are the board pins of :mod:`k37.hdl.board.pins`, by name; :mod:`k37.hdl.board.ulx3s` puts
them on a board's balls. (The first line of this file lets a top be built for its ports alone,
without Amaranth's unused-elaboratable warning for the core and bridge it holds.)
"""

from __future__ import annotations

from amaranth.hdl import EnableInserter, Module
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out, connect

from k37.hdl.board.core import BoardCore
from k37.hdl.board.pins import BoardPin
from k37.hdl.bridge import UartBridge
from k37.hdl.bridge.protocol import DEFAULT_BAUD
from k37.hdl.chipset.identity import chipset_identity
from k37.hdl.common.constants import CHIP_HZ

__all__ = ["BoardTop"]

#: The core's ports the bridge drives or that stay inside, no board pins.
_INNER = {"bus", "feed", "tick"}


class BoardTop(wiring.Component):
    """A :class:`~k37.hdl.board.core.BoardCore` driven by a :class:`~k37.hdl.bridge.UartBridge`.

    The bridge runs under the core's clock enable, like the chipset: its UART bit time is
    ``CHIP_HZ / baud`` chipset cycles, and it drives the chipset's bus one byte access per
    chipset cycle, as the 8085 did; each whole frame it takes feeds the board's watchdog.
    The ``sync`` domain's reset resets the chipset, the bridge and the clock enable.

    Parameters
    ----------
    pins : tuple of BoardPin
        The board's pins (:func:`k37.hdl.board.pins.ulx3s_pins`): the ports, by ``signal``,
        but for ``reset`` (the board's wrapper makes it the domain's reset).
    axes : int
        The chipset's axes, 2 or 3.
    clock_hz : int
        The board clock (:class:`~k37.hdl.board.core.BoardCore`).
    baud : int
        The host link's bit rate; ``CHIP_HZ`` must be a multiple of it.
    **chipset : dict
        The chipset's other parameters (``accel``...); the bridge's IDENT reply tells them
        (:func:`k37.hdl.chipset.identity.chipset_identity`).

    Members
    -------
    <signal> : In(1) or Out(1)
        One per board pin; timings as :class:`~k37.hdl.board.core.BoardCore`'s ports
        (``uart_rx`` and ``uart_tx`` are the bridge's ``rx`` and ``tx``).
    """

    def __init__(self, pins: tuple[BoardPin, ...], *, axes: int = 3,
                 clock_hz: int = 25_000_000, baud: int = DEFAULT_BAUD, **chipset):
        if not isinstance(baud, int) or baud <= 0 or CHIP_HZ % baud:
            raise ValueError(f"baud must divide {CHIP_HZ} (the chipset clock), not {baud!r}")
        self.core = BoardCore(axes=axes, clock_hz=clock_hz, **chipset)
        self.bridge = UartBridge(CHIP_HZ // baud, chipset_identity(axes=axes, **chipset))
        self.pins = pins
        ports = {*self.core.signature.members, "uart_rx", "uart_tx"} - _INNER
        pins = tuple(pin for pin in pins if pin.signal != "reset")
        names = {pin.signal for pin in pins}
        if names != ports:
            raise ValueError(f"pins must be exactly {sorted(ports)}; missing "
                             f"{sorted(ports - names)}, unknown {sorted(names - ports)}")
        # a fail-safe input idles released (high) in simulation, as when its contacts are closed
        super().__init__({pin.signal: In(1, init=int(pin.pull_down)) if pin.direction == "i"
                          else Out(1) for pin in pins})

    def elaborate(self, platform) -> Module:
        m = Module()
        core, bridge = self.core, self.bridge
        m.submodules.core = core
        m.submodules.bridge = EnableInserter(core.tick)(bridge)
        connect(m, bridge.bus, core.bus)
        m.d.comb += [bridge.irq_interp.eq(core.irq_interp), bridge.irq_alarm.eq(core.irq_alarm),
                     core.feed.eq(bridge.frame),
                     bridge.rx.eq(self.uart_rx), self.uart_tx.eq(bridge.tx)]
        for name in core.signature.members:
            if name in _INNER:
                continue
            port, inner = getattr(self, name), getattr(core, name)
            flow = core.signature.members[name].flow
            m.d.comb += inner.eq(port) if flow is wiring.In else port.eq(inner)
        return m
