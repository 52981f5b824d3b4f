"""The ``--html`` report of one run (:func:`run_page`): what the page's script
(``run.js``) draws, gathered from the run's report and its samples.

* **The part**: the programmed path (every move as a polyline, in mm) and the actual path
  (the first sample of each of at most :data:`k37.sim.run.report_html.series.FINEST`
  buckets) coloured by the bucket's largest contour error; each point knows its block, so
  hovering it names the block's line, N-word, feed and contour error.
* **The time series** (:mod:`k37.sim.run.report_html.series`): contour error, following
  errors, speeds against the programmed feed, D/A volts, at several resolutions.
* **The blocks**: one row per block run, with its planned and actual time and its largest and
  RMS contour error (those :func:`k37.sim.run.plot_data.plot_data` sums over every sample,
  from :func:`k37.sim.run.contour.contour_errors`, as the report's own figures are).
* The summary, the job, and the ballbar's polar plot when the run has one.
"""

from __future__ import annotations

import html
import json
from typing import TYPE_CHECKING, Any

import numpy as np

from k37.firmware_model.feeds import planned_seconds, run_feed
from k37.sim.run.plot import block_code, programmed_path
from k37.sim.run.plot_data import plot_data
from k37.sim.run.report_html.page import packed, page
from k37.sim.run.report_html.series import FINEST, MERGE, levels
from k37.sim.run.runner import RunResult

if TYPE_CHECKING:
    from k37.sim.run.ballbar import Ballbar

__all__ = ["SERIES", "run_page"]

#: The time-series panels: (title, unit, columns), ``{a}`` standing for each axis.
SERIES = (
    ("contour error", "LSB", ("contour_error",)),
    ("following error (K3702 error counter)", "LSB", ("{a}_error",)),
    ("speeds (20 ms windows) and programmed feed", "mm/min", ("{a}_speed", "path_speed")),
    ("D/A output", "V", ("{a}_dac_volts",)),
)


def _blocks(result: RunResult, stats: list[tuple[float, float]]) -> dict[str, list]:
    """The per-block table's columns, one entry per block run."""
    job, report = result.job, result.report
    clock = report["clock_hz"]
    items = {item.index: item for item in job.program.items}
    rows: dict[str, list] = {key: [] for key in (
        "label", "line", "index", "code", "kind", "feed", "start", "end", "planned", "actual",
        "max", "rms")}
    for block, (peak, rms) in zip(report["blocks"], stats, strict=True):
        item = items[block["index"]]
        end = block["end_cycle"]
        values = (job.program.label(block["line"]), block["line"], block["index"],
                  block_code(item), block["kind"], run_feed(item, job.machine),
                  block["start_cycle"] / clock, None if end is None else end / clock,
                  planned_seconds(item, job.machine),
                  None if end is None else (end - block["start_cycle"]) / clock, peak, rms)
        for key, value in zip(rows, values, strict=True):
            rows[key].append(round(value, 6) if isinstance(value, float) else value)
    return rows


def _program(result: RunResult) -> tuple[dict[str, Any], bool]:
    """The programmed path in mm, moves separated by NaN, and each vertex's block (its row
    in the table; -1: a move that did not run); and whether it moves Z."""
    job = result.job
    row_of = {b["index"]: k for k, b in enumerate(result.report["blocks"])}
    pieces = programmed_path(result)
    axes = job.machine.axes
    points, owner = [np.full((0, axes), np.nan)], [np.zeros(0, dtype=np.int32)]
    for move, piece in zip(job.program.moves, pieces, strict=True):
        points += [piece, np.full((1, axes), np.nan)]
        owner += [np.full(len(piece) + 1, row_of.get(move.index, -1), dtype=np.int32)]
    xyz = np.vstack(points) * job.machine.lsb_mm
    moves_z = axes == 3 and bool(np.nanmax(xyz[:, 2]) > np.nanmin(xyz[:, 2])
                                 if len(xyz) > 1 else False)
    return ({**{a: packed(xyz[:, k]) for k, a in enumerate(job.machine.axis_names)},
             "block": packed(np.concatenate(owner), "<i4")}, moves_z)


