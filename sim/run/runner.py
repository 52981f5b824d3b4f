"""Running a job: the simulated machine, the firmware, sampling and the report.

:func:`run_job` builds :class:`k37.sim.machine.system.System` for the job's machine on a backend,
sets the plants, runs :class:`k37.firmware_model.firmware.Firmware` over the program, samples the
machine every ``sample_every`` cycles into a :class:`k37.sim.run.sampler.SampleStore`, and returns a
:class:`RunResult` whose ``report`` is the JSON document of :mod:`k37.sim.run.report`.

A run ends at the program's end, an alarm or fault, or the first limit it reaches: the cycle
limit ``max_cycles`` or the job's ``run.max_time_s`` of simulated time, whichever is fewer
cycles (the firmware stops there, even inside a dwell), a stall
(:class:`k37.sim.run.stall.StallWatch`: no feed pulse and no axis motion while a block runs), or
a stop request (``stop``, which Ctrl-C or SIGTERM sets with ``sigint``); stalls and stop
requests are looked at on the sampler's ticks (every 10^6 cycles at most), so a run ends
within a tick of them, and still reports.
"""

from __future__ import annotations

import hashlib
import math
import os
import signal
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import cache, cached_property
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

import k37.hdl
import k37.sim.machine
from k37.firmware_model.feeds import check_program, program_seconds
from k37.firmware_model.firmware import Firmware
from k37.firmware_model.host import Host8085
from k37.firmware_model.job import Job
from k37.firmware_model.motion.program import Dwell, Event
from k37.sim.backends.contract import Backend
from k37.sim.backends.factory import BACKEND_NAMES, make_backend
from k37.sim.files import OutputFailure, discard_temporary, keep_temporary, temporary_beside, why

if TYPE_CHECKING:
    from k37.sim.machine.system import System
from k37.sim.link.simulated import SimulatedLink
from k37.sim.machine.servo import axis_port, servo_ports
from k37.sim.run.assemble import measured_report, run_status
from k37.sim.run.fst import convert_in_child
from k37.sim.run.meter import BlockMeter
from k37.sim.run.progress import ProgramPlan, Progress
from k37.sim.run.report import validate
from k37.sim.run.sampler import Sampler, SampleStore
from k37.sim.run.stall import RunStopped, StallWatch
from k37.sim.run.waveform import is_fst

__all__ = ["STOP_SIGNALS", "OptionError", "RunOptions", "RunResult", "RunStopped",
           "build_backend", "check_options", "configure_plants", "cycle_limit", "reused_backend",
           "run_job", "system_params"]


@dataclass
class RunOptions:
    """How to run a job (the command line's options)."""

    #: One of :data:`k37.sim.backends.factory.BACKEND_NAMES`.
    backend: str = BACKEND_NAMES[0]
    #: The run's cycle limit; None: the program's (:func:`cycle_limit`).
    max_cycles: int | None = None
    sample_every: int = 1000
    vcd: Path | None = None
    vcd_start: int = 0
    vcd_stop: int | None = None
    #: Globs over the dotted signal paths below the top to dump (empty: every signal).
    signals: tuple[str, ...] = ()
    #: Called with the run's :class:`k37.sim.run.progress.Progress` at the sampler's ticks.
    progress: Callable[[Progress], None] | None = None
    faults: dict[str, dict[str, int]] = field(default_factory=dict)
    #: Added to every block's FP budget (the FP-budget hazard); 0 normally.
    budget_offset: int = 0
    #: Let the backend skip provably idle cycles (bit-identical; see Backend.step).
    skip_idle: bool = True
    #: Set (from another thread, or by Ctrl-C with ``sigint``) to stop the run at the next
    #: tick, status interrupted.
    stop: threading.Event | None = None
    #: While the run goes, Ctrl-C (SIGINT) and SIGTERM set ``stop`` instead of ending the
    #: process (in the main thread; the command line sets it). The signal is the result's
    #: ``stopped_by``.
    sigint: bool = False


