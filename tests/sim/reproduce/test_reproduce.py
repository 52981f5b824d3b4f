"""``k37 reproduce``: the paper's experiments on the emulator, every row within tolerance.

The reproduction runs once per session at the quick scale (the closed-loop runs are millions
of cycles on the compiled backend, in two worker processes); the tests then check its rows,
its report and figures, and that a row really fails when the emulator's result is off.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from k37.firmware_model.feeds import feed_word, word_feed
from k37.sim.cli import build_parser
from k37.sim.reproduce.experiments import analyse, reproduce
from k37.sim.reproduce.paper import FEED_HIGH, FEED_LOW
from k37.sim.reproduce.runs import MACHINE, QUICK
from k37.sim.reproduce.theory import (
    fp_rate,
    hardware_tau,
    lag,
    servo,
    servo_radius_loss,
)


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("reproduce")
    return reproduce(out, quick=True), out


@pytest.mark.slow
def test_every_row_of_the_quick_reproduction_passes(quick):
    result, _ = quick
    failed = [f"{row.what}: {row.emulator} (tolerance: {row.tolerance})"
              for row in result.failed]
    assert not failed, "\n".join(failed)
    assert [s.number for s in result.sections] == [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11]
    assert all(s.rows for s in result.sections)


@pytest.mark.slow
def test_report_has_every_row_and_every_figure(quick):
    result, out = quick
    report = (out / "report.md").read_text()
    for row in result.rows:
        assert row.what.replace("|", "\\|") in report
    figures = [s.figure for s in result.sections if s.figure]
    assert len(figures) == 10
    for name in figures:
        assert f"]({name})" in report
        data = (out / name).read_bytes()
        assert data.startswith(b"\x89PNG")
        assert len(data) < 400_000
    assert "What was scaled down" in report and "Scale `quick`" in report


@pytest.mark.slow
def test_a_row_fails_when_the_emulator_is_off(quick, tmp_path):
    """The rows compare measured values: doctor one run and its row, and only it, fails."""
    result, _ = quick
    minus = result.runs["hazard_minus"]
    doctored = dataclasses.replace(minus, probes={**minus.probes, "busy": 0})
    runs = {**result.runs, "hazard_minus": doctored}
    failed = [row.what for row in analyse(runs, QUICK, tmp_path).failed]
    assert failed == ["budget one too low"]


def test_feed_words_of_the_paper_photos_map_back_to_their_feeds():
    machine = MACHINE["pre"]
    for word in (FEED_HIGH, FEED_LOW):
        assert feed_word(machine, word_feed(machine, word)) == word
    # W / 2^18 of the rate multiplier's clock, f_clk / 11.
    assert fp_rate(machine, FEED_HIGH) == pytest.approx(61695 / 2**18 * 1e6 / 11, rel=1e-6)
    assert hardware_tau(machine) == pytest.approx(0.3, rel=1e-6)


def test_models_match_their_closed_forms():
    t = np.arange(0, 2, 1e-3)
    step = lag(t, np.ones_like(t), 0.3)
    assert np.allclose(step, 1.0)  # from rest at the input's value: nothing moves
    ramp = lag(t, t, 0.3)  # a ramp through a lag trails it by tau
    assert t[-1] - ramp[-1] == pytest.approx(0.3 * (1 - math.exp(-t[-1] / 0.3)), rel=1e-9)
    following = t * 1000 - servo(t, t * 1000, 30.0, 0.01)
    assert following[-1] == pytest.approx(1000 / 30, rel=1e-6)  # v / Kp
    assert servo_radius_loss(5000, 20000, 30.0, 0.01) == pytest.approx(
        5000 * (1 - 30 / abs(complex(30 - 16 * 0.01, 4))))


def test_k37_reproduce_is_a_command():
    args = build_parser().parse_args(["reproduce", "--quick", "--out", "somewhere"])
    assert args.quick and args.out == "somewhere"
