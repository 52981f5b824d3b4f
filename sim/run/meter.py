"""What a run measures at the firmware's trace points: :class:`BlockMeter`, the logic analyser.

At each block's start and end (:class:`k37.firmware_model.firmware.BlockObserver`) the meter
reads the simulation's observation counters (feed pulses, K3701 step pulses), which no firmware
sees, into a :class:`BlockMeasure` per block.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from k37.firmware_model.firmware import BlockRecord
from k37.hdl.chipset.map import AXES
from k37.sim.run.sampler import Sampler

__all__ = ["BlockMeasure", "BlockMeter"]


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
