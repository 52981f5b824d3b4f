"""The ``--plot`` figure shows what the run measured: the report's contour error, the blocks'
boundaries at their start cycles, speeds in mm/min that reach the programmed feed."""

from __future__ import annotations

import numpy as np
import pytest

from k37.sim.run import plot as plot_module
from k37.sim.run import plot_data as plot_data_module
from k37.sim.run.contour import contour_errors
from k37.sim.run.plot import BOUNDARY, figure, windowed_speed
from k37.sim.run.plot_data import BlockContour, plot_data
from k37.sim.run.runner import RunOptions, run_job

GCODE = "G21 G90 F1200\nG01 X60\nG04 P0.2\nG02 X70 Y0 I5 J0\nG00 X0 Y5\nM30"


@pytest.fixture(scope="module")
def run(make_job):
    return run_job(make_job(GCODE, name="plot"), RunOptions(sample_every=500))


@pytest.fixture(scope="module")
def panels(run):
    return {ax.get_title().split(" (")[0]: ax for ax in figure(run).axes if ax.get_title()}


def test_the_figure_has_every_panel_with_units_on_its_axes(panels):
    assert set(panels) == {"path: programmed", "contour error per block", "contour error",
                           "following error", "speeds", "D/A output"}
    for ax in panels.values():
        assert ax.get_xlabel() and ax.get_ylabel()
    units = {title: ax.get_ylabel() for title, ax in panels.items()}
    assert units["speeds"] == "mm/min" and units["D/A output"] == "V"
    assert "(LSB)" in units["contour error"] and "(LSB)" in units["following error"]
    # LSB panels carry a second axis in mm
    for title in ("contour error per block", "contour error", "following error"):
        assert [c.get_ylabel() for c in panels[title].child_axes] == ["mm"]


def test_the_contour_panel_is_the_reports_contour_error(run, panels, monkeypatch):
    path = run.report["path"]
    # drawn as envelopes of a few samples each, it keeps the largest
    (line,) = panels["contour error"].lines[:1]
    assert len(line.get_ydata()) <= plot_module.SERIES_POINTS < path["samples"]
    assert np.max(line.get_ydata()) == pytest.approx(path["max_contour_error"], rel=1e-12)
    # with room for every sample, it draws every sample
    monkeypatch.setattr(plot_module, "SERIES_POINTS", path["samples"])
    every = {ax.get_title().split(" (")[0]: ax for ax in figure(run).axes}
    (line,) = every["contour error"].lines[:1]
    assert len(line.get_ydata()) == path["samples"]
    assert np.max(line.get_ydata()) == pytest.approx(path["max_contour_error"], rel=1e-12)
    assert np.sqrt(np.mean(np.square(line.get_ydata()))) == pytest.approx(
        path["rms_contour_error"], rel=1e-9)
    bars = [p.get_height() for p in panels["contour error per block"].patches]
    blocks = len(run.report["blocks"])
    assert len(bars) == 2 * blocks  # max and RMS per block
    assert max(bars[:blocks]) == pytest.approx(path["max_contour_error"], rel=1e-12)


def boundaries(ax) -> list[float]:
    """The times of the block boundary lines of a time panel."""
    (lines,) = [c for c in ax.collections if c.get_gid() == BOUNDARY]
    return [float(seg[0, 0]) for seg in lines.get_segments()]


def test_block_boundaries_are_at_the_blocks_start_cycles(run, panels):
    clock = run.report["clock_hz"]
    starts = [b["start_cycle"] / clock for b in run.report["blocks"]]
    assert len(starts) == 3
    for title in ("contour error", "following error", "speeds", "D/A output"):
        assert boundaries(panels[title]) == starts
        labels = [t.get_text().strip() for t in panels[title].texts]
        assert labels == [f"line {b['line']}" for b in run.report["blocks"]]


