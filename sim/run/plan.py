"""``k37 plan``: a job's program as the firmware will run it, without running it.

One row per program item: its index, G-code line, kind (``line``, ``rapid``, ``arc``,
``correction`` for the host's line after an arc, ``dwell``, ``event``), the absolute end
point (LSB, machine axes), the FP count the K3701 is budgeted and, for dwells and events,
what they are. As a text table or as JSON (:func:`plan_rows`).
"""

from __future__ import annotations

from typing import Any

from k37.firmware_model.feeds import SETTLE_SECONDS, planned_seconds, program_time
from k37.firmware_model.job import Job
from k37.firmware_model.motion.program import Arc, Dwell, Event, Item, Line

__all__ = ["MANY_BLOCKS", "machine_time", "plan_rows", "plan_table"]

#: From this many blocks on, a program whose exact stops take longer than its moves is told
#: what shortens them.
MANY_BLOCKS = 10


def _kind(item: Item) -> str:
    if isinstance(item, Line):
        return "correction" if item.correction else "rapid" if item.rapid else "line"
    return type(item).__name__.lower()


def plan_rows(job: Job) -> list[dict[str, Any]]:
    """The program's items as JSON-able rows."""
    rows = []
    rates: dict = {}
    for item in job.program.items:
        row: dict[str, Any] = {"index": item.index, "line": item.line_no, "kind": _kind(item)}
        if isinstance(item, Dwell):
            row["seconds"] = item.seconds
        elif isinstance(item, Event):
            row |= {"word": item.word, "event": item.kind, "value": item.value}
        else:  # a move: a line, an arc, a parabola or an exponential
            row |= {"end": list(item.end), "fp": item.plan.fp, "steps": item.plan.steps,
                    "seconds": planned_seconds(item, job.machine, rates)}
            if isinstance(item, Arc):
                row |= {"plane": item.plane, "cw": item.cw}
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
    lines += machine_time(job)
    return "\n".join(lines) + "\n"


def machine_time(job: Job) -> list[str]:
    """The program's planned machine time in words, and what shortens it where the exact stops
    behind the accel/decel circuit take most of it."""
    machine = job.machine
    time = program_time(job)
    total, moving, dwells, stops = time.total, time.moving, time.dwells, time.stops
    text = [f"planned machine time {_hms(total)}: {_hms(moving)} moving at the programmed "
            f"feeds, {_hms(dwells)} of dwells, {_hms(stops)} of block ends and settling (an "
            f"upper estimate; the run's default limit follows it)"]
    if (machine.accel == "pre" and len(job.program.moves) >= MANY_BLOCKS
            and stops - SETTLE_SECONDS > moving):
        text.append(f"the exact stop behind the accel/decel circuit at each of the "
                    f"{len(job.program.moves)} blocks (tau {1e3 * machine.tau_s:g} ms) takes "
                    f"most of it: machine.accel = \"post\" (one circuit per axis after the "
                    f"K3701) or a shorter tau (machine.accel_bits, machine.accel_fa_hz) "
                    f"shortens it")
    return text


def _hms(seconds: float) -> str:
    """``1 h 02 min 03.4 s``, ``2 min 03.4 s`` or ``3.400 s``."""
    if seconds < 60:
        return f"{seconds:.3f} s"
    minutes, secs = divmod(seconds, 60)
    hours, minutes = divmod(int(minutes), 60)
    return (f"{hours} h {minutes:02d} min {secs:04.1f} s" if hours
            else f"{minutes} min {secs:04.1f} s")
