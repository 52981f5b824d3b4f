"""``k37 plan``: a job's program as the firmware will run it, without running it.

One row per program item: its index, G-code line, kind (``line``, ``rapid``, ``arc``,
``correction`` for the host's line after an arc, ``dwell``, ``event``), the absolute end
point (LSB, machine axes), the FP count the K3701 is budgeted and, for dwells and events,
what they are. As a text table or as JSON (:func:`plan_rows`).
"""

from __future__ import annotations

from typing import Any

from firmware_model.gcode.parser import Arc, Dwell, Event, Line
from firmware_model.job import Job

__all__ = ["plan_rows", "plan_table"]


def _kind(item: Line | Arc | Dwell | Event) -> str:
    if isinstance(item, Line):
        return "correction" if item.correction else "rapid" if item.rapid else "line"
    return type(item).__name__.lower()


def plan_rows(job: Job) -> list[dict[str, Any]]:
    """The program's items as JSON-able rows."""
    rows = []
    for item in job.program.items:
        row: dict[str, Any] = {"index": item.index, "line": item.line_no, "kind": _kind(item)}
        if isinstance(item, Line | Arc):
            row |= {"end": list(item.end), "fp": item.plan.fp, "steps": item.plan.steps}
            if isinstance(item, Arc):
                row |= {"plane": item.plane, "cw": item.cw}
        elif isinstance(item, Dwell):
            row["seconds"] = item.seconds
        else:
            row |= {"word": item.word, "event": item.kind, "value": item.value}
        rows.append(row)
    return rows


def plan_table(job: Job) -> str:
    """The rows as an aligned text table, with a summary line."""
    lines = [f"{'#':>5} {'line':>6}  {'kind':<10} {'end (LSB)':<30} {'FP':>9}  note"]
    fp = 0
    for row in plan_rows(job):
        end = "(" + ", ".join(map(str, row["end"])) + ")" if "end" in row else ""
        note = ""
        if row["kind"] == "arc":
            note = f"G{row['plane']} {'CW' if row['cw'] else 'CCW'}"
        elif row["kind"] == "dwell":
            note = f"{row['seconds']:g} s"
        elif row["kind"] == "event":
            note = f"{row['word']} {row['event']}"
        fp += row.get("fp", 0)
        lines.append(f"{row['index']:>5} {row['line']:>6}  {row['kind']:<10} {end:<30} "
                     f"{row.get('fp', ''):>9}  {note}".rstrip())
    program = job.program
    lines.append(f"{len(program.moves)} blocks, {fp} FP, {len(program.events)} events; ends at "
                 f"{tuple(program.final_position)} LSB; "
                 f"{'M02/M30' if program.end else 'no program end'}")
    return "\n".join(lines) + "\n"
