"""Reference model of :class:`k37.hdl.k3701.latency.StepLatency`, the K3701's step latency count.

The count holds a step between the FP that completes its credit and its pulses: loaded with
``L - 1`` (``L`` the running type's latency), it goes down by one per cycle, and the cycles on
the way time the datapath's decision stages (``L - 1 - s`` for stage ``s``) and the step
itself (1, ``advance``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from k37.hdl.common.params import positive_int

__all__ = ["LatencyOutputs", "StepLatencyModel", "check_params"]


def check_params(latencies: Sequence[int], stages: Sequence[int]) -> None:
    """Refuse latencies and stage counts the count cannot time, naming the value."""
    if len(latencies) != len(stages) or not latencies:
        raise ValueError(f"one stage count per latency, not {len(stages)} for "
                         f"{len(latencies)} latencies")
    for latency, count in zip(latencies, stages, strict=True):
        positive_int("a latency", latency, 2)
        positive_int("a stage count", count, 0)
        if latency < 2 + count:  # the stages come before advance (DatapathSignature)
            raise ValueError(f"a latency of {latency} cycles has no room for {count} stages "
                             f"before its step (at least {2 + count})")


@dataclass(frozen=True)
class LatencyOutputs:
    """The combinational outputs of one cycle."""
    zero: bool
    last: bool
    advance: tuple[bool, ...]
    stage: tuple[int, ...]


class StepLatencyModel:
    """The count and its strobes, cycle by cycle."""

    def __init__(self, latencies: Sequence[int], stages: Sequence[int]):
        check_params(latencies, stages)
        self.latencies = tuple(latencies)
        self.stages = tuple(stages)
        self.count = 0

    def outputs(self, running: Sequence[bool]) -> LatencyOutputs:
        """What the count shows in this cycle, with ``running[i]`` for datapath i."""
        last = self.count == 1
        return LatencyOutputs(
            zero=self.count == 0, last=last,
            advance=tuple(bool(r) and last for r in running),
            stage=tuple(sum(1 << s for s in range(n) if r and self.count == latency - 1 - s)
                        for r, latency, n in zip(running, self.latencies, self.stages,
                                                 strict=True)))

    def step(self, *, clear: bool = False, load: bool = False, value: int = 0,
             run: bool = False) -> None:
        """The clock edge ending the cycle: ``clear`` before ``load`` before the decrement."""
        if clear:
            self.count = 0
        elif load:
            self.count = value
        elif run and self.count:
            self.count -= 1
