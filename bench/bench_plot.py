"""What ``--plot`` costs on a CAM program of thousands of short blocks, against the run.

Run with ``pytest bench/bench_plot.py --benchmark-only -s`` (or ``python bench/bench_plot.py
[FOLDER]``, which keeps the figure in FOLDER). The program is a zigzag pocket of 25 rows of
101 blocks of 0.25 mm at F2400 (2,526 blocks, 17.8 s of machine time) on per-axis accel/decel
with a 9 ms time constant. Timed in one process, after a warm-up run (the compiled machine
built, matplotlib imported): the run (simulation and report), the figure's data (the
samples read back and their contour error), and drawing and writing the PNG; at the default
sampling (every 1000 cycles) and every 10 cycles (1.8 million samples). The goal: the plot
costs at most 20% of the run beyond matplotlib's fixed cost of drawing six panels, which the
three-block demo's figure costs too (printed beside it).
"""

from __future__ import annotations

import math
import time
from pathlib import Path

from bench.output_timing import benchmark_measure, main, timed_run
from k37.sim.run.plot import figure

HERE = Path(__file__).resolve().parent
DEMO = HERE.parent / "examples" / "circle.toml"


def pocket_gcode(rows: int = 25, per_row: int = 100) -> str:
    """A zigzag pocket: ``rows`` rows of ``per_row`` 0.25 mm blocks with a 0.05 mm wiggle."""
    lines = ["G17 G21 G90 F2400", "G00 X0 Y0"]
    for row in range(rows):
        xs = [k * 0.25 for k in range(per_row + 1)]
        for k, x in enumerate(xs[::-1] if row % 2 else xs):
            lines.append(f"G01 X{x:.3f} Y{row + 0.05 * math.sin(k):.3f}")
    return "\n".join([*lines, "M30"])


def pocket_job(folder: Path) -> Path:
    (folder / "pocket.ngc").write_text(pocket_gcode() + "\n")
    job = folder / "pocket.toml"
    job.write_text('name = "zigzag pocket"\n[machine]\naccel = "post"\naccel_bits = 10\n'
                   '[program]\nfile = "pocket.ngc"\n')
    return job


def _timed(job: Path, sample_every: int, png: Path) -> dict[str, float]:
    result, timing = timed_run(job, sample_every)
    start = time.perf_counter()
    fig = figure(result)
    built = time.perf_counter()
    fig.savefig(png, dpi=100)
    done = time.perf_counter()
    return {**timing, "figure": built - start, "draw": done - built, "plot": done - start,
            "kib": png.stat().st_size / 1024}


def measure(folder: Path) -> list[str]:
    job = pocket_job(folder)
    _timed(DEMO, 1000, folder / "warm.png")  # build the machine, import matplotlib
    demo = _timed(DEMO, 1000, folder / "demo.png")
    lines = [f"demo (3 blocks): plot {demo['plot']:.2f} s (figure data {demo['figure']:.2f} s, "
             f"drawing {demo['draw']:.2f} s)"]
    for every in (1000, 10):
        t = _timed(job, every, folder / f"pocket_every{every}.png")
        lines.append(
            f"pocket, {t['blocks']:,} blocks, {t['samples']:,} samples: run {t['run']:.2f} s; "
            f"plot {t['plot']:.2f} s = {100 * t['plot'] / t['run']:.0f}% of the run (figure "
            f"data {t['figure']:.2f} s, drawing {t['draw']:.2f} s); beyond the demo's "
            f"{t['plot'] - demo['plot']:.2f} s = "
            f"{100 * (t['plot'] - demo['plot']) / t['run']:.0f}%; PNG {t['kib']:.0f} KiB")
    return lines


def test_plot_of_a_cam_program_costs_a_fraction_of_its_run(benchmark, tmp_path: Path):
    benchmark_measure(benchmark, measure, tmp_path)


if __name__ == "__main__":
    main(measure)
