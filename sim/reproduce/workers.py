"""The experiments' runs in worker processes: :func:`run_all`.

The closed-loop runs are independent, so they run in worker processes (two by default, one
per core), each on the backend ``auto`` picks for it (the event-level engine where it runs the
run's machine and program, else the compiled RTL); the runs of one machine design share one
built backend, built once per process and reset between runs.
"""

from __future__ import annotations

import multiprocessing
import signal
import time
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait

import numpy as np

from k37.firmware_model.host import Host8085
from k37.firmware_model.job import AXES, Job
from k37.hdl.feed.map.decel_control import DECEL_MAP
from k37.hdl.feed.map.feed_rate import FEED_MAP
from k37.hdl.k3701.block import Block
from k37.hdl.k3701.map import block_registers
from k37.sim.backends.contract import Backend
from k37.sim.link.simulated import SimulatedLink
from k37.sim.reproduce.runs import RateSpec, RunData, RunSpec, Specs, minus_spec
from k37.sim.run.runner import RunOptions, design_key, reused_backend, run_job
from k37.sim.study.sweep import end_with_parent, stop_workers

__all__ = ["max_rates", "run_all", "start_at_full_feed"]

def _build(spec: RunSpec | RateSpec) -> RunData:
    """Build (or load from the cache) this process's model for ``spec``'s machine."""
    start = time.perf_counter()
    reused_backend(spec.job())
    return RunData(f"build {spec.key}", {}, np.zeros(0), {}, time.perf_counter() - start)


def _run(spec: RunSpec) -> RunData:
    """A closed-loop run of ``spec``, and the probes its experiment reads after it."""
    start = time.perf_counter()
    job = spec.job()
    backend = reused_backend(job)
    result = run_job(job, RunOptions(sample_every=spec.sample_every,
                                     max_cycles=spec.max_cycles,
                                     budget_offset=spec.budget_offset), backend)
    probes = {"busy": backend.probe("chipset.k3701.busy"),
              "remaining_x": Host8085(SimulatedLink(backend)).read("K3701", "X")}
    if spec.drain_cycles:
        limit = backend.cycle + spec.drain_cycles
        while not backend.probe("chipset.accel.idle") and backend.cycle < limit:
            backend.step(1000)
        probes["drained_cycle"] = backend.cycle
    probes["fp_total"] = backend.get("fp_total")
    for axis in AXES:
        probes[f"{axis}_command"] = backend.get(f"{axis}__command")
        probes[f"{axis}_steps"] = (backend.get(f"{axis}__pulses_pos")
                                   - backend.get(f"{axis}__pulses_neg"))
    return RunData(spec.key, result.report, result.samples, probes,
                   time.perf_counter() - start)


def start_at_full_feed(host: Host8085, block: Block) -> None:
    """Start the K3701 on ``block`` with the feed path wide open: the rate multiplier's input
    clock at every cycle and its word at the maximum, the budget at the maximum: FP in all but
    1 of 2^18 cycles."""
    host.command("K3701", ack=1, clear=1)
    for register, value in block_registers(block).items():
        host.write("K3701", register, value)
    host.command("K3701", start=1, ack=1)
    for chip, regmap, register in (("FEED", FEED_MAP, "RM_INC"), ("FEED", FEED_MAP, "FEED"),
                                   ("DECEL", DECEL_MAP, "BUDGET")):
        host.write(chip, register, regmap[register].bounds[1])


def max_rates(spec: RateSpec,
              backend_for: Callable[[Job], Backend] = reused_backend) -> RunData:
    """Step rates of the K3701 gateware with FP offered every cycle (``docs/chips/k3701.md``),
    each block on ``backend_for(spec.job())`` (default: this process's machine for it)."""
    start = time.perf_counter()
    probes: dict[str, int] = {}
    cycles, used = 0, set()
    for name, block, counter, steps in spec.blocks:
        backend = backend_for(spec.job())
        used.add(backend.name)
        start_at_full_feed(Host8085(SimulatedLink(backend)), block)
        backend.step(1000)  # past the start and the circle's radius check
        c0, n0 = backend.cycle, backend.get(counter)
        backend.step(steps * block.latency)
        probes[f"{name}_cycles"] = backend.cycle - c0
        probes[f"{name}_steps"] = backend.get(counter) - n0
        probes[f"{name}_busy"] = backend.probe("chipset.k3701.busy")
        probes[f"{name}_overrun"] = backend.probe("chipset.k3701.overrun")
        cycles += backend.cycle
    return RunData(spec.key, {"cycles": cycles, "backend": ", ".join(sorted(used))},
                   np.zeros(0), probes, time.perf_counter() - start)


def _execute(task: RunSpec | RateSpec | tuple[str, RunSpec | RateSpec]) -> RunData:
    """A worker's task: a run, the step-rate measurement, or ``("build", spec)``: build the
    model of ``spec``'s machine."""
    if isinstance(task, tuple):
        return _build(task[1])
    if isinstance(task, RateSpec):
        return max_rates(task)
    return _run(task)


def _worker_init() -> None:
    """A worker leaves Ctrl-C to the main process (which ends it) and ends with it."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    end_with_parent()


def run_all(specs: Specs, jobs: int = 2,
            progress: Callable[[str], None] | None = None) -> dict[str, RunData]:
    """Run ``specs`` in ``jobs`` worker processes; results by key.

    Each distinct machine (:func:`~k37.sim.run.runner.design_key`) is built once first, the builds
    in parallel; a machine's runs are queued as soon as its model is in the cache, so no model
    is compiled twice. The budget-too-low run follows the exact one (:func:`minus_spec`).
    """
    say = progress or (lambda _: None)
    by_design: dict[str, list[RunSpec | RateSpec]] = {}
    for spec in specs.values():
        by_design.setdefault(design_key(spec.job()), []).append(spec)
    results: dict[str, RunData] = {}
    context = multiprocessing.get_context("spawn")
    pool = ProcessPoolExecutor(max(1, jobs), mp_context=context, initializer=_worker_init)
    try:
        _run_pool(pool, specs, by_design, results, say)
    except BaseException:  # Ctrl-C, SIGTERM: no worker may go on with its run
        # the pool's processes (a private attribute: the executor has no public way to end
        # running tasks before Python 3.14's terminate_workers)
        stop_workers(list((getattr(pool, "_processes", None) or {}).values()))
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown()
    return results


def _run_pool(pool: ProcessPoolExecutor, specs: Specs,
              by_design: dict[str, list[RunSpec | RateSpec]], results: dict[str, RunData],
              say: Callable[[str], None]) -> None:
    """:func:`run_all`'s runs on ``pool``, into ``results``."""
    pending: dict[Future, str] = {pool.submit(_execute, ("build", group[0])): key
                                  for key, group in by_design.items()}
    while pending:
        done, _ = wait(pending, return_when=FIRST_COMPLETED)
        for future in done:
            key = pending.pop(future)
            data = future.result()
            results[data.key] = data
            cycles = data.report.get("cycles")
            what = f", {cycles / 1e6:.1f} M cycles" if cycles else ""
            say(f"{data.key}: {data.seconds:.1f} s{what}")
            if key in by_design:
                pending.update({pool.submit(_execute, spec): spec.key
                                for spec in by_design[key]})
            elif key == "hazard_exact":
                minus = minus_spec(data, specs["hazard_exact"])  # type: ignore[arg-type]
                pending[pool.submit(_execute, minus)] = minus.key
