"""The board's pin map: which board pin carries which chipset signal (no Amaranth here).

The one source of the pin map: :mod:`k37.hdl.board.ulx3s` requests these pins from the board's
Amaranth platform, ``k37 build`` writes them with their FPGA balls next to the bitstream and
the manual's pin table (``docs/guide/fpga.md``) is made from them.
"""

from __future__ import annotations

from dataclasses import dataclass

from k37.hdl.chipset.map import axis_names

__all__ = ["BoardPin", "ulx3s_pins"]


@dataclass(frozen=True)
class BoardPin:
    """One pin of the board's top.

    ``signal`` is the top's name for it, ``direction`` ``"i"`` (into the FPGA) or ``"o"``;
    the pin is either on the board's expansion connector (``connector_pin``, the Amaranth
    platform's name on connector ``gpio`` 0, e.g. ``"0+"``) or one of the platform's own
    resources (``resource``: name and number, e.g. ``("led", 0)``); ``label`` is the board's
    silkscreen name; an input is pulled up unless ``pull_down`` (a fail-safe input that reads
    active, low, when its wire is cut).
    """

    signal: str
    direction: str
    label: str
    doc: str
    connector_pin: str | None = None
    resource: tuple[str, int] | None = None
    pull_down: bool = False


def ulx3s_pins(axes: int = 3) -> tuple[BoardPin, ...]:
    """The ULX3S's pins of an ``axes``-axis chipset, host link first."""
    out = [
        BoardPin("uart_rx", "i", "US1 (USB)", "Host bridge: serial data from the host, 8N1, "
                 "through the board's FTDI USB serial port", resource=("uart", 0)),
        BoardPin("uart_tx", "o", "US1 (USB)", "Host bridge: serial data to the host",
                 resource=("uart", 0)),
        BoardPin("reset", "i", "BTN1 (F1)", "Resets the chipset and the bridge while held",
                 resource=("button_fire", 0)),
    ]
    out += [
        BoardPin("estop_n", "i", "GP3", "E-stop, active low: the E-stop chain's normally closed "
                 "contacts to 3.3 V; open (or a cut wire) stops the drives", connector_pin="3+",
                 pull_down=True),
        BoardPin("drive_enable", "o", "GN3", "Drive-enable (servo-on) of every axis: low on a "
                 "watchdog trip or E-stop", connector_pin="3-"),
    ]
    for k, axis in enumerate(axis_names(axes)):
        up = axis.upper()
        out += [
            BoardPin(f"{axis}_a", "i", f"GP{k}", f"{up} encoder line A (3.3 V, pulled up)",
                     connector_pin=f"{k}+"),
            BoardPin(f"{axis}_b", "i", f"GN{k}", f"{up} encoder line B (3.3 V, pulled up)",
                     connector_pin=f"{k}-"),
            BoardPin(f"{axis}_dac", "o", f"GP{4 + k}", f"{up} D/A: sigma-delta stream of the "
                     f"K3702's 16-bit word at 25 MHz (RC low pass to the drive)",
                     connector_pin=f"{4 + k}+"),
            BoardPin(f"{axis}_alarm", "o", f"LED D{k}", f"{up} ALARM: lit on alarm",
                     resource=("led", k)),
            BoardPin(f"{axis}_limit_n", "i", f"GN{4 + k}", f"{up} limit, active low: the "
                     f"limit switches' normally closed contacts to 3.3 V; open holds the feed",
                     connector_pin=f"{4 + k}-", pull_down=True),
        ]
    return (*out,
            BoardPin("irq_interp", "o", "LED D6", "K3701 data request (lit while pending)",
                     resource=("led", 6)),
            BoardPin("irq_alarm", "o", "LED D7", "Alarm interrupt (any axis)",
                     resource=("led", 7)))
