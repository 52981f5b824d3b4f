"""Running a job: the simulated machine, the firmware, sampling and the report.

:func:`run_job` builds :class:`sim.system.System` for the job's machine on a backend, sets
the plants, runs :class:`firmware_model.firmware.Firmware` over the program, samples the
machine every ``sample_every`` cycles, and returns a :class:`RunResult` whose ``report`` is
the JSON document of :mod:`sim.report`.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from firmware_model.firmware import Firmware, check_program
from firmware_model.gcode import Arc, Dwell, Line
from firmware_model.host import Host8085
from firmware_model.job import AXES, Job
from hdl.chipset import CHIP_SELECTS, port
from sim.backend import Backend, make_backend
from sim.plant import DAC_VOLTS, PlantParams, dac_zero
from sim.report import SCHEMA_VERSION, validate
from sim.system import System

__all__ = ["TRACE_COLUMNS", "RunOptions", "RunResult", "Sampler", "run_job"]

#: Columns of the trace (CSV) and of :attr:`RunResult.samples`.
TRACE_COLUMNS = ("cycle", "x_command", "y_command", "x_actual", "y_actual", "x_error",
                 "y_error", "x_dac_volts", "y_dac_volts", "fp_total")
#: The ports behind those columns (after "cycle"; the D/A words become volts).
SAMPLED_PORTS = ("x__command", "y__command", "x__count", "y__count", "x__error", "y__error",
                 "x__dac", "y__dac", "fp_total")


@dataclass
class RunOptions:
    """How to run a job (the command line's options)."""

    backend: str = "auto"
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


#: With a backend that records the samples itself, calls stop only for the progress bar.
PROGRESS_CYCLES = 1_000_000
NEVER = 1 << 63


class Sampler:
    """Wraps a backend so that it is sampled at every multiple of ``every`` cycles.

    It offers the backend calls the firmware's host uses (``step``, ``run_until``, ``get``,
    ``bus_write``, ``bus_read``, ``cycle``). A backend that records (:meth:`Backend.record`,
    the compiled one) samples as it steps, without a call per sample; with another, the
    sampler advances it in chunks that stop at every sample point and samples there. The
    samples are the same either way, on every backend alike. ``skip_idle`` is passed on to
    the backend's ``step`` and ``run_until``.
    """

    def __init__(self, backend: Backend, every: int, dac_bits: int, progress_total: int = 0,
                 *, skip_idle: bool = False):
        if every < 1:
            raise ValueError(f"sample_every must be >= 1 cycle, not {every}")
        self.backend = backend
        self.rows: list[list[int]] = []  # raw samples taken here: cycle and SAMPLED_PORTS
        self.half = 1 << (dac_bits - 1)
        self.progress_total = progress_total
        self.skip_idle = skip_idle
        self._progress_at = 0.0
        self.native = backend.record(SAMPLED_PORTS, every)
        # Where calls stop: at each sample, or for the progress bar.
        self.stride = (every if not self.native else PROGRESS_CYCLES if progress_total
                       else NEVER)
        self.next = self.stride

    @property
    def cycle(self) -> int:
        return self.backend.cycle

    def get(self, name: str) -> int:
        return self.backend.get(name)

    def samples(self) -> np.ndarray:
        """The samples, a row of :data:`TRACE_COLUMNS` each (the D/A words in volts)."""
        raw = (self.backend.recorded() if self.native else
               np.array(self.rows, dtype=np.int64).reshape(-1, 1 + len(SAMPLED_PORTS)))
        data = raw.astype(float)
        volts = slice(TRACE_COLUMNS.index("x_dac_volts"), TRACE_COLUMNS.index("y_dac_volts") + 1)
        data[:, volts] = DAC_VOLTS * (data[:, volts] - self.half) / self.half
        return data

    def _progress(self) -> None:
        now = time.monotonic()
        if now - self._progress_at < 0.5:
            return
        self._progress_at = now
        frac = min(1.0, self.cycle / self.progress_total)
        bar = "#" * int(frac * 30)
        print(f"\rk37 run: [{bar:<30}] {self.cycle:,} cycles", end="", file=sys.stderr)

    def _after(self) -> None:
        if self.cycle >= self.next:
            if not self.native:
                self.rows.append([self.cycle, *self.backend.get_many(SAMPLED_PORTS)])
            self.next += self.stride
            if self.progress_total:
                self._progress()

    def step(self, n: int = 1) -> None:
        while n > 0:
            k = min(n, self.next - self.cycle)
            self.backend.step(k, skip_idle=self.skip_idle)
            n -= k
            self._after()

    def run_until(self, port_name: str, max_cycles: int) -> int:
        done = 0
        while done < max_cycles:
            k = min(max_cycles - done, self.next - self.cycle)
            ran = self.backend.run_until(port_name, k, skip_idle=self.skip_idle)
            done += ran
            self._after()
            if ran < k or self.backend.get(port_name):
                break
        return done

    def bus_write(self, addr: int, data: int) -> None:
        self.backend.bus_write(addr, data)
        self._after()

    def bus_read(self, addr: int) -> int:
        value = self.backend.bus_read(addr)
        self._after()
        return value


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
        servo = job.servo[axis]
        max_speed = None if servo.max_speed is None else servo.max_speed / 60 / machine.lsb_mm
        params = PlantParams(kp=servo.kp, tm=servo.tm, max_speed=max_speed,
                             clock_hz=machine.clock_hz)
        backend.set(f"{axis}__gain", params.gain)
        backend.set(f"{axis}__alpha", params.alpha)
        backend.set(f"{axis}__vmax", params.vmax)
        backend.set(f"{axis}__dac_zero", dac_zero(machine.dac_bits))
        for name, value in faults.get(axis, {}).items():
            backend.set(f"{axis}__{name}", value)


def build_backend(job: Job, kind: str) -> Backend:
    """The simulated machine of ``job`` on backend ``kind`` (auto, pysim, cxxrtl)."""
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
    host = Host8085(sampler, clock_hz=job.machine.clock_hz)  # type: ignore[arg-type]
    firmware = Firmware(host, job, budget_offset=options.budget_offset)
    start = time.perf_counter()
    firmware.run(options.max_cycles)
    wall = time.perf_counter() - start
    if options.progress:
        print(file=sys.stderr)
    samples = sampler.samples()
    report = _report(job, backend, firmware, samples, wall)
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


def _axis_report(backend: Backend, axis: str) -> dict:
    chip = f"K3702_{axis.upper()}"
    status = CHIP_SELECTS[chip][1]["STATUS"]
    # Read after the run has been timed and counted: the reads cost a cycle each.
    word = backend.bus_read(port(chip, "STATUS"))
    return {"command": backend.get(f"{axis}__command"), "error": backend.get(f"{axis}__error"),
            "actual": backend.get(f"{axis}__count"),
            "max_abs_error": backend.get(f"{axis}__max_abs_error"),
            "flags": {f.name: f.decode(word) for f in status.fields}}


def _report(job: Job, backend: Backend, firmware: Firmware, samples: np.ndarray,
            wall: float) -> dict:
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
        "blocks": [{
            "index": b.index, "line": b.line, "kind": b.kind, "start_cycle": b.start_cycle,
            "end_cycle": b.end_cycle, "fp_budget": b.fp_budget, "fp_pulses": b.fp_pulses,
            "feed_word": b.feed_word,
            "steps": b.steps or {"x+": 0, "x-": 0, "y+": 0, "y-": 0},
            "end_command": list(b.end_command) if b.end_command else None,
        } for b in firmware.blocks],
        "axes": {axis: _axis_report(backend, axis) for axis in AXES},
        "path": {
            "max_contour_error": float(contour.max()) if contour.size else 0.0,
            "rms_contour_error": float(math.sqrt(np.mean(contour**2))) if contour.size else 0.0,
            "samples": len(samples),
        },
        "alarms": [{"axis": a.axis, "cycle": a.cycle, "kind": a.kind} for a in firmware.alarms],
    }


