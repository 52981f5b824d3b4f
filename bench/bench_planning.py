"""What planning costs, each figure against another measured in the same run.

Run with ``pytest bench/bench_planning.py --benchmark-only -s``. The host plans an arc's
FP count and end from its geometry (:func:`k37.firmware_model.motion.arcs.plan_block`) instead of
walking every step as the reference model does (:func:`k37.hdl.k3701.model.chip.plan`), helices
included; ``k37 plan`` of a thousand-line program is timed as a whole command, and the
planning of a ten-thousand-line one (:func:`tests.programs.mixed_program`, shared with the
tests) on its own.
"""

from __future__ import annotations

import time
from pathlib import Path

from k37.firmware_model.job import MachineConfig, parse_for_machine
from k37.firmware_model.motion.arcs import plan_block
from k37.hdl.k3701.block import Block
from k37.hdl.k3701.model.chip import plan
from k37.sim.cli import main
from tests.programs import mixed_program


def test_a_large_circle_plans_far_faster_than_its_walk(benchmark):
    # a full circle of radius 200,000 LSB: about 1.1 million steps for the walk
    block = Block.arc(0, 0, -200_000, 0, sqrt2=True)
    start = time.perf_counter()
    walked = plan(block)
    walk = time.perf_counter() - start
    planned = benchmark(plan_block, block)
    fast = benchmark.stats.stats.min
    assert (planned.end, planned.fp) == (walked.end, walked.fp)
    print(f"\nR 200,000 LSB circle: planned in {1e3 * fast:.2f} ms, walked in {walk:.2f} s "
          f"(x{walk / fast:,.0f})")
    assert walk / fast > 100


def test_a_large_helix_plans_far_faster_than_its_walk(benchmark):
    # a full turn of radius 254,000 LSB (254 mm at 1 um) rising 100 mm: about 1.4 million
    # steps for the walk
    block = Block.arc(0, 0, -254_000, 0, sqrt2=True, ze=100_000)
    start = time.perf_counter()
    walked = plan(block)
    walk = time.perf_counter() - start
    planned = benchmark(plan_block, block)
    fast = benchmark.stats.stats.min
    assert planned == walked
    print(f"\nR 254,000 LSB helix: planned in {1e3 * fast:.2f} ms, walked in {walk:.2f} s "
          f"(x{walk / fast:,.0f})")
    assert walk / fast > 20


def test_plan_command_of_a_thousand_lines(benchmark, tmp_path: Path, capsys):
    path = tmp_path / "big.ngc"
    path.write_text(mixed_program(1000))
    assert benchmark.pedantic(main, args=(["plan", str(path)],), rounds=3, iterations=1) == 0
    capsys.readouterr()
    print(f"\nk37 plan of 1,000 lines: {benchmark.stats.stats.min:.3f} s")


def test_planning_ten_thousand_lines(benchmark):
    # the front end and the planner (k37 plan without the start of Python and the table):
    # 5,000 lines and 5,000 arcs; the goal is under a second
    text = mixed_program(10_000)
    machine, program = benchmark.pedantic(
        parse_for_machine, args=(MachineConfig(), text), kwargs={"source": "<10k>"},
        rounds=3, iterations=1)
    assert machine.axes == 2 and len(program.moves) >= 9_999
    print(f"\nplanning 10,000 lines ({len(program.moves):,} blocks): "
          f"{benchmark.stats.stats.min:.3f} s")
