"""A run's report assembled from what the run measured: its status and why, each block, each
axis's counters and flags, the end point, the contour error
(:mod:`k37.sim.run.report` defines the document's schema)."""

from __future__ import annotations

from k37.firmware_model.feeds import clamped_feeds
from k37.firmware_model.firmware import BlockRecord, Firmware
from k37.firmware_model.job import Job
from k37.hdl.chipset.map import chip_register, port
from k37.sim.backends.contract import Backend
from k37.sim.run.contour import contour_summary
from k37.sim.run.meter import BlockMeasure, BlockMeter
from k37.sim.run.report import SCHEMA_VERSION
from k37.sim.run.sampler import SampleStore
from k37.sim.run.stall import RunStopped

__all__ = ["measured_report", "report_document", "run_status"]


def run_status(firmware: Firmware, stopped: RunStopped | None, limit_name: str,
               cycles: int) -> tuple[str, str]:
    """The run's status and why, in words."""
    for alarm in firmware.alarms:
        if alarm.kind == "alarm":
            return "alarm", (f"K3702 alarm on axis {alarm.axis} at cycle {alarm.cycle:,} "
                             f"(|error| beyond the alarm zone)")
    if firmware.alarms:
        fault = firmware.alarms[0]
        axis = f" on axis {fault.axis}" if fault.axis else ""
        return "fault", f"{fault.kind}{axis} at cycle {fault.cycle:,}"
    if stopped is not None:
        return stopped.status, stopped.reason
    if firmware.timed_out:
        return "timeout", f"{limit_name} ran out at cycle {cycles:,}"
    return "ok", "the program ran to its end"


def _block_report(b: BlockRecord, measure: BlockMeasure) -> dict:
    return {"index": b.index, "line": b.line, "kind": b.kind, "start_cycle": b.start_cycle,
            "end_cycle": b.end_cycle, "fp_budget": b.fp_budget,
            "fp_pulses": measure.fp_pulses, "feed_word": b.feed_word, "steps": measure.steps,
            "end_command": None if measure.end_command is None else list(measure.end_command)}


def _axis_report(backend: Backend, axis: str) -> dict:
    chip = f"K3702_{axis.upper()}"
    status = chip_register(chip, "STATUS")
    # Read after the run has been timed and counted: the reads cost a cycle each.
    word = backend.bus_read(port(chip, "STATUS"))
    return {"command": backend.get(f"{axis}__command"), "error": backend.get(f"{axis}__error"),
            "actual": backend.get(f"{axis}__count"),
            "max_abs_error": backend.get(f"{axis}__max_abs_error"),
            "flags": {f.name: f.decode(word) for f in status.fields}}


def _end_point(job: Job, firmware: Firmware, axes: dict[str, dict]) -> dict:
    programmed = list(job.program.final_position)
    actual = [axes[axis]["actual"] for axis in job.machine.axis_names]
    zone = job.machine.in_position
    moves = len(job.program.moves)
    ran = len(firmware.blocks) == moves and all(b.end_cycle is not None for b in firmware.blocks)
    return {"programmed": programmed, "actual": actual, "program_ran": ran,
            "reached": ran and all(a is not None and abs(a - p) <= zone
                                   for a, p in zip(actual, programmed, strict=True))}


def measured_report(job: Job, backend: Backend, firmware: Firmware, meter: BlockMeter,
            store: SampleStore, wall: float, status: str, reason: str) -> dict:
    """The report of a run of ``job`` on ``backend`` that has just ended, read from the
    machine, the firmware's records, the block meter and the samples."""
    max_contour, rms_contour = contour_summary(
        job, [(b.index, b.start_cycle) for b in firmware.blocks], store)
    return report_document(
        job, firmware, status=status, reason=reason, backend=backend.name,
        backend_reason=backend.reason, cycles=backend.cycle, wall=wall,
        skipped=backend.skipped_cycles,
        blocks=[_block_report(b, meter.of(b)) for b in firmware.blocks],
        axes={axis: _axis_report(backend, axis) for axis in job.machine.axis_names},
        path={"max_contour_error": max_contour, "rms_contour_error": rms_contour,
              "samples": store.rows})


def report_document(job: Job, firmware: Firmware, *, status: str, reason: str, backend: str,
                    backend_reason: str = "", cycles: int, wall: float, skipped: int,
                    blocks: list[dict], axes: dict[str, dict], path: dict) -> dict:
    """The report of a run of ``job`` by ``firmware`` (:mod:`k37.sim.run.report`), from what was
    measured of it."""
    clock = job.machine.clock_hz
    return {
        "schema_version": SCHEMA_VERSION,
        "job": job.to_dict(),
        "status": status,
        "reason": reason,
        "backend": backend,
        **({"backend_reason": backend_reason} if backend_reason else {}),
        "cycles": cycles,
        "clock_hz": clock,
        "machine_seconds": cycles / clock,
        "wall_seconds": wall,
        "cycles_per_second": cycles / wall if wall > 0 else 0.0,
        "skipped_cycles": skipped,
        "blocks": blocks,
        "axes": axes,
        "end_point": _end_point(job, firmware, axes),
        "path": path,
        "alarms": [{"axis": a.axis, "cycle": a.cycle, "kind": a.kind} for a in firmware.alarms],
        "warnings": [*job.program.notes, *clamped_feeds(job)],
        **({"events": [{"line": r.event.line_no, "word": r.event.word, "kind": r.event.kind,
                        "value": r.event.value, "cycle": r.cycle} for r in firmware.events]}
           if job.program.events else {}),
    }
