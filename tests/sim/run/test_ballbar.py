"""Ballbar figures as ISO 230-4 practice gives them: the feed-in and feed-out left out by
default, a settle angle checked against the program's sweep, reversal figures only for the
reversals swept, and a polar plot with a radial scale in LSB and um drawing only the
circle's own samples."""

from __future__ import annotations

import math

import numpy as np
import pytest

from k37.sim.cli import main
from k37.sim.run.ballbar import (
    BallbarError,
    arc_sweep,
    ballbar_figure,
    break_at_gaps,
    check_settle,
    circle_figures,
    feed_in_out,
)
from k37.sim.run.report import RUN_SCHEMA, validate


def arc_samples(start_deg: float, sweep_deg: float, n: int = 2000, radius: float = 10_000,
                ramp_s: float = 0.0) -> tuple[np.ndarray, ...]:
    """Samples of a CCW arc run in 1 s of steady speed (after a ramp of ``ramp_s`` at half
    the speed and before one as long): t, x, y relative to the centre."""
    t = np.linspace(0, 1 + 2 * ramp_s, n)
    rate = np.where((t < ramp_s) | (t > 1 + ramp_s), 0.5, 1.0)
    angle = np.concatenate([[0], np.cumsum(rate[1:] * np.diff(t))])
    angle = math.radians(start_deg) + angle / angle[-1] * math.radians(sweep_deg)
    return t, radius * np.cos(angle), radius * np.sin(angle)


def test_a_half_circle_reports_only_the_reversal_it_sweeps_across():
    t, x, y = arc_samples(0, 180)
    b = circle_figures(t, x, y, 10_000)
    figures = b.figures()
    assert figures["reversal_spike_90"] is not None
    assert figures["reversal_spike_0"] is None and figures["reversal_spike_180"] is None
    assert figures["reversal_spike_270"] is None
    # a report carrying them is valid: null is the schema's "not swept"
    spike = RUN_SCHEMA["properties"]["ballbar"]["properties"]["reversal_spike_270"]
    assert "null" in spike["type"] and "null" in spike["description"]
    validate(figures, RUN_SCHEMA["properties"]["ballbar"])


def test_a_circle_from_45_degrees_sweeps_across_every_reversal():
    t, x, y = arc_samples(45, 360)
    assert None not in circle_figures(t, x, y, 10_000).reversal_spikes


def test_by_default_the_feed_in_and_feed_out_are_left_out():
    t, x, y = arc_samples(0, 360, ramp_s=0.1)
    everything = circle_figures(t, x, y, 10_000, settle_deg=0)
    iso = circle_figures(t, x, y, 10_000, settle_deg=None)
    assert everything.sweep == pytest.approx(360, abs=0.5)
    # the ramps at half speed cover 360 * 0.05 / 1.1 = 16.4 degrees at each end
    assert iso.sweep == pytest.approx(360 - 2 * 16.4, abs=1.5)
    keep = feed_in_out(t, np.unwrap(np.arctan2(y, x)))
    assert not keep[t < 0.09].any() and not keep[t > 1.11].any()
    assert keep[(t > 0.1) & (t < 1.1)].all()


def test_a_settle_angle_leaves_out_the_first_degrees_only():
    t, x, y = arc_samples(0, 360)
    assert circle_figures(t, x, y, 10_000, settle_deg=90).sweep == pytest.approx(270, abs=0.5)


def test_a_settle_angle_of_the_whole_sweep_is_refused(make_job):
    job = make_job("G17 G21 G90 F1200\nG03 I-10 J0\nM30")
    assert arc_sweep(job) == pytest.approx(360)
    check_settle(job, 359)
    with pytest.raises(BallbarError, match="sweep 360 degrees"):
        check_settle(job, 400)
    check_settle(make_job("G21 G90 F600\nG01 X1\nM30"), 400)  # no circle: the run warns


def test_k37_run_refuses_a_settle_angle_beyond_the_sweep_before_running(tmp_path, capsys):
    job = tmp_path / "circle.ngc"
    job.write_text("G17 G21 G90 F1200\nG03 I-10 J0\nM30\n")
    assert main(["run", str(job), "--ballbar", str(tmp_path / "b.png"),
                 "--ballbar-settle", "400", "-q"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("k37: error: --ballbar-settle 400:") and "360 degrees" in err
    assert len(err.splitlines()) == 1 and not (tmp_path / "b.png").exists()


def test_too_few_samples_after_the_settle_angle_blame_the_angle():
    t, x, y = arc_samples(0, 360, n=200)
    with pytest.raises(BallbarError, match="once the first 359 degrees are left out"):
        circle_figures(t, x, y, 10_000, settle_deg=359)


def test_break_at_gaps_puts_a_nan_where_the_data_jump():
    x = np.array([0.0, 1, 2, 3, 40, 41, 42])
    bx, by = break_at_gaps(x, 10 * x)
    assert np.isnan(bx[4]) and np.isnan(by[4]) and len(bx) == 8
    assert np.array_equal(break_at_gaps(x[:4])[0], x[:4])


def test_the_polar_plot_has_a_radial_scale_in_lsb_and_um_and_no_chord_across_a_gap():
    t, x, y = arc_samples(0, 360)
    # a data gap from 100 to 200 degrees
    angle = np.degrees(np.arctan2(y, x)) % 360
    kept = (angle < 100) | (angle > 200)
    b = circle_figures(t[kept], x[kept] * 1.0001, y[kept] * 1.0001, 10_000)
    fig = ballbar_figure(b, "test", lsb_mm=0.002)
    ax = fig.axes[0]
    fig.canvas.draw()
    labels = [t.get_text() for t in ax.get_yticklabels() if t.get_text()]
    assert any(" LSB = " in s and s.endswith(" um") for s in labels)
    one = next(s for s in labels if s.startswith("+"))
    lsb, um = (float(part.split()[0]) for part in one.split(" = "))
    assert um == pytest.approx(2 * lsb, rel=0.01)
    measured = next(line for line in ax.lines if line.get_label() == "measured")
    theta = np.asarray(measured.get_xdata(), dtype=float)
    assert np.isnan(theta).sum() == 1  # the line stops at the gap and starts again after it
    assert np.nanmax(np.abs(np.diff(theta))) < math.radians(5)