def _segment_distance(p: np.ndarray, a: tuple[int, int], b: tuple[int, int]) -> np.ndarray:
    ax, ay = a
    d = np.array([b[0] - ax, b[1] - ay], dtype=float)
    rel = p - np.array([ax, ay], dtype=float)
    length2 = float(d @ d)
    t = np.zeros(len(p)) if length2 == 0 else np.clip(rel @ d / length2, 0.0, 1.0)
    return np.hypot(*(rel - np.outer(t, d)).T)


def _arc_distance(p: np.ndarray, item: Arc) -> np.ndarray:
    cx, cy = item.start[0] + item.i, item.start[1] + item.j
    rel = p - np.array([cx, cy], dtype=float)
    radius = math.hypot(item.i, item.j)
    a0 = math.atan2(-item.j, -item.i)
    end = item.end
    a1 = math.atan2(end[1] - cy, end[0] - cx)
    sweep = (a1 - a0) % (2 * math.pi) if not item.cw else (a0 - a1) % (2 * math.pi)
    if sweep == 0:
        sweep = 2 * math.pi
    ang = np.arctan2(rel[:, 1], rel[:, 0])
    off = (ang - a0) % (2 * math.pi) if not item.cw else (a0 - ang) % (2 * math.pi)
    on_arc = np.abs(np.hypot(rel[:, 0], rel[:, 1]) - radius)
    ends = np.minimum(np.hypot(*(p - np.array(item.start, dtype=float)).T),
                      np.hypot(*(p - np.array(end, dtype=float)).T))
    return np.where(off <= sweep, on_arc, ends)


def contour_errors(job: Job, firmware: Firmware, samples: np.ndarray) -> np.ndarray:
    """Distance of each sample's actual position to the programmed path (LSB).

    A sample is compared with the block running at its cycle and its neighbours (a lagging
    axis is still on the block before).
    """
    moves = [it for it in job.program.items if not isinstance(it, Dwell)]
    if not len(samples) or not moves or not firmware.blocks:
        return np.zeros(0)
    cycles, pts = samples[:, 0], samples[:, 3:5]
    move_of = {it.index: k for k, it in enumerate(moves)}
    block_move = np.array([move_of[b.index] for b in firmware.blocks])
    running = np.searchsorted([b.start_cycle for b in firmware.blocks], cycles,
                              side="right") - 1
    candidates = []
    for shift in (-1, 0, 1):
        idx = running + shift
        valid = (idx >= 0) & (idx < len(block_move))
        candidates.append(np.where(valid, block_move[np.clip(idx, 0, len(block_move) - 1)],
                                   -1))
    candidates = np.array(candidates)
    best = np.full(len(pts), np.inf)
    for k in np.unique(candidates[candidates >= 0]):
        near = (candidates == k).any(axis=0)
        item = moves[k]
        dist = (_segment_distance(pts[near], item.start, item.end) if isinstance(item, Line)
                else _arc_distance(pts[near], item))
        best[near] = np.minimum(best[near], dist)
    # Samples before the first block: distance to the start point.
    before = ~np.isfinite(best)
    best[before] = np.hypot(*(pts[before] - np.array(moves[0].start, dtype=float)).T)
    return best