def test_blocks_are_labelled_by_the_programs_own_n_words(make_job):
    job = make_job("N10 G21 G90 F1200\nN30 G01 X2\nG01 Y2\nN50 G01 X0\nM30", name="nwords")
    assert job.program.sequence == {1: 10, 2: 30, 4: 50}
    result = run_job(job, RunOptions(sample_every=500))
    bars = next(ax for ax in figure(result).axes
                if ax.get_title().startswith("contour error per block"))
    assert [t.get_text().split("\n")[0] for t in bars.get_xticklabels()] == [
        "N30", "line 3", "N50"]


def test_path_speed_reaches_the_programmed_feed_in_a_blocks_steady_part(run, panels):
    clock = run.report["clock_hz"]
    # 60 mm at F1200: the feed goes in for 3 s; the FP circuit's output is within 1% of it
    # after 5 tau (tau = 0.3 s) and until the feed stops
    start = run.report["blocks"][0]["start_cycle"] / clock
    path = next(ln for ln in panels["speeds"].lines if ln.get_label() == "path")
    t, v = path.get_xdata(), path.get_ydata()
    steady = (t > start + 1.5) & (t < start + 3.0)
    assert steady.sum() > 500
    assert np.all(np.abs(v[steady] - 1200) < 0.01 * 1200)
    # no staircase of encoder counts: a constant speed reads constant
    assert np.ptp(v[steady]) < 15


def test_windowed_speed_is_the_position_change_over_the_window():
    cycles = np.arange(0, 10_000, 100.0)
    t, v = windowed_speed(cycles, 3.0 * cycles, 1e6, 20)
    assert np.allclose(v, 3e6) and t[0] == pytest.approx(1000 / 1e6)
    assert windowed_speed(cycles[:1], cycles[:1], 1e6, 20)[1].size == 0


def test_per_block_contour_error_takes_each_blocks_samples_in_any_chunks(run):
    s = run.samples
    blocks = run.report["blocks"]
    errors = contour_errors(run.job, [(b["index"], b["start_cycle"]) for b in blocks], s)
    starts = [b["start_cycle"] for b in blocks]
    whole, halves = BlockContour(starts), BlockContour(starts)
    whole.add(s[:, 0], errors)
    cut = len(s) // 3
    halves.add(s[:cut, 0], errors[:cut])
    halves.add(s[cut:, 0], errors[cut:])
    second = (s[:, 0] >= blocks[1]["start_cycle"]) & (s[:, 0] < blocks[2]["start_cycle"])
    peak, rms = whole.stats()[1]
    assert peak == errors[second].max()
    assert rms == pytest.approx(np.sqrt(np.mean(errors[second] ** 2)), rel=1e-12)
    assert np.allclose(halves.stats(), whole.stats(), rtol=1e-12, atol=0)


def test_a_long_run_is_plotted_from_buckets_with_every_peak_kept(run, monkeypatch):
    blocks = [(b["index"], b["start_cycle"]) for b in run.report["blocks"]]
    full = plot_data(run.job, blocks, run.store)
    few = plot_data(run.job, blocks, run.store, buckets=50)
    assert full.bucket == 1 and len(full.rows) == run.report["path"]["samples"]
    assert few.bucket > 1 and len(few.rows) <= 50
    for column in ("contour_error", "x_error", "y_dac_volts"):
        low, high = few.envelope(column)
        all_low, all_high = full.envelope(column)
        assert high.max() == all_high.max() and low.min() == all_low.min()
    assert np.allclose(few.blocks, full.blocks, rtol=1e-12, atol=0)
    assert max(peak for peak, _ in few.blocks) == run.report["path"]["max_contour_error"]
    # the figure reads the store in buckets and never loads the whole run
    monkeypatch.setattr(plot_data_module, "PLOT_BUCKETS", 50)
    monkeypatch.setattr(type(run.store), "array", lambda _: pytest.fail("loaded it all"))
    panels = {ax.get_title().split(" (")[0]: ax for ax in figure(run).axes}
    band = panels["contour error"].collections[0]
    assert band.get_paths()[0].vertices[:, 1].max() == pytest.approx(
        run.report["path"]["max_contour_error"], rel=1e-12)
