"""The host bridge: a UART to the chipset's 8-bit bus, so that a PC stands where the 8085 stood.

The protocol (:mod:`k37.hdl.bridge.protocol`) and its reference model (:mod:`k37.hdl.bridge.model`)
import without Amaranth; the gateware is :class:`k37.hdl.bridge.chip.UartBridge` (also reachable as
``k37.hdl.bridge.UartBridge``) over the UART of :mod:`k37.hdl.bridge.uart`.
"""

from __future__ import annotations

__all__ = ["UartBridge"]


def __getattr__(name: str) -> object:
    # The gateware is imported on first use, so the protocol and the model stay Amaranth-free.
    if name == "UartBridge":
        from k37.hdl.bridge.chip import UartBridge

        return UartBridge
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
