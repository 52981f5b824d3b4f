"""The ``k37 effects DIR --html`` page: the study's runs (a sortable table, each run linked to
its own report where ``DIR/runs/RUN.html`` exists, as ``k37 sweep --html`` writes them), the
main effects of the metric and its second-order response surface (the coefficients, and the
fitted metric over the first two factors, the others at their centre), in one
self-contained page (:mod:`k37.sim.run.report_html.page`)."""

from __future__ import annotations

import html
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from k37.sim.run.report_html.page import page
from k37.sim.study.analysis import Surface

__all__ = ["RUN_REPORTS", "SURFACE_GRID", "study_page"]

#: The folder of a study's per-run reports, in the study's folder: ``runs/RUN.html``.
RUN_REPORTS = "runs"
#: Points per side of the response surface's grid.
SURFACE_GRID = 41


def _number(text: str) -> float | str:
    try:
        return float(text)
    except ValueError:
        return text


def _surface(surface: Surface) -> dict[str, Any]:
    """The coefficients, and the fit over the first two factors (the others at the centre)."""
    out: dict[str, Any] = {
        "factors": list(surface.factors), "terms": list(surface.terms),
        "coefficients": list(surface.coefficients), "r_squared": surface.r_squared,
        "stationary": None if surface.stationary is None else list(surface.stationary),
        "kind": surface.kind, "grid": None}
    if len(surface.factors) >= 2:
        axes = [np.linspace(c - h, c + h, SURFACE_GRID)
                for c, h in zip(surface.centre[:2], surface.half_range[:2], strict=True)]
        rest = list(surface.centre[2:])
        z = [[surface.predict([a, b, *rest]) for a in axes[0]] for b in axes[1]]
        out["grid"] = {"x": axes[0].tolist(), "y": axes[1].tolist(), "z": z}
    return out


def study_page(folder: Path, header: Sequence[str], rows: Sequence[dict[str, str]],
               metric: str, effects: dict[str, list[tuple[float, float]]],
               surface: Surface | None, needs: str | None) -> str:
    """The page of the study in ``folder``: ``rows`` of its results table (every run, with
    ``header``'s columns), the main ``effects`` on ``metric`` and its ``surface`` (None:
    ``needs`` says why not)."""
    links = {}
    for row in rows:
        report = folder / RUN_REPORTS / f"{row['run']}.html"
        if report.exists():
            links[row["run"]] = f"{RUN_REPORTS}/{row['run']}.html"
    payload = {
        "metric": metric, "columns": list(header),
        "rows": {c: [_number(r.get(c, "")) for r in rows] for c in header},
        "links": [links.get(r["run"]) for r in rows],
        "effects": {f: [list(p) for p in points] for f, points in effects.items()},
        "surface": None if surface is None else _surface(surface), "needs": needs,
    }
    body = "\n".join([
        f"<p>{len(rows)} runs; the metric: <b>{html.escape(metric)}</b> (over the runs with "
        "status ok).</p>",
        '<section><h2>Main effects</h2><div id="effects" class="figure"></div></section>',
        '<section><h2>Response surface</h2><p id="surface-text"></p>'
        '<div id="surface" class="figure"></div><div id="coefficients" class="table"></div>'
        "</section>",
        '<section><h2>Runs</h2><p class="hint">Click a heading to sort; a run links to its '
        f"own report where <code>{RUN_REPORTS}/RUN.html</code> exists.</p>"
        '<div id="runs" class="table"></div></section>',
    ])
    return page(f"k37 effects {folder.name}: {metric}", body, payload, "study.js")