@dataclass
class RunResult:
    """A finished run: its report (JSON-able), its samples (in a store) and its job."""

    report: dict
    store: SampleStore
    job: Job
    #: Outputs the run itself writes (the waveform) that could not be written whole.
    failures: list[OutputFailure] = field(default_factory=list)
    #: The signal that stopped the run (with ``RunOptions.sigint``), or None.
    stopped_by: signal.Signals | None = None

    @cached_property
    def samples(self) -> np.ndarray:
        """Every sample, a row of the store's ``columns`` each (in memory; the two-axis
        machine's are :data:`k37.sim.run.sampler.TRACE_COLUMNS`)."""
        return self.store.array()

    @cached_property
    def traces(self) -> dict[str, np.ndarray]:
        """Every sample by column (the CSV's columns): ``traces["x_error"]`` is the X
        following error at each sample (LSB)."""
        return {name: self.samples[:, k] for k, name in enumerate(self.store.columns)}

    @property
    def ok(self) -> bool:
        return self.report["status"] == "ok"


class OptionError(ValueError):
    """Run options that cannot work; one line naming the command line's option."""


def check_options(options: RunOptions) -> None:
    """Refuse, before anything is built, options that cannot work: a waveform window that is
    empty or starts where the run can no longer be."""
    start, stop = options.vcd_start, options.vcd_stop
    if start < 0:
        raise OptionError(f"--vcd-start {start}: a cycle cannot be negative")
    if stop is not None and start >= stop:
        raise OptionError(f"--vcd-start {start:,} must come before --vcd-stop {stop:,}: "
                          f"the waveform window would be empty")
    if options.vcd is not None and options.max_cycles is not None and start >= options.max_cycles:
        raise OptionError(f"--vcd-start {start:,} is at or past --max-cycles "
                          f"{options.max_cycles:,}: the waveform window would never be reached")


def configure_plants(backend: Backend, job: Job,
                     faults: dict[str, dict[str, int]] | None = None) -> None:
    """Set the plants of a backend built for ``job`` to its servos, with ``faults`` (per axis:
    a plant input, ``stall``, ``break_a`` or a load step's ``load_step`` and ``load_after``
    (:func:`k37.sim.machine.servo.load_step_fault`), and its value)."""
    faults = faults or {}
    machine = job.machine
    for axis in machine.axis_names:
        for name, value in {**servo_ports(machine, job.servo[axis]),
                            **faults.get(axis, {})}.items():
            backend.set(axis_port(axis, name), value)


def system_params(job: Job) -> dict[str, Any]:
    """What the simulated machine of ``job`` is built with: jobs with equal parameters can
    share one built backend (reset between runs)."""
    return {"accel": job.machine.accel, "accel_bits": job.machine.accel_bits,
            "axes": job.machine.axes, "accel_shape": job.machine.accel_shape,
            "axis_accel": job.accel_circuits(), "axis_fa": job.fa_axes(),
            "drives": {axis: job.servo[axis].drive for axis in job.machine.axis_names}}


@cache
def _design_sources() -> str:
    """The hash of every source the simulated machine is elaborated from: the gateware
    (``hdl``), the plants and the system (``k37.sim.machine``), and Amaranth's version."""
    digest = hashlib.sha256(metadata.version("amaranth").encode())
    for package in (k37.hdl, k37.sim.machine):
        root = Path(package.__file__).parent
        for path in sorted(root.rglob("*.py")):
            digest.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


def design_key(job: Job) -> str:
    """The simulated machine of ``job`` named by its sources and :func:`system_params`: equal
    keys elaborate equal designs, so a compiled model is found without elaborating it."""
    return f"{_design_sources()} {sorted(system_params(job).items())}"


def build_backend(job: Job, kind: str, *, internals: bool = False) -> Backend:
    """The simulated machine of ``job`` on backend ``kind`` (one of ``BACKEND_NAMES``; ``auto``
    as :func:`k37.sim.backends.factory.choose_backend` picks, with ``internals``: the caller
    reads internal signals); the machine (and Amaranth) is only made if the backend has no
    model of it yet."""
    params = system_params(job)

    def machine() -> System:
        from k37.sim.machine.system import System

        return System(**params)

    return make_backend(machine, kind, design_key=design_key(job), params=params,
                        internals=internals)


_REUSED: dict[str, Backend] = {}


def reused_backend(job: Job) -> Backend:
    """This process's machine for ``job`` on the backend ``auto`` picks for it
    (:func:`k37.sim.backends.factory.choose_backend`: the engine, given a C++ compiler),
    built once per design (:func:`design_key`) and reset to cycle 0 for each later job: what a
    process running many jobs (a study's or a reproduction's worker) runs them on."""
    key = design_key(job)
    backend = _REUSED.get(key)
    if backend is None:
        backend = _REUSED[key] = build_backend(job, "auto")
    else:
        backend.reset()
    return backend


