"""Running a job: the simulated machine, the firmware, sampling and the report.

:func:`run_job` builds :class:`sim.machine.system.System` for the job's machine on a backend, sets
the plants, runs :class:`firmware_model.firmware.Firmware` over the program, samples the machine
every ``sample_every`` cycles, and returns a :class:`RunResult` whose ``report`` is the JSON
document of :mod:`sim.run.report`.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from firmware_model.firmware import BlockRecord, Firmware, check_program
from firmware_model.host import Host8085
from firmware_model.job import AXES, Job
from hdl.chipset import CHIP_SELECTS, port
from sim.backends.contract import Backend
from sim.backends.factory import BACKEND_NAMES, make_backend
from sim.machine.plant import dac_zero
from sim.machine.system import System
from sim.run.contour import contour_errors
from sim.run.jobfile import plant_params
from sim.run.link import BlockMeasure, BlockMeter, SimulatedLink
from sim.run.report import SCHEMA_VERSION, validate
from sim.run.sampler import Sampler

__all__ = ["RunOptions", "RunResult", "build_backend", "run_job"]


@dataclass
class RunOptions:
    """How to run a job (the command line's options)."""

    #: One of :data:`sim.backends.factory.BACKEND_NAMES`.
    backend: str = BACKEND_NAMES[0]
    max_cycles: int = 10**9
    sample_every: int = 1000
    vcd: Path | None = None
    vcd_start: int = 0
    vcd_stop: int | None = None
    progress: bool = False
    faults: dict[str, dict[str, int]] = field(default_factory=dict)
    #: Added to every block's FP budget (the SPEC section 7 hazard); 0 normally.
    budget_offset: int = 0
    #: Let the backend skip provably idle cycles (bit-identical; see Backend.step).
    skip_idle: bool = True


@dataclass
class RunResult:
    """A finished run: its report (JSON-able), samples and wall-clock time."""

    report: dict
    samples: np.ndarray
    job: Job

    @property
    def ok(self) -> bool:
        return self.report["status"] == "ok"


def _configure_plants(backend: Backend, job: Job, faults: dict[str, dict[str, int]]) -> None:
    machine = job.machine
    for axis in AXES:
        params = plant_params(machine, job.servo[axis])
        backend.set(f"{axis}__gain", params.gain)
        backend.set(f"{axis}__alpha", params.alpha)
        backend.set(f"{axis}__vmax", params.vmax)
        backend.set(f"{axis}__dac_zero", dac_zero(machine.dac_bits))
        for name, value in faults.get(axis, {}).items():
            backend.set(f"{axis}__{name}", value)


def build_backend(job: Job, kind: str) -> Backend:
    """The simulated machine of ``job`` on backend ``kind`` (one of ``BACKEND_NAMES``)."""
    system = System(accel=job.machine.accel, accel_bits=job.machine.accel_bits)
    return make_backend(system, kind)


def run_job(job: Job, options: RunOptions | None = None,
            backend: Backend | None = None) -> RunResult:
    """Run ``job`` to its end (or an alarm, or ``max_cycles``) and report.

    A ``backend`` passed in must be freshly built for the job's machine
    (:func:`build_backend`); it is left open, for the caller to look at afterwards.
    """
    options = options or RunOptions()
    check_program(job)  # refuse what the hardware cannot do before building anything
    owned = backend is None
    backend = backend or build_backend(job, options.backend)
    _configure_plants(backend, job, options.faults)
    if options.vcd is not None:
        backend.trace(str(options.vcd), options.vcd_start, options.vcd_stop)
    sampler = Sampler(backend, options.sample_every, job.machine.dac_bits,
                      options.max_cycles if options.progress else 0,
                      skip_idle=options.skip_idle)
    host = Host8085(SimulatedLink(sampler), clock_hz=job.machine.clock_hz)
    meter = BlockMeter(sampler)
    firmware = Firmware(host, job, budget_offset=options.budget_offset, observer=meter)
    start = time.perf_counter()
    firmware.run(options.max_cycles)
    wall = time.perf_counter() - start
    if options.progress:
        print(file=sys.stderr)
    samples = sampler.samples()
    report = _report(job, backend, firmware, meter, samples, wall)
    if owned:
        backend.close()
    validate(report)
    return RunResult(report, samples, job)


def _status(firmware: Firmware) -> str:
    if any(a.kind == "alarm" for a in firmware.alarms):
        return "alarm"
    if firmware.alarms:
        return "fault"
    if firmware.timed_out:
        return "timeout"
    return "ok"


def _block_report(b: BlockRecord, measure: BlockMeasure) -> dict:
    return {"index": b.index, "line": b.line, "kind": b.kind, "start_cycle": b.start_cycle,
            "end_cycle": b.end_cycle, "fp_budget": b.fp_budget,
            "fp_pulses": measure.fp_pulses, "feed_word": b.feed_word, "steps": measure.steps,
            "end_command": None if measure.end_command is None else list(measure.end_command)}


def _axis_report(backend: Backend, axis: str) -> dict:
    chip = f"K3702_{axis.upper()}"
    status = CHIP_SELECTS[chip][1]["STATUS"]
    # Read after the run has been timed and counted: the reads cost a cycle each.
    word = backend.bus_read(port(chip, "STATUS"))
    return {"command": backend.get(f"{axis}__command"), "error": backend.get(f"{axis}__error"),
            "actual": backend.get(f"{axis}__count"),
            "max_abs_error": backend.get(f"{axis}__max_abs_error"),
            "flags": {f.name: f.decode(word) for f in status.fields}}


def _report(job: Job, backend: Backend, firmware: Firmware, meter: BlockMeter,
            samples: np.ndarray, wall: float) -> dict:
    cycles = backend.cycle
    clock = job.machine.clock_hz
    contour = contour_errors(job, firmware, samples)
    return {
        "schema_version": SCHEMA_VERSION,
        "job": job.to_dict(),
        "status": _status(firmware),
        "backend": backend.name,
        "cycles": cycles,
        "clock_hz": clock,
        "machine_seconds": cycles / clock,
        "wall_seconds": wall,
        "cycles_per_second": cycles / wall if wall > 0 else 0.0,
        "skipped_cycles": backend.skipped_cycles,
        "blocks": [_block_report(b, meter.of(b)) for b in firmware.blocks],
        "axes": {axis: _axis_report(backend, axis) for axis in AXES},
        "path": {
            "max_contour_error": float(contour.max()) if contour.size else 0.0,
            "rms_contour_error": float(math.sqrt(np.mean(contour**2))) if contour.size else 0.0,
            "samples": len(samples),
        },
        "alarms": [{"axis": a.axis, "cycle": a.cycle, "kind": a.kind} for a in firmware.alarms],
    }
