"""Reproducing the paper's experiments on the emulator: ``k37 reproduce``.

Each experiment of the paper (section 3 and its photos, the maximum step rates, Table 1, and
the FP-budget warning) is run on the emulated machine with the compiled backend, and each
observation becomes a row of ``report.md``: the paper's figure, the emulator's, the tolerance
and pass or fail. The comparisons are computed against the paper's numbers
(:mod:`~k37.sim.reproduce.paper`) or against the physics that explains them
(:mod:`~k37.sim.reproduce.theory`), never written in.

:func:`reproduce` runs every run (:mod:`~k37.sim.reproduce.workers`) and :func:`analyse` turns
them into the seven sections, one module each: :mod:`~k37.sim.reproduce.accel`,
:mod:`~k37.sim.reproduce.rates`, :mod:`~k37.sim.reproduce.fp_counts`,
:mod:`~k37.sim.reproduce.path_error`, :mod:`~k37.sim.reproduce.fp_control`,
:mod:`~k37.sim.reproduce.budget` and :mod:`~k37.sim.reproduce.parabola` (the K3701's parabolic mode
on the contour-error paper's parabola), then one section per companion paper (:data:`COMPANIONS`):
:mod:`~k37.sim.reproduce.filters` (the accel/decel filters),
:mod:`~k37.sim.reproduce.motion_errors` (radius error by accel/decel type),
:mod:`~k37.sim.reproduce.contour_error` (the contour error vector) and
:mod:`~k37.sim.reproduce.profile_error` (the profile error of multi-axis control).
:data:`~k37.sim.reproduce.runs.FULL` is the scale of the committed figures;
:data:`~k37.sim.reproduce.runs.QUICK` shrinks the long runs for CI, and the report says what
each scale shrank. """

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from types import ModuleType

from k37.sim.reproduce import (
    accel,
    budget,
    contour_error,
    filters,
    fp_control,
    fp_counts,
    motion_errors,
    parabola,
    path_error,
    profile_error,
    rates,
)
from k37.sim.reproduce.markdown import Reproduction, report_markdown
from k37.sim.reproduce.runs import FULL, QUICK, RunData, RunSpec, Scale, Specs, run_specs
from k37.sim.reproduce.workers import run_all

__all__ = ["COMPANIONS", "all_specs", "analyse", "reproduce"]


#: The companion papers' sections, numbered from 8 on: modules with ``specs(scale)`` (their
#: runs, keys unique across the reproduction) and ``section(runs, specs, scale, out)``, and
#: optionally ``follow_up(runs, scale)``: runs that depend on others' results (run in rounds
#: until it has none left).
COMPANIONS: tuple[ModuleType, ...] = (filters, motion_errors, contour_error, profile_error)


def all_specs(scale: Scale) -> Specs:
    """Every run of the reproduction at ``scale``: the paper's, then each companion's."""
    specs = run_specs(scale)
    for companion in COMPANIONS:
        theirs = companion.specs(scale)
        if clash := specs.keys() & theirs.keys():
            raise ValueError(f"{companion.__name__}: run keys {sorted(clash)} already used")
        specs |= theirs
    return specs


def reproduce(out: Path, *, quick: bool = False, jobs: int = 2,
              progress: Callable[[str], None] | None = None,
              update_cycles: int = 1) -> Reproduction:
    """Run every experiment, write the figures and ``report.md`` into ``out``.

    ``quick`` runs the smaller :data:`~k37.sim.reproduce.runs.QUICK` scale (for CI); ``jobs`` is
    the number of worker processes for the closed-loop runs; ``update_cycles``: the first-order
    plants' update period in every closed-loop run (1: the papers' plant).
    """
    scale = QUICK if quick else FULL
    start = time.perf_counter()

    def held(specs: Specs) -> Specs:
        return {key: replace(spec, update_cycles=update_cycles)
                if isinstance(spec, RunSpec) else spec for key, spec in specs.items()}

    runs = run_all(held(all_specs(scale)), jobs, progress)
    while more := {key: spec for companion in COMPANIONS if hasattr(companion, "follow_up")
                   for key, spec in companion.follow_up(runs, scale).items()}:
        runs |= run_all(held(more), jobs, progress)
    return analyse(runs, scale, out, start, update_cycles)


def analyse(runs: dict[str, RunData], scale: Scale, out: Path,
            start: float | None = None, update_cycles: int = 1) -> Reproduction:
    """The sections of the report from the runs of :func:`run_all`; writes ``out``.

    ``start``: the ``time.perf_counter()`` at which the runs began (for the run time);
    ``update_cycles``: the plants' update period the runs had.
    """
    out.mkdir(parents=True, exist_ok=True)
    specs = all_specs(scale)
    model_start = time.perf_counter()
    circles = path_error.circles(runs, specs)
    sections = [accel.section(runs, specs, out), rates.section(runs, specs),
                fp_counts.section(runs, out), path_error.section(circles, scale, out),
                fp_control.section(runs, circles, specs, out),
                budget.section(runs, specs, scale, out), parabola.section(runs, specs, out),
                *(companion.section(runs, specs, scale, out) for companion in COMPANIONS)]
    end = time.perf_counter()
    result = Reproduction(scale, sections, runs, end - (model_start if start is None else start),
                          end - model_start, update_cycles)
    (out / "report.md").write_text(report_markdown(result))
    return result