class _Watch:
    """What the sampler's ticks look at: a stop request, a stall, progress."""

    def __init__(self, options: RunOptions, stop: threading.Event, sampler: Sampler,
                 firmware: Firmware, meter: BlockMeter):
        self.options = options
        self.stop = stop
        self.sampler = sampler
        self.firmware = firmware
        self.meter = meter
        self.stall = StallWatch(sampler, firmware)
        self.plan = ProgramPlan(firmware.job) if options.progress else None
        self.start = time.perf_counter()
        #: The signal that set ``stop``, if one did.
        self.signal: signal.Signals | None = None

    def __call__(self) -> None:
        cycle = self.sampler.cycle
        if self.stop.is_set():
            by = ("on request (Ctrl-C)" if self.signal in (None, signal.SIGINT)
                  else f"by {self.signal.name}")
            raise RunStopped("interrupted", f"stopped {by} at cycle {cycle:,}")
        self.stall.check(cycle)
        if self.options.progress is not None:
            self.options.progress(self.progress(cycle, time.perf_counter() - self.start))

    def progress(self, cycle: int, wall: float) -> Progress:
        assert self.plan is not None
        item = self.firmware.item
        if item is None:
            done = 0.0
        elif isinstance(item, Dwell):
            done = self.plan.dwell_done(item, cycle - self.firmware.item_cycle)
        elif isinstance(item, Event):
            done = 1.0
        else:
            done = self.meter.done(item.index, item.plan.fp)
        return self.plan.progress(item, done, cycle, wall)


#: The signals that stop a run with ``RunOptions.sigint``, as Ctrl-C does.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


@contextmanager
def _signals_set(stop: threading.Event, watch: _Watch, enabled: bool) -> Iterator[None]:
    """While it lasts, SIGINT and SIGTERM set ``stop`` and name themselves in ``watch`` (if
    ``enabled``, in the main thread)."""
    if not enabled or threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum: int, _: object) -> None:
        watch.signal = signal.Signals(signum)
        stop.set()

    previous = {s: signal.signal(s, handler) for s in STOP_SIGNALS}
    try:
        yield
    finally:
        for s, handler_before in previous.items():
            signal.signal(s, signal.SIG_DFL if handler_before is None else handler_before)


def run_job(job: Job, options: RunOptions | None = None,
            backend: Backend | None = None) -> RunResult:
    """Run ``job`` to its end (or an alarm, a fault, a limit, a stop request) and report.

    Raises :class:`OptionError` or :class:`k37.firmware_model.feeds.FirmwareError` before
    building anything if the options or the program cannot work. A ``backend`` passed in must
    be freshly built for the job's machine (:func:`build_backend`); it is left open, for the
    caller to look at afterwards.
    """
    options = options or RunOptions()
    check_program(job)  # refuse what the hardware cannot do before building anything
    check_options(options)
    for axis in options.faults.keys() - set(job.machine.axis_names):
        raise OptionError(f"a fault on axis {axis}: the machine has {job.machine.axes} axes "
                          f"({', '.join(job.machine.axis_names)})")
    owned = backend is None
    backend = backend or build_backend(job, options.backend, internals=options.vcd is not None)
    configure_plants(backend, job, options.faults)
    traced = None
    if options.vcd is not None:
        try:
            traced = temporary_beside(Path(options.vcd), ".vcd")
            backend.trace(str(traced), options.vcd_start, options.vcd_stop, options.signals)
        except (ValueError, OSError) as e:
            if traced is not None:
                discard_temporary(traced)
            if owned:
                backend.close()
            if isinstance(e, OSError):
                raise OptionError(f"--vcd {options.vcd}: cannot write: {why(e)}") from None
            raise OptionError(str(e)) from None
    try:
        result = _run(job, options, backend, traced)
    except BaseException:
        if traced is not None:
            backend.stop_trace()
            discard_temporary(traced)
        if owned:
            backend.close()
        raise
    if owned:
        backend.close()
    return result


