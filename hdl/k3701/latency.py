"""The K3701's step latency count and the strobes it times (``docs/chips/k3701.md``).

The reference model is :class:`k37.hdl.k3701.model.latency.StepLatencyModel`.
"""

from __future__ import annotations

from collections.abc import Sequence

from amaranth.hdl import Const, Module, Mux
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from k37.hdl.k3701.model.latency import check_params

__all__ = ["StepLatency"]


class StepLatency(wiring.Component):
    """The count between a step's FP and its pulses, and the datapaths' strobes from it.

    A block of its own so that a compiled simulation evaluates what reads the strobes only
    when one changes, not at each decrement of the count (CXXRTL's parts follow the module
    hierarchy, see :func:`k37.sim.backends.cxxrtl.rise.rise_eval`).

    Parameters
    ----------
    latencies : sequence of int
        Per datapath, its latency L in cycles (FP to pulses), at least 2 + its stages.
    stages : sequence of int
        Per datapath, its decision stages (``Datapath.STAGES``).

    Members
    -------
    clear, load : In(1)
        At the edge ending the cycle, ``count`` takes 0 with ``clear``, else ``value`` with
        ``load``.
    value : In(range(max(latencies)))
        The count loaded (L - 1 of the running type).
    run : In(1)
        Otherwise, while ``run``, a non-zero ``count`` goes down by one at the edge.
    running : In(1).array(len(latencies))
        Datapath i's block runs: enables its strobes.
    count : Out(range(max(latencies)))
        The count (a register).
    zero, last : Out(1)
        ``count`` is 0, 1: combinational, in the same cycle.
    advance : Out(1).array(len(latencies))
        ``running[i]`` and ``last``: combinational.
    stage : Out(max(stages)).array(len(latencies))
        Bit s of ``stage[i]``: ``running[i]`` and ``count`` is ``latencies[i] - 1 - s``
        (the cycle after a load is stage 0): combinational.
    """

    def __init__(self, latencies: Sequence[int], stages: Sequence[int]):
        check_params(latencies, stages)
        self.latencies = tuple(latencies)
        self.stages = tuple(stages)
        size = range(max(self.latencies))
        n = len(self.latencies)
        super().__init__({"clear": In(1), "load": In(1), "value": In(size), "run": In(1),
                          "running": In(1).array(n), "count": Out(size), "zero": Out(1),
                          "last": Out(1), "advance": Out(1).array(n),
                          "stage": Out(max(self.stages)).array(n)})

    def elaborate(self, platform) -> Module:
        m = Module()
        with m.If(self.clear):
            m.d.sync += self.count.eq(0)
        with m.Elif(self.load):
            m.d.sync += self.count.eq(self.value)
        with m.Elif(self.run & ~self.zero):
            m.d.sync += self.count.eq(self.count - 1)
        m.d.comb += [self.zero.eq(self.count == 0), self.last.eq(self.count == 1)]
        for i, (latency, stages) in enumerate(zip(self.latencies, self.stages, strict=True)):
            # Bit s of 2^(L - 1) >> count is set when count is L - 1 - s: one shift decodes
            # every stage (a compiled simulation evaluates one statement, not one per stage).
            window = (Const(1 << (latency - 1), latency) >> self.count)[:stages]
            m.d.comb += [self.advance[i].eq(self.running[i] & self.last),
                         self.stage[i].eq(Mux(self.running[i], window, 0))]
        return m
