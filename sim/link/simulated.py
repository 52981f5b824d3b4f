"""The simulated machine as the 8085 sees it: :class:`SimulatedLink` implements
:class:`k37.firmware_model.link.ChipsetLink` over a sampled backend (:class:`SampledMachine`,
as :class:`k37.sim.run.sampler.Sampler` samples one as it runs) or a bare backend: the bus, the
two interrupt inputs and the clock, nothing else. """

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

from k37.firmware_model.link import Interrupts
from k37.sim.backends.contract import Backend

__all__ = ["SampledMachine", "SimulatedLink"]


class SampledMachine(Protocol):
    """A backend seen through a sampler (:class:`k37.sim.run.sampler.Sampler`): what the link
    uses of it."""

    @property
    def cycle(self) -> int: ...

    def step(self, n: int = 1) -> None: ...

    def run_until(self, port_name: str, max_cycles: int) -> int: ...

    def get(self, name: str) -> int: ...

    def bus_write(self, addr: int, data: int) -> None: ...

    def bus_read(self, addr: int) -> int: ...

    def wait_polling(self, max_cycles: int, period: int, ports: Sequence[int],
                     stops: Sequence[int], idles: Sequence[int],
                     due: bool) -> tuple[int, list[int] | None, int] | None: ...


class SimulatedLink:
    """:class:`k37.firmware_model.link.ChipsetLink` on the simulated machine's bus and IRQ ports."""

    def __init__(self, sampler: SampledMachine | Backend):
        self.sampler = sampler

    @property
    def cycle(self) -> int:
        return self.sampler.cycle

    def idle(self, cycles: int) -> None:
        self.sampler.step(cycles)

    def write(self, address: int, data: int) -> None:
        self.sampler.bus_write(address, data)

    def read(self, address: int) -> int:
        return self.sampler.bus_read(address)

    def wait_interrupt(self, max_cycles: int) -> int:
        return self.sampler.run_until("irq", max_cycles)

    def wait_polling(self, max_cycles: int, period: int, ports: Sequence[int],
                     stops: Sequence[int], idles: Sequence[int],
                     due: bool) -> tuple[int, list[int] | None, int] | None:
        if not isinstance(self.sampler, Backend):
            return self.sampler.wait_polling(max_cycles, period, ports, stops, idles, due)
        return self.sampler.wait_polling("irq", max_cycles, max_cycles, period, ports, stops,
                                         idles, due=due)

    def interrupts(self) -> Interrupts:
        return Interrupts(bool(self.sampler.get("irq_interp")),
                          bool(self.sampler.get("irq_alarm")))
