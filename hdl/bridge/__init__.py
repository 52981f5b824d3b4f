"""The host bridge: a UART to the chipset's 8-bit bus, so that a PC stands where the 8085 stood.

The protocol (:mod:`hdl.bridge.protocol`) and its reference model (:mod:`hdl.bridge.model`)
import without Amaranth; the gateware is :class:`hdl.bridge.chip.UartBridge` (also reachable as
``hdl.bridge.UartBridge``) over the UART of :mod:`hdl.bridge.uart`.
"""

from __future__ import annotations

__all__ = ["UartBridge"]


def __getattr__(name: str) -> object:
    # The gateware is imported on first use, so the protocol and the model stay Amaranth-free.
    if name == "UartBridge":
        from hdl.bridge.chip import UartBridge

        return UartBridge
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
