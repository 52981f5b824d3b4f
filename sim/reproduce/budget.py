"""Experiment 6: the FP-budget hazard, a budget one too high and one too low
(``docs/chips/decel.md``).

The same X line under FP control with the firmware's exact budget and with the budget off by
+1 and -1 (``RunOptions(budget_offset=+-1)``): exact counts of where the FP go.
"""

from __future__ import annotations

from pathlib import Path

from k37.firmware_model.motion.program import Line
from k37.sim.reproduce.markdown import Section, pyplot, save_figure
from k37.sim.reproduce.runs import MACHINE, RunData, Scale, Specs, Trace
from k37.sim.reproduce.theory import fp_rate, hardware_tau

__all__ = ["section"]


def section(runs: dict[str, RunData], specs: Specs, scale: Scale, out: Path) -> Section:
    """Experiment 6's rows, text and figure ``budget.png``."""
    sec = Section(6, "The FP-budget hazard: a budget one too high and one too low",
                  ("hazard_exact", "hazard_plus", "hazard_minus"))
    machine = MACHINE["pre"]
    item = specs["hazard_exact"].move(Line)
    need, end = item.plan.fp, item.end[0]
    tau = hardware_tau(machine)
    fa_per_x = 1 / tau  # the rate of one FP left in the circuit: x fa / 2^n, x = 1
    exact, plus, minus = (runs[k] for k in sec.runs)
    eb, pb = (r.report["blocks"][0] for r in (exact, plus))
    clock = machine.clock_hz
    fi = fp_rate(machine, eb["feed_word"])

    left_exact = eb["fp_budget"] - eb["fp_pulses"]
    sec.row(f"exact budget ({need} FP, X line of {end} LSB)",
            "the host computes the interpolator's exact count",
            f"block ends with the circuit empty ({left_exact} FP left, output 0 FP/s); "
            f"{eb['fp_pulses']} FP received; X at {exact.report['axes']['x']['actual']}",
            "exact", left_exact == 0 and eb["fp_pulses"] == need
            and exact.report["axes"]["x"]["actual"] == end, kind="trend")

    left = pb["fp_budget"] - pb["fp_pulses"]
    early = (eb["end_cycle"] - pb["end_cycle"]) / clock
    late_fp = plus.probes["fp_total"] - pb["fp_pulses"]
    sec.row("budget one too high",
            "too many FP: the interpolator stops while the feed is still running",
            f"block ends {1e3 * early:.0f} ms earlier with {left} FP still in the circuit "
            f"(its output still {left * fa_per_x:.1f} FP/s, not 0); that FP reaches the idle "
            f"K3701 {1e3 * (plus.probes['drained_cycle'] - pb['end_cycle']) / clock:.0f} ms "
            f"later ({late_fp} FP) and is ignored: {plus.probes['x_steps']} steps, X command "
            f"{plus.probes['x_command']}",
            "exact counts", left == 1 and late_fp == 1 and plus.probes["x_steps"] == need
            and plus.report["status"] == "ok", kind="trend")

    waited = (minus.report["cycles"] - eb["end_cycle"]) / clock
    sec.row("budget one too low",
            "too few FP: the block never ends",
            f"{waited / tau:.1f} tau after the exact run's end: status "
            f"{minus.report['status']}, K3701 BUSY = {minus.probes['busy']}, remaining "
            f"distance Xm = {minus.probes['remaining_x']}, X command "
            f"{minus.probes['x_command']} (one step short of {end}); all "
            f"{minus.probes['fp_total']} FP delivered",
            "exact counts", minus.report["status"] == "timeout" and minus.probes["busy"] == 1
            and minus.probes["remaining_x"] == 1 and minus.probes["x_command"] == end - 1
            and minus.probes["fp_total"] == need - 1, kind="trend")
    sec.text += [
        "The paper warns that under FP control the host's count of the FP a block needs must "
        "equal the interpolator's; the decel control's datasheet spells out the two ways it "
        "goes wrong. "
        f"The emulator runs an X line of {end} LSB at "
        f"F{machine.mm_per_min(scale.hazard_fp_s):g} ({fi:.0f} FP/s) three times, with "
        f"the firmware's exact budget and with the budget one too high and one too low "
        f"(`RunOptions(budget_offset=+-1)`).",
        f"One FP too many: the K3701 ends its block when it has its {need} FP, while the "
        f"accel/decel circuit still holds one; at that point the circuit would still emit "
        f"x fa / 2^n = {fa_per_x:.1f} FP/s. The axis is already at its end point, so the harm "
        f"is the stray FP: it arrives later, when the K3701 is idle (ignored) or, in a "
        f"program, already running the next block, which then starts one FP early. With a "
        f"budget k too high the circuit holds k FP at the end and the rate is k / tau: the "
        f"hazard 'stops while the feed is still high' needs k comparable to fi tau "
        f"({fi * tau:.0f} FP here).",
        "One FP too few: the circuit drains completely and the K3701 waits for its last FP "
        "forever, BUSY, one step short of the end point; the firmware's interrupt never "
        "comes and the program hangs (the run stops at its cycle limit).",
    ]
    plt = pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.6), sharey=True)
    for a, (name, run) in zip(axes, (("exact", exact), ("+1", plus), ("-1", minus)),
                              strict=True):
        r = Trace(run, clock)
        budget = r.block["fp_budget"]
        a.plot(r.t, need - r["fp_total"], lw=1.2, label="FP the K3701 still needs")
        a.plot(r.t, budget - r["fp_total"], "--", lw=1.2,
               label="FP still to come (budget - delivered)")
        if r.block["end_cycle"] is not None:
            a.axvline(r.seconds(r.block["end_cycle"]), color="C3", lw=0.8)
        a.set_yscale("symlog", linthresh=1)
        a.set(title=f"budget {name}: {budget} FP ({r.data.report['status']})",
              xlabel="time (s)")
    axes[0].set_ylabel("FP")
    axes[0].legend(fontsize=8)
    fig.suptitle("FP left, as the accel/decel circuit drains (red: the block ends)")
    sec.figure = save_figure(fig, out, "budget.png")
    return sec
