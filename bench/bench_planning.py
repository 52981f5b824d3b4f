"""What planning costs, each figure against another measured in the same run.

Run with ``pytest bench/bench_planning.py --benchmark-only -s``. The host plans an arc's
FP count and end from its geometry (:func:`firmware_model.gcode.arcs.plan_block`) instead of
walking every step as the reference model does (:func:`hdl.k3701.model.plan`); ``k37 plan``
of a thousand-line program is timed as a whole command.
"""

from __future__ import annotations

import time
from pathlib import Path

from firmware_model.gcode.arcs import plan_block
from hdl.k3701.block import Block
from hdl.k3701.model import plan
from sim.cli import main


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
    lines = ["G21 G90 F1000"]
    for k in range(250):
        lines += [f"G01 X{k % 50}.{k % 7} Y{k % 13}", f"G02 X{k % 50 + 2}.{k % 7} "
                  f"Y{k % 13} I1 J0", "G01 X0 Y0", f"G03 I{1 + k % 9} J0"]
    path = tmp_path / "big.ngc"
    path.write_text("\n".join(lines[:1000]))
    assert benchmark.pedantic(main, args=(["plan", str(path)],), rounds=3, iterations=1) == 0
    capsys.readouterr()
    print(f"\nk37 plan of 1,000 lines: {benchmark.stats.stats.min:.3f} s")