def _ballbar(b: Ballbar) -> dict[str, Any]:
    return {"theta": packed(np.degrees(b.theta)), "deviation": packed(b.deviation),
            "figures": b.figures(), "radius": b.radius}


def run_page(result: RunResult, summary: str, ballbar: Ballbar | None = None) -> str:
    """The report page of ``result``: ``summary`` is the terminal's summary of the run,
    ``ballbar`` its ballbar analysis, if any."""
    job, report = result.job, result.report
    machine, clock = job.machine, report["clock_hz"]
    blocks = report["blocks"]
    data = plot_data(job, [(b["index"], b["start_cycle"]) for b in blocks], result.store,
                     FINEST)
    names = machine.axis_names
    panels = [(title, unit, [c.format(a=a) for c in columns for a in
                             (names if "{a}" in c else ("",))])
              for title, unit, columns in SERIES]
    series = levels(data, machine, clock, [c for _, _, cols in panels for c in cols])
    actual = data.rows[:, [data.columns.index(f"{a}_actual") for a in names]] * machine.lsb_mm
    owner = np.searchsorted([b["start_cycle"] for b in blocks], data.rows[:, 0],
                            side="right") - 1
    contour = data.envelope("contour_error")[1]
    program, moves_z = _program(result)
    payload = {
        "axes": list(names), "three_d": moves_z,
        "blocks": _blocks(result, data.blocks),
        "program": program,
        "actual": {**{a: packed(actual[:, k]) for k, a in enumerate(names)},
                   "error": packed(contour), "block": packed(owner, "<i4")},
        "series": {"time": packed(series.time), "merge": MERGE,
                   "samples_per_bucket": series.samples_per_bucket,
                   "panels": [{"title": t, "unit": u, "columns": c} for t, u, c in panels],
                   "high": {c: [packed(v) for v in lv] for c, lv in series.high.items()},
                   # a level whose least values are its largest (single samples, the
                   # speeds) carries them once
                   "low": {c: [None if np.array_equal(lo, hi) else packed(lo)
                               for lo, hi in zip(lv, series.high[c], strict=True)]
                           for c, lv in series.low.items()}},
        "ballbar": None if ballbar is None else _ballbar(ballbar),
    }
    body = "\n".join([
        f'<p class="status {html.escape(report["status"])}">{html.escape(report["status"])}: '
        f"{html.escape(report['reason'])}</p>",
        '<section><h2>The part</h2><div id="part" class="figure"></div>'
        '<p class="hint">Colour: the contour error (LSB) of the actual path. Hover a point '
        "for its block; the cursor on the time series marks the tool here."
        + (" Z is drawn at least a quarter of the longest side." if moves_z else "")
        + "</p></section>",
        '<section><h2>Along the run</h2><div id="series" class="figure tall"></div>'
        '<p class="hint">Each line runs through every bucket\'s least and largest value: '
        "no peak is lost; zoom in for finer buckets (down to "
        f"{series.samples_per_bucket:,} sample{'s' if series.samples_per_bucket > 1 else ''}"
        ").</p></section>",
        '<section><h2>Blocks</h2><p class="hint">Click a heading to sort, a row to zoom both '
        'views to its block.</p><div id="blocks" class="table"></div></section>',
        '<section id="ballbar-section" hidden><h2>Ballbar</h2>'
        '<div id="ballbar" class="figure"></div></section>',
        f"<section><h2>Summary</h2><pre id=\"summary\">{html.escape(summary)}</pre></section>",
        "<section><h2>Job</h2><details><summary>the job as run</summary><pre id=\"job\">"
        f"{html.escape(json.dumps(report['job'], indent=2))}</pre></details></section>",
    ])
    return page(f"k37 run {job.name}", body, payload, "run.js")
