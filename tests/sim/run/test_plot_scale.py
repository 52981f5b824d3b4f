"""The ``--plot`` figure of a program of many short blocks reads as the demo's does: labels
thinned to what fits, bars for the worst blocks only, time panels not greyed by block lines,
every series one artist."""

from __future__ import annotations

import math

import numpy as np
import pytest

from k37.firmware_model.job import MachineConfig
from k37.sim.run.plot import (
    BOUNDARY,
    MAX_BOUNDARIES,
    MAX_LABELS,
    WORST_BLOCKS,
    bars_that_fit,
    figure,
    marked_blocks,
    thin,
)
from k37.sim.run.runner import RunOptions, run_job


def zigzag(rows: int, per_row: int, step_mm: float = 0.25, pitch_mm: float = 1.0) -> str:
    """A CAM-style pocket: ``rows`` rows of ``per_row`` short G01 blocks with a small
    wiggle, alternating direction."""
    lines = ["G17 G21 G90 F2400"]
    for row in range(rows):
        xs = [k * step_mm for k in range(per_row + 1)]
        for k, x in enumerate(xs[::-1] if row % 2 else xs):
            lines.append(f"G01 X{x:.3f} Y{row * pitch_mm + 0.05 * math.sin(k):.3f}")
    return "\n".join([*lines, "M30"])


@pytest.fixture(scope="module")
def many(make_job):
    job = make_job(zigzag(4, 50), MachineConfig(accel="post", accel_bits=10), name="pocket")
    return run_job(job, RunOptions(sample_every=200))


@pytest.fixture(scope="module")
def panels(many):
    return {ax.get_title().split(" (")[0]: ax for ax in figure(many).axes if ax.get_title()}


def test_the_program_has_more_blocks_than_the_figure_marks(many):
    assert len(many.report["blocks"]) > max(MAX_BOUNDARIES, WORST_BLOCKS, MAX_LABELS)


def test_bars_show_only_the_worst_blocks_in_program_order(many, panels):
    bars = panels["contour error per block"]
    shown = len(bars.get_xticks())
    assert shown == bars_that_fit([f"line {b['line']}" for b in many.report["blocks"]])
    assert 0 < shown <= WORST_BLOCKS and len(bars.patches) == 2 * shown
    heights = [p.get_height() for p in bars.patches[:shown]]
    assert max(heights) == pytest.approx(many.report["path"]["max_contour_error"], rel=1e-12)
    lines = [int(t.get_text().split("\n")[0].removeprefix("line "))
             for t in bars.get_xticklabels()]
    assert lines == sorted(lines)
    assert f"the {shown} worst of {len(many.report['blocks'])}" in bars.get_title()


def test_time_panels_mark_only_the_worst_blocks_starts(many, panels):
    clock = many.report["clock_hz"]
    starts = {b["start_cycle"] / clock for b in many.report["blocks"]}
    shown = len(panels["contour error per block"].get_xticks())
    for title in ("contour error", "following error", "speeds", "D/A output"):
        times = [float(s[0, 0]) for c in panels[title].collections if c.get_gid() == BOUNDARY
                 for s in c.get_segments()]
        assert len(times) == shown and set(times) <= starts
        assert len(panels[title].texts) <= shown


def test_labels_are_few_and_do_not_overlap(panels):
    for title, ax in panels.items():
        assert len(ax.texts) <= MAX_LABELS, title
        xs = sorted(t.get_position()[0] for t in ax.texts)
        if title not in ("path: programmed", "contour error per block") and len(xs) > 1:
            span = np.ptp(ax.get_xlim())
            assert np.min(np.diff(xs)) / span > 0.04


def test_every_series_is_one_artist_whatever_the_block_count(panels):
    assert len(panels["path: programmed"].lines) <= 3 + MAX_LABELS
    assert len(panels["speeds"].collections) == 2  # the feed steps and the boundaries


def test_thin_keeps_the_most_wanted_labels_that_do_not_overlap():
    positions = np.array([0.0, 0.01, 0.5, 0.52, 0.9])
    assert thin(positions, [3, 0, 1, 2, 4], 0.05) == [3, 0, 4]
    assert thin(positions, range(5), 0.05, most=2) == [0, 2]
    # in two dimensions labels clash only when close in both
    points = np.array([[0.0, 0.0], [0.0, 0.5], [0.02, 0.01]])
    assert thin(points, range(3), (0.1, 0.05)) == [0, 1]


def test_marked_blocks_are_the_largest_in_program_order_then_the_rest():
    peaks = [1.0, 5.0, 3.0, 5.0, 0.5]
    bars, wanted = marked_blocks(peaks, most=2)
    assert bars == [1, 3] and wanted == [1, 3, 0, 2, 4]
    assert marked_blocks(peaks, most=10)[0] == [0, 1, 2, 3, 4]