def _run(job: Job, options: RunOptions, backend: Backend, traced: Path | None) -> RunResult:
    """:func:`run_job` once its backend is built and traces (into ``traced``, if given)."""
    store = SampleStore(job.machine.dac_bits, job.machine.axis_names)
    sampler = Sampler(backend, options.sample_every, store, skip_idle=options.skip_idle)
    host = Host8085(SimulatedLink(sampler), clock_hz=job.machine.clock_hz)
    meter = BlockMeter(sampler, job.machine.axis_names)
    firmware = Firmware(host, job, budget_offset=options.budget_offset, observer=meter)
    stop = options.stop or threading.Event()
    sampler.tick = watch = _Watch(options, stop, sampler, firmware, meter)
    stopped = None
    limit, limit_name = cycle_limit(job, options)
    with _signals_set(stop, watch, options.sigint):
        try:
            firmware.run(limit)
        except RunStopped as e:
            stopped = e
    wall = time.perf_counter() - watch.start
    sampler.flush()
    status, reason = run_status(firmware, stopped, limit_name, backend.cycle)
    report = measured_report(job, backend, firmware, meter, store, wall, status, reason)
    failures = []
    if options.vcd is not None and traced is not None:
        backend.stop_trace()
        failure = _finish_waveform(options, traced, report)
        if failure is not None:
            failures.append(failure)
            report["warnings"].append(str(failure))
    validate(report)
    return RunResult(report, store, job, failures,
                     watch.signal if stopped is not None else None)


def _finish_waveform(options: RunOptions, traced: Path, report: dict) -> OutputFailure | None:
    """Put the waveform the backend traced into ``traced`` at ``--vcd``: checked whole,
    converted if it is an FST, renamed over the target. Nothing is left at the target if the
    run ended before the window (a warning) or the file could not be written whole (the
    failure, returned)."""
    assert options.vcd is not None
    wave = Path(options.vcd)
    if report["cycles"] <= options.vcd_start:
        discard_temporary(traced)
        report["warnings"].append(
            f"--vcd {wave}: the run ended at cycle {report['cycles']:,}, before --vcd-start "
            f"{options.vcd_start:,}: no waveform written (nor a GTKWave save file)")
        return None
    try:
        # The backend's writer may not say that a write failed: one more byte and a sync
        # find a full disk or an I/O error (a VCD ignores the blank line).
        with open(traced, "ab") as f:
            f.write(b"\n")
            f.flush()
            os.fsync(f.fileno())
        if is_fst(wave):
            fst = temporary_beside(wave, ".fst")
            try:
                convert_in_child(traced, fst)
            except BaseException:
                discard_temporary(fst)
                raise
            discard_temporary(traced)
            traced = fst
        keep_temporary(traced, wave)
    except OSError as e:
        discard_temporary(traced)
        return OutputFailure("--vcd", str(wave), why(e))
    return None


#: The default cycle limit follows the program: this many times its planned machine time
#: (:func:`k37.firmware_model.feeds.program_seconds`), plus :data:`PLAN_MARGIN_SECONDS`.
PLAN_MARGIN_FACTOR = 2
PLAN_MARGIN_SECONDS = 10.0


def cycle_limit(job: Job, options: RunOptions) -> tuple[int, str]:
    """The run's cycle limit, the fewer of ``max_cycles`` (None: the program's planned machine
    time with a margin, :data:`PLAN_MARGIN_FACTOR` and :data:`PLAN_MARGIN_SECONDS`) and the
    job's ``run.max_time_s`` of simulated time, and its name in words."""
    if options.max_cycles is None:
        planned = program_seconds(job)
        limit = math.ceil((PLAN_MARGIN_FACTOR * planned + PLAN_MARGIN_SECONDS)
                          * job.machine.clock_hz)
        by_option = (limit, f"the program's limit ({limit:,} cycles: {PLAN_MARGIN_FACTOR} x "
                            f"its planned {planned:.3f} s + {PLAN_MARGIN_SECONDS:g} s; "
                            f"--max-cycles sets another),")
    else:
        by_option = (options.max_cycles,
                     f"the cycle limit, --max-cycles {options.max_cycles:,},")
    seconds = job.run.max_time_s
    if seconds is None:
        return by_option
    exact = seconds * job.machine.clock_hz
    if not exact < by_option[0]:  # (an infinite product too: the other limit wins)
        return by_option
    cycles = max(1, round(exact))
    if cycles >= by_option[0]:
        return by_option
    return cycles, f"the job's limit, run.max_time_s = {seconds:g} s ({cycles:,} cycles),"
