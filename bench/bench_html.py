"""What ``--html`` costs on a 3-D CAM program of about 3,000 blocks, against the run, and how
large the page of a five-million-sample run is.

Run with ``pytest bench/bench_html.py --benchmark-only -s`` (or ``python -m bench.bench_html
[FOLDER]`` from the checkout's root, which keeps the pages in FOLDER). The program is a
surface-finishing pass in the style of CAM output (:func:`tests.programs.surface_finish`):
30 zigzag rows of 100 moves of 0.25 mm at F2400, each moving X, Y and Z over a wavy surface
(3,034 blocks, about 19 s of machine time), on per-axis accel/decel with a 9 ms time
constant. Timed in one process, after a warm-up run (the compiled machine built, plotly.js
read): the run (simulation and report), the page (the samples read back with their contour
error, the levels, the page written) and, where Chromium and Playwright are installed, the
page's opening (until both figures are drawn); at the default sampling (every 1000 cycles)
and every 4 cycles (5.4 million samples). The goals: the page costs at most half of the run,
and a five-million-sample run's page is at most 25 MB and opens in at most 30 s.
"""

from __future__ import annotations

import time
from pathlib import Path

from bench.output_timing import benchmark_measure, main, timed_run
from k37.sim.run.output import write_html
from tests.programs import surface_finish

#: Debian's Chromium and the switches the browser tests use (nothing fetched).
CHROMIUM = Path("/usr/bin/chromium")
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
        "--disable-background-networking", "--disable-component-update", "--disable-sync"]
#: The bound on a page's size (bytes).
PAGE_BOUND = 25_000_000
#: The bound on a page's opening in headless Chromium without a GPU (s).
OPEN_BOUND_S = 30.0


def surface_job(folder: Path) -> Path:
    (folder / "surface.ngc").write_text(surface_finish() + "\n")
    job = folder / "surface.toml"
    job.write_text('name = "3-D surface finish"\n[machine]\naxes = 3\naccel = "post"\n'
                   'accel_bits = 10\n[program]\nfile = "surface.ngc"\n')
    return job


def opening_seconds(page: Path) -> float | None:
    """Seconds from asking headless Chromium for ``page`` to both figures drawn (None: no
    Chromium or no Playwright here)."""
    if not CHROMIUM.exists():
        return None
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        return None
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=str(CHROMIUM), args=ARGS)
        tab = browser.new_page(viewport={"width": 1300, "height": 900})
        start = time.perf_counter()
        tab.goto(page.resolve().as_uri())
        tab.wait_for_selector("#part .main-svg")
        tab.wait_for_selector("#series .main-svg")
        seconds = time.perf_counter() - start
        browser.close()
    return seconds


def _timed(job: Path, sample_every: int, page: Path) -> dict[str, float]:
    result, timing = timed_run(job, sample_every)
    start = time.perf_counter()
    write_html(result, page)
    return {**timing, "page": time.perf_counter() - start, "mb": page.stat().st_size / 1e6,
            "open": opening_seconds(page)}


def measure(folder: Path) -> list[str]:
    job = surface_job(folder)
    _timed(job, 100_000, folder / "warm.html")  # build the machine, read plotly.js
    lines = []
    for every in (1000, 4):
        t = _timed(job, every, folder / f"surface_every{every}.html")
        lines.append(
            f"3-D surface, {t['blocks']:,} blocks, {t['samples']:,} samples: run "
            f"{t['run']:.2f} s; page {t['page']:.2f} s = {100 * t['page'] / t['run']:.0f}% of "
            f"the run; {t['mb']:.1f} MB (bound {PAGE_BOUND / 1e6:.0f} MB); "
            + ("no Chromium here to open it" if t["open"] is None else
               f"opened and drawn in headless Chromium in {t['open']:.1f} s (bound "
               f"{OPEN_BOUND_S:.0f} s)"))
        assert t["mb"] * 1e6 <= PAGE_BOUND
        assert t["open"] is None or t["open"] <= OPEN_BOUND_S
    return lines


def test_html_of_a_3d_cam_program_costs_a_fraction_of_its_run(benchmark, tmp_path: Path):
    benchmark_measure(benchmark, measure, tmp_path)


if __name__ == "__main__":
    main(measure)
