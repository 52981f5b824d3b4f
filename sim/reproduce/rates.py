"""Experiment 2: the K3701's maximum step rates at a 1 MHz clock (section 2 (1)).

Measured on the gateware inside the post machine with the feed path wide open (the
:class:`~k37.sim.reproduce.runs.RateSpec` run), against the paper's 90.0 and 47.6 K/sec.
"""

from __future__ import annotations

from k37.sim.reproduce.markdown import Section
from k37.sim.reproduce.paper import PAPER_RATE_CIRCULAR, PAPER_RATE_LINEAR
from k37.sim.reproduce.runs import MACHINE, RunData, Specs

__all__ = ["section"]


def section(runs: dict[str, RunData], specs: Specs) -> Section:
    """Experiment 2's rows and text (no figure)."""
    sec = Section(2, "Maximum step rates at a 1 MHz clock", ("rates",))
    probes = runs["rates"].probes
    clock = MACHINE["post"].clock_hz
    blocks = {name: block for name, block, _, _ in specs["rates"].blocks}
    for name, paper, tolerance in (("linear", PAPER_RATE_LINEAR, 0.015),
                                   ("circular", PAPER_RATE_CIRCULAR, 0.005)):
        rate = probes[f"{name}_steps"] / probes[f"{name}_cycles"] * clock
        running = probes[f"{name}_busy"] and probes[f"{name}_overrun"]
        sec.row(f"{name} interpolation, FP offered every cycle",
                f"{paper / 1e3:.1f} K/sec",
                f"{rate / 1e3:.2f} k steps/s ({probes[f'{name}_steps']} steps in "
                f"{probes[f'{name}_cycles']} cycles; one step per {blocks[name].latency} "
                f"cycles)",
                f"within {100 * tolerance:g}%; K3701 busy and FP in surplus (OVERRUN set)",
                abs(rate - paper) <= tolerance * paper and running, kind="number")
    sec.text += [
        "The paper gives the K3701's maximum feed-pulse rates at CP = 1 MHz: 90.0 K/sec for "
        "linear and 47.6 K/sec for circular interpolation. The emulator measures them on the "
        "gateware inside the simulated machine (the post-interpolation build, whose K3701 "
        "takes FP straight from the rate multiplier): the feed path is opened completely "
        "(rate-multiplier clock at every cycle, word and budget at their maximum), so an FP "
        "is offered in all but one of 2^18 cycles, and the steps are counted on the K3701's "
        "step outputs over a window inside a long X line and inside the first octant of a "
        "circle of radius 100000 LSB, sqrt(2) control off.",
        "K37 reads the paper's figures as one step per 11 cycles (linear, 90.9 k/s; the "
        "paper prints 90.0) and per 21 cycles (circular, 47.6 k/s); the surplus FP are lost "
        "and flagged by the OVERRUN status bit, never silently.",
    ]
    return sec
