"""The filters paper's missing resonance, identified: the grids bracket and refine, and on a
target the emulator itself produced at a known free mode and damping the identification finds
that point again and its prediction holds."""

from __future__ import annotations

import dataclasses

import pytest

from k37.sim.reproduce import filters, identify
from k37.sim.reproduce.identify import Point, coarse_grid, refine_grid, residual, within
from k37.sim.reproduce.runs import FULL, QUICK
from k37.sim.reproduce.workers import run_all


def test_the_refined_grid_brackets_the_coarse_best_within_the_coarse_bounds():
    coarse = coarse_grid(FULL)
    hz = sorted({p.hz for p in coarse})
    best = Point(hz[3], 0.02)
    fine = sorted({p.hz for p in refine_grid(FULL, best)})
    assert fine[0] == pytest.approx(hz[2]) and fine[-1] == pytest.approx(hz[4])
    assert len(fine) == 9
    edge = sorted({p.hz for p in refine_grid(FULL, Point(hz[-1], 0.2))})
    assert edge[-1] == pytest.approx(hz[-1]) and len(edge) == 5
    zeta = sorted({p.zeta for p in refine_grid(FULL, Point(hz[-1], 0.2))})
    assert zeta == pytest.approx([0.2 / 40 ** (1 / 3), 0.2 / 40 ** (1 / 6), 0.2])


def test_the_residual_weighs_a_miss_of_either_number_by_its_factor():
    assert residual((70, 9), (70, 9)) == 1
    assert residual((140, 9), (70, 9)) == pytest.approx(2)
    assert residual((70, 4.5), (70, 9)) == pytest.approx(2)
    assert within((80, 10), (70, 9), 0.25) and not within((70, 12), (70, 9), 0.25)


@pytest.mark.slow
def test_a_target_made_by_the_emulator_is_identified_and_predicted():
    # low enough for the damping to show in the errors (above about 40 Hz it changes them by
    # a few LSB only), between the quick grid's frequencies, on one of its damping ratios
    truth = Point(25.0, 0.2)
    problem = filters.RESONANCE
    servo = identify.resonant_servo(problem.base, truth)
    made = {f"truth_{shape}_{tau}": problem.corner(f"truth_{shape}_{tau}", shape, tau, servo)
            for shape in filters.SHAPES for tau in problem.taus}
    runs = run_all(made | identify.specs(problem, QUICK))
    target = {shape: tuple(round(problem.peak(runs[f"truth_{shape}_{tau}"]))
                           for tau in problem.taus) for shape in filters.SHAPES}
    problem = dataclasses.replace(problem, paper=target)
    runs |= run_all(identify.follow_up(problem, runs, QUICK))
    assert not identify.follow_up(problem, runs, QUICK)
    fit = identify.identify(problem, runs, QUICK)
    step = 10 ** (1 / 8)  # the quick grid's refined frequency step
    assert truth.hz / step <= fit.point.hz <= truth.hz * step
    assert fit.point.zeta == pytest.approx(truth.zeta)
    assert residual(fit.fitted, target["linear"]) < 1.05
    assert fit.fits and fit.holds
    assert within(fit.predicted, target["exponential"], 0.05)
