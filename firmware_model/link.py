"""What an 8085 sees of the chipset: its I/O bus, its interrupt inputs and the clock.

:class:`ChipsetLink` is the whole contract between the host firmware and the hardware it
drives (Glasgow's split of an abstract interface and its implementations): a bus write or
read at an 8-bit port address, time passing with no bus activity, waiting for an interrupt,
and the levels of the interrupt inputs (what the 8085's RIM instruction reads). Time is
counted in system clock cycles. The firmware model uses nothing else, so it runs unchanged
on any implementation: the simulated machine (:class:`k37.sim.link.simulated.SimulatedLink`),
a board behind the host bridge (:class:`k37.sim.link.bridge.BridgeLink`) or a test double. """

from __future__ import annotations

from typing import NamedTuple, Protocol

__all__ = ["ChipsetLink", "Interrupts"]


class Interrupts(NamedTuple):
    """Levels of the 8085's interrupt inputs the chipset drives."""

    #: RST 7.5: the K3701's data request (its block ended).
    interp: bool
    #: RST 6.5: either K3702's alarm.
    alarm: bool

    def any(self) -> bool:
        return self.interp or self.alarm


class ChipsetLink(Protocol):
    """The 8085's pins towards the chipset, in system clock cycles."""

    @property
    def cycle(self) -> int:
        """System clock cycles since reset."""

    def idle(self, cycles: int) -> None:
        """Let ``cycles`` cycles pass with no bus activity."""

    def write(self, address: int, data: int) -> None:
        """One bus write cycle (one system cycle) of byte ``data`` to port ``address``."""

    def read(self, address: int) -> int:
        """One bus read cycle (one system cycle) of port ``address``: the byte read."""

    def wait_interrupt(self, max_cycles: int) -> int:
        """Let cycles pass until an interrupt input is high after one, at most ``max_cycles``
        (at least one, if ``max_cycles`` > 0); the cycles that passed."""

    def interrupts(self) -> Interrupts:
        """The interrupt inputs' levels now."""

    # Optional: ``wait_polling(max_cycles, period, ports, stops, idles, due)``, a halted wait with a
    # read-only timer routine that the link runs itself, as
    # :meth:`k37.firmware_model.host.Host8085.wait_polling` would with the operations above
    # (see :meth:`k37.sim.backends.contract.Backend.wait_polling`); the host looks it up with
    # getattr and uses its own loop where a link has none or it returns None.
