"""The speed goals of the compiled backend and of a run's own work, each against its goal.

Run with ``pytest bench/bench_goals.py --benchmark-only -s``; every figure is measured in
this one run and printed with its goal and the ratio (figure / goal for speeds, goal /
figure for costs: 1.0 or more meets the goal). Builds are excluded (each machine is built or
loaded before timing), except in the tiny job, which is a whole ``k37 run`` process with a
warm cache, start to exit.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from k37.firmware_model.feeds import check_program
from k37.firmware_model.job import Job, demo_job, gcode_job
from k37.sim.run.contour import contour_errors
from k37.sim.run.runner import RunOptions, build_backend, run_job
from k37.sim.run.sampler import TRACE_COLUMNS

ROOT = Path(__file__).resolve().parent.parent
#: A line at the K3701's top linear feed (5,454 mm/min at 1 MHz and 1 um per pulse).
TOP_FEED_GCODE = "G21 G91 F5400\nG01 X100\nM30\n"
#: The paper's low feed (feed word 0x00FF, 88 FP/s = 5.3 mm/min) on a 1 mm circle.
LOW_FEED_GCODE = "G21 G91 F5.3\nG03 X0 Y0 I0.5 J0\nM30\n"
TINY_GCODE = "G21 G91 F600\nG01 X0.1\nM30\n"


def _events(report: dict) -> int:
    """Feed pulses, step pulses and encoder counts of a run (each step moves its encoder by
    one count, give or take the servo's final lag)."""
    fp = sum(b["fp_pulses"] for b in report["blocks"])
    steps = sum(sum(b["steps"].values()) for b in report["blocks"])
    return fp + 2 * steps


def _evaluated_per_event(report: dict) -> float:
    """The cycles a run evaluated (not skipped) per event."""
    return (report["cycles"] - report["skipped_cycles"]) / _events(report)


def _timed_run(job: Job) -> dict:
    backend = build_backend(job, "cxxrtl")  # built (or loaded) outside the timing
    report = run_job(job, RunOptions(backend="cxxrtl"), backend).report
    backend.close()
    return report


def _show(name: str, figure: float, unit: str, goal: float, higher_is_better: bool) -> None:
    ratio = figure / goal if higher_is_better else goal / figure
    print(f"\n{name}: {figure:,.4g} {unit} (goal {'>=' if higher_is_better else '<='} "
          f"{goal:,.4g} {unit}; ratio {ratio:.3f})")


@pytest.mark.parametrize(("name", "gcode", "goal"), [
    ("demo", None, 5e7), ("top-feed line", TOP_FEED_GCODE, 1e7),
    ("low-feed circle", LOW_FEED_GCODE, 1e9)])
def test_cycles_per_second(benchmark, name, gcode, goal):
    """The fastest of three runs (a shared machine's runs of the same code vary by up to
    1.5x)."""
    job = demo_job() if gcode is None else gcode_job(name, gcode, f"<{name}>")
    reports: list[dict] = []
    benchmark.pedantic(lambda: reports.append(_timed_run(job)), rounds=3, iterations=1)
    report = max(reports, key=lambda r: r["cycles_per_second"])
    _show(f"{name}: {report['cycles']:,} cycles, best of 3", report["cycles_per_second"],
          "cycles/s", goal, True)
    if gcode is None:
        per_event = report["wall_seconds"] / _events(report) * 1e6
        _show(f"demo, {_events(report):,} events", per_event, "us/event", 0.25, False)
        print(f"demo: {report['cycles'] - report['skipped_cycles']:,} cycles evaluated, "
              f"{_evaluated_per_event(report):.2f} per event")


def test_an_evaluated_cycle_at_rest_bounds_the_cost_per_event(benchmark):
    """Not a goal: the floor under the demo's cost per event. After the demo, with the axes
    at rest, cycles are evaluated without skipping, so only the free-running clocks move;
    the demo's evaluated cycles per event (the RTL's pipelines) times this cost is a lower
    bound on its cost per event, before the pipelines' own work and the skips."""
    job = demo_job()
    backend = build_backend(job, "cxxrtl")
    report = run_job(job, RunOptions(backend="cxxrtl"), backend).report
    cycles = 2_000_000

    costs: list[float] = []  # us per cycle

    def at_rest() -> None:
        start = time.perf_counter()
        backend.step(cycles, skip_idle=False)
        costs.append((time.perf_counter() - start) / cycles * 1e6)

    benchmark.pedantic(at_rest, rounds=3, iterations=1)
    backend.close()
    floor = min(costs)
    per_event = _evaluated_per_event(report)
    print(f"\nan evaluated cycle at rest: {floor:.4f} us; x {per_event:.2f} evaluated cycles "
          f"per event on the demo = {floor * per_event:.3f} us per event at least (goal 0.25)")


def test_tiny_job_with_a_warm_cache_start_to_exit(benchmark, tmp_path):
    job = tmp_path / "tiny.toml"
    job.write_text(f'[program]\ngcode = """\n{TINY_GCODE}"""\n')
    command = [sys.executable, "-m", "k37.sim.cli", "run", str(job), "-q"]
    # As a user's: Python writes its bytecode cache (the warm-up writes it, as it writes the
    # model cache) even where the benchmark's own environment says not to.
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPATH"] = str(ROOT)
    subprocess.run(command, check=True, env=env)  # warm the caches

    def run() -> float:
        start = time.perf_counter()
        subprocess.run(command, check=True, env=env)
        return time.perf_counter() - start

    seconds = benchmark.pedantic(run, rounds=3, iterations=1)
    _show("tiny job, k37 run process", min(seconds, benchmark.stats.stats.min), "s", 0.3, False)


#: A child that runs the command line and prints its own peak resident memory (kB) last.
_PEAK_RSS = ("import atexit, resource, runpy, sys; atexit.register(lambda: print("
             "resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, file=sys.stderr)); "
             "sys.argv = ['k37', *sys.argv[1:]]; "
             "runpy.run_module('k37.sim.cli', run_name='__main__')")


def test_memory_is_flat_in_the_runs_length(benchmark, tmp_path):
    """A circle, then a dwell of 10 s, 100 s or 1,000 s (10^7 to 10^9 cycles, 10^4 to 10^6
    samples): a whole ``k37 run`` process's peak memory (its samples stream to disk)."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPATH"] = str(ROOT)

    def peak(seconds: int) -> int:
        job = tmp_path / f"dwell{seconds}.toml"
        job.write_text(f'[program]\ngcode = """\nG21 G91 F600\nG02 X0 Y0 I2 J0\n'
                       f'G04 P{seconds}\nM30\n"""\n')
        done = subprocess.run([sys.executable, "-c", _PEAK_RSS, "run", str(job), "-q",
                               "--max-cycles", "2000000000"],
                              check=True, env=env, capture_output=True, text=True)
        return int(done.stderr.split()[-1])

    peak(10)  # warm the caches
    small, middle = peak(10), peak(100)
    large = benchmark.pedantic(peak, args=(1000,), rounds=1, iterations=1)
    print(f"\npeak memory of a run of 10^7 / 10^8 / 10^9 cycles: {small / 1024:.1f} / "
          f"{middle / 1024:.1f} / {large / 1024:.1f} MiB: x{large / small:.2f} for x100 the "
          f"length (flat: 1)")


