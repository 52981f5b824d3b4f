"""The contour-error paper's controlled runs in ``k37 reproduce`` (Tables 2 and 3): the exact
curves the host is told. The closed-loop runs are checked by the quick reproduction."""

from __future__ import annotations

import numpy as np
import pytest

from k37.firmware_model.motion.program import Line
from k37.sim.reproduce import contour_error
from k37.sim.reproduce.runs import QUICK, RunSpec

CURVES = {"bezier": contour_error.Curve.bezier(contour_error.BEZIER_MM),
          "parabola": contour_error.Curve.parabola()}


@pytest.mark.parametrize("name", ["bezier", "parabola"])
def test_the_cubic_spline_is_the_papers_curve(name):
    spline, _ = contour_error.exact_curve(name, 10)
    curve = CURVES[name]
    u = np.linspace(0.0, 1.0, 101)
    assert spline.at(u) * contour_error.MACHINE.lsb_mm == pytest.approx(curve.at(u), abs=1e-9)


@pytest.mark.parametrize("key", list(contour_error.CONTOUR_RUNS))
def test_every_chord_carries_the_curve_between_its_ends(key):
    spec = contour_error.specs(QUICK)[key]
    job = spec.job()
    assert job.contour.controller == contour_error.CONTOUR_RUNS[key][1]
    lines = [item for item in job.program.items if isinstance(item, Line)]
    for line in lines:
        span = line.curve
        ends = span.curve.at(np.array([span.t0, span.t1]))
        assert np.abs(ends - [line.start[:2], line.end[:2]]).max() <= 1.0  # the G-code's 1 um


def test_a_curve_needs_as_many_spans_as_chords():
    spline, ends = contour_error.exact_curve("parabola", 10)
    gcode = contour_error.chords_gcode(CURVES["parabola"], 12)
    with pytest.raises(ValueError, match="12 chords for 10 spans"):
        RunSpec("x", "none", gcode, 1, machine=contour_error.MACHINE, exact=(spline, ends)).job()
