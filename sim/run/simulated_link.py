"""The simulated machine as the 8085 sees it, and what the run measures at the firmware's
trace points.

:class:`SimulatedLink` implements :class:`k37.firmware_model.link.ChipsetLink` over a
:class:`k37.sim.run.sampler.Sampler` (a backend sampled as it runs) or a bare backend: the bus, the
two interrupt inputs and the clock, nothing else. :class:`BlockMeter` is the logic analyser: at each
block's start and end (:class:`k37.firmware_model.firmware.BlockObserver`) it reads the simulation's
observation counters (feed pulses, K3701 step pulses), which no firmware sees. """

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

from k37.firmware_model.firmware import BlockRecord
from k37.firmware_model.link import Interrupts
from k37.hdl.chipset.map import AXES
from k37.sim.backends.contract import Backend
from k37.sim.run.sampler import Sampler

__all__ = ["BlockMeasure", "BlockMeter", "SimulatedLink"]


class SimulatedLink:
    """:class:`k37.firmware_model.link.ChipsetLink` on the simulated machine's bus and IRQ ports."""

    def __init__(self, sampler: Sampler | Backend):
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
        if isinstance(self.sampler, Sampler):
            return self.sampler.wait_polling(max_cycles, period, ports, stops, idles, due)
        return self.sampler.wait_polling("irq", max_cycles, max_cycles, period, ports, stops,
                                         idles, due=due)

    def interrupts(self) -> Interrupts:
        return Interrupts(bool(self.sampler.get("irq_interp")),
                          bool(self.sampler.get("irq_alarm")))


def _pulses(axes: tuple[str, ...]) -> dict[str, str]:
    """The step-pulse counters of each axis, by the report's names."""
    return {f"{axis}{sign}": f"{axis}__pulses_{name}"
            for axis in axes for sign, name in (("+", "pos"), ("-", "neg"))}


@dataclass
class BlockMeasure:
    """What the run measured of one block: FP the K3701 received, its step pulses per axis
    and direction, and the interpolated end position those pulses make."""

    fp_pulses: int = 0
    steps: dict[str, int] = field(default_factory=lambda: dict.fromkeys(_pulses(AXES), 0))
    end_command: tuple[int, ...] | None = None


class BlockMeter:
    """Reads the observation counters at the firmware's block trace points, on a machine
    with ``axes``."""

    def __init__(self, sampler: Sampler, axes: tuple[str, ...] = AXES):
        self.sampler = sampler
        self.axes = axes
        self._pulses = _pulses(axes)
        self.measures: dict[int, BlockMeasure] = {}
        self._marks: dict[str, int] = {}
        self._running: int | None = None  # the index of the block started and not ended

    def _counters(self) -> dict[str, int]:
        return {"fp": self.sampler.get("fp_total"),
                **{key: self.sampler.get(port) for key, port in self._pulses.items()}}

    def block_started(self, record: BlockRecord) -> None:
        self._marks = self._counters()
        self.measures[record.index] = BlockMeasure()
        self._running = record.index

    def block_ended(self, record: BlockRecord) -> None:
        now = self._counters()
        delta = {key: now[key] - self._marks[key] for key in now}
        steps = {key: delta[key] for key in self._pulses}
        self.measures[record.index] = BlockMeasure(
            delta["fp"], steps,
            tuple(now[f"{axis}+"] - now[f"{axis}-"] for axis in self.axes))
        self._running = None

    def done(self, index: int, fp: int) -> float:
        """The part of block ``index`` (``fp`` FP planned) done: the FP received so far over
        ``fp`` while it runs; 0 before it started, 1 once it ended."""
        if self._running != index:
            return 1.0 if index in self.measures else 0.0
        return (self.sampler.get("fp_total") - self._marks["fp"]) / fp if fp else 1.0

    def of(self, record: BlockRecord) -> BlockMeasure:
        """The measure of a block the firmware ran (zeros if it never ended)."""
        return self.measures.get(
            record.index, BlockMeasure(steps=dict.fromkeys(self._pulses, 0)))