def _zigzag(blocks: int) -> Job:
    """A program of ``blocks`` short lines and arcs."""
    moves = "\n".join(f"G01 X{(k % 2) * 2} Y{k * 0.01:.3f}\nG02 X{(k % 2) * 2 + 1} "
                      f"Y{k * 0.01:.3f} I0.5 J0" for k in range(blocks // 2))
    return gcode_job("zigzag", f"G21 G90 F600\n{moves}\nM30\n", "<zigzag>")


def test_planning_is_linear_in_the_programs_size(benchmark):
    def plan(blocks: int) -> float:
        start = time.perf_counter()
        check_program(_zigzag(blocks))  # parsed and planned, then checked
        return time.perf_counter() - start

    small = plan(200)
    large = benchmark.pedantic(plan, args=(2000,), rounds=1, iterations=1)
    print(f"\nplanning 200 blocks {small:.3f} s, 2,000 blocks {large:.3f} s: "
          f"x{large / small:.1f} for x10 the blocks (linear: 10)")


def test_contour_error_is_linear_in_the_programs_size(benchmark):
    """100 samples per block, each against the moves of its block and its neighbours."""
    def contour(blocks: int) -> float:
        job = _zigzag(blocks)
        moves = list(job.program.moves)
        starts = [(move.index, 1000 * k) for k, move in enumerate(moves)]
        rows = 100 * len(moves)
        rng = np.random.default_rng(1)
        samples = np.zeros((rows, len(TRACE_COLUMNS)), dtype=np.int64)
        samples[:, 0] = np.sort(rng.integers(0, 1000 * len(moves), rows))
        samples[:, 3:5] = rng.integers(0, 4000, (rows, 2))
        start = time.perf_counter()
        contour_errors(job, starts, samples)
        return time.perf_counter() - start

    small = contour(200)
    large = benchmark.pedantic(contour, args=(2000,), rounds=1, iterations=1)
    print(f"\ncontour error, 200 blocks {small:.3f} s, 2,000 blocks {large:.3f} s: "
          f"x{large / small:.1f} for x10 the blocks and samples (linear: 10)")
    assert large / small < 30, "the contour error grows faster than the program"


def _lagging_tool(job: Job, per_block: int, lag: int) -> tuple[list[tuple[int, int]], np.ndarray]:
    """The blocks of ``job`` started every 1,000 cycles and ``per_block`` samples a block of a
    tool ``lag`` blocks behind the interpolator, 3 LSB off the path."""
    moves = list(job.program.moves)
    starts = [(move.index, 1000 * k) for k, move in enumerate(moves)]
    u = np.linspace(0.0, 1.0, per_block, endpoint=False)
    points = []
    for move in moves:
        a, b = np.array(move.start[:2], dtype=float), np.array(move.end[:2], dtype=float)
        if hasattr(move, "center"):  # an arc: round its centre
            c = np.array(move.center, dtype=float)
            a0, sweep = move.span
            angle = a0 + (-sweep if move.cw else sweep) * u
            points.append(c + (move.radius + 3) * np.column_stack([np.cos(angle), np.sin(angle)]))
        else:
            points.append(a + np.outer(u, b - a) + 3)
    rows = per_block * len(moves)
    samples = np.zeros((rows, len(TRACE_COLUMNS)), dtype=np.int64)
    samples[:, 0] = np.arange(rows) * (1000 // per_block) + 1000 * lag
    samples[:, 3:5] = np.rint(np.vstack(points))
    return starts, samples


def test_contour_error_of_a_lagging_tool_costs_the_same_per_sample(benchmark):
    """A tool two blocks behind the interpolator on 10,000 blocks, 50 samples a block."""
    job = _zigzag(10_000)
    starts, samples = _lagging_tool(job, 50, 2)

    def contour() -> float:
        start = time.perf_counter()
        contour_errors(job, starts, samples)
        return time.perf_counter() - start

    took = benchmark.pedantic(contour, rounds=1, iterations=1)
    print(f"\ncontour error of a lagging tool, 10,000 blocks: {took:.3f} s, "
          f"{took / len(samples) * 1e6:.2f} us a sample")
