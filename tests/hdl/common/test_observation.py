"""Each block declares its own simulation-only state; the simulation top composes them into
paths that name real registers of the design."""

from __future__ import annotations

import pytest
from amaranth.hdl import Fragment

from k37.hdl.chipset.map import Accel
from k37.hdl.common.observation import (
    CarryAccumulator,
    Countdown,
    FreeRunning,
    PhaseAccumulator,
    PlantState,
    StrobeCounter,
)
from k37.sim.backends.introspect import signal_paths
from k37.sim.machine.system import System


def design_signals(component) -> set[str]:
    """Every signal of the elaborated design, by its dotted path below the top."""
    return set(signal_paths(Fragment.get(component, None).prepare()))


def test_a_declaration_seen_from_a_parent_is_prefixed_with_the_instance_name():
    child = FreeRunning(
        accumulators=(PhaseAccumulator("clk", 24),),
        counters=(StrobeCounter("rate", 18, clock="clk", gate="gate"),),
        carries=(CarryAccumulator("acc", 15, False),),
        plants=(PlantState("", 37, 24, 32),),
        countdowns=(Countdown("count", stop=1),), quiet="quiet")
    seen = child.under("chip")
    assert seen.accumulators[0].path == "chip.clk"
    assert seen.counters[0] == StrobeCounter("chip.rate", 18, clock="chip.clk", gate="chip.gate")
    assert seen.carries[0] == CarryAccumulator("chip.acc", 15, False, clock=None)
    assert seen.plants[0].path == "chip"
    assert seen.countdowns[0] == Countdown("chip.count", stop=1)
    assert seen.quiet == "chip.quiet"


def test_merged_declarations_keep_every_part_and_take_the_parents_quiet():
    a = FreeRunning(accumulators=(PhaseAccumulator("a", 8),), quiet="a.quiet")
    b = FreeRunning(countdowns=(Countdown("b", stop=1),), quiet="b.quiet")
    merged = a.merge(b, quiet="quiet")
    assert merged.accumulators == a.accumulators and merged.countdowns == b.countdowns
    assert merged.quiet == "quiet"


@pytest.mark.parametrize("accel", list(Accel))
def test_the_machine_declares_the_registers_that_run_on_by_themselves(accel):
    system = System(accel=accel, accel_bits=9)
    free = system.free_running
    carries = {Accel.PRE: ["chipset.accel"], Accel.POST: ["chipset.accel_x", "chipset.accel_y"],
               Accel.NONE: []}[accel]
    assert [a.path for a in free.accumulators] == ["chipset.feed.rm_clock",
                                                   "chipset.feed.fa_clock"]
    assert free.counters == (StrobeCounter("chipset.feed.rate", 18, clock="chipset.feed.rm_clock",
                                           gate="chipset.decel.gate_open"),)
    assert free.carries == tuple(CarryAccumulator(path, 9, accel is Accel.POST,
                                                  clock="chipset.feed.fa_clock")
                                 for path in carries)
    assert [p.path for p in free.plants] == ["plant_x", "plant_y"]
    assert free.countdowns == (Countdown("chipset.k3701.latency.count", stop=1),)
    assert free.quiet == "quiet"
    # Every declared register and signal is a signal of the design, by that path.
    signals = design_signals(system)
    named = {*free.registers(), free.quiet, "chipset.decel.gate_open",
             *(f"{a.path}.increment" for a in free.accumulators),
             *(f"{c.path}.{n}" for c in free.counters for n in ("word",)),
             *(f"{c.path}.x" for c in free.carries),
             *(f"{p.path}.{n}" for p in free.plants
               for n in ("dac", "dac_zero", "gain", "alpha", "vmax", "stall"))}
    assert named - signals == set()
