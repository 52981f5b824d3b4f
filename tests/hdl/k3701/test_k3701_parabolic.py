"""K3701 parabolic interpolation: the model against the true parabola, the gateware against
the model cycle by cycle."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from k37.firmware_model.motion.curves import frame_distances
from k37.hdl.k3701.block import COORD_MAX, Block, BlockError
from k37.hdl.k3701.datapaths.model.parabolic import FramePath, ParabolicPath
from k37.hdl.k3701.model.chip import make_path, plan
from tests.hdl.k3701.test_k3701 import (
    check_clean_end_on_gateware,
    compare_with_model,
    fp_kinds,
    fp_source,
)


def curve_distances(path: ParabolicPath, points: np.ndarray) -> np.ndarray:
    """Euclidean distance of each (p, v) (the curve's frame) to the whole parabola."""
    return frame_distances(path.b / path.a, path.c / path.a, points)


def visited(block: Block) -> tuple[FramePath, np.ndarray, bool]:
    """The model's path of a curve (a parabola or an exponential): the path, the points it
    visits from the start on (in the curve's frame) and its error."""
    path = make_path(block)
    assert isinstance(path, FramePath)
    points, final, error = [(0, 0)], False, False
    while not final:
        _, final, error = path.advance()
        points.append((path.p, path.v))
    return path, np.array(points, dtype=float), error


@st.composite
def parabolas(draw, span: int = 60) -> Block:
    """A parabola no sharper than the host accepts (|B| <= A / 16), any orientation and
    direction."""
    pe = draw(st.integers(1, span)) * draw(st.sampled_from([1, -1]))
    vp = draw(st.integers(-span, span))
    half_b = draw(st.integers(-(pe * pe // 32), pe * pe // 32))  # B = 2 ve - 4 vp
    ve = half_b + 2 * vp
    swap = draw(st.booleans())
    xe, ye, i, j = (ve, pe, vp, pe // 2) if swap else (pe, ve, pe // 2, vp)
    return Block.parabola(xe, ye, i, j, swap=swap, sqrt2=draw(st.booleans()))


#: The |F| rule's rounding where the parabola is steep: 0.5002 LSB is the largest distance
#: seen (1,500 random parabolas with vertex radii from 8 LSB).
ROUNDING = 1e-3


def check_points_and_end(block: Block) -> None:
    path, points, error = visited(block)
    assert not error
    assert (path.x, path.y) == (block.xe, block.ye)
    assert curve_distances(path, points).max() <= 0.5 + ROUNDING


@settings(max_examples=60, deadline=None, derandomize=True)
@given(block=parabolas(span=200))
def test_parabola_visits_points_within_half_an_lsb_and_ends_exactly(block):
    check_points_and_end(block)


@pytest.mark.slow
@settings(max_examples=1500, deadline=None, derandomize=True)
@given(block=parabolas(span=400))
def test_many_parabolas_visit_points_within_half_an_lsb_and_end_exactly(block):
    check_points_and_end(block)


def test_the_contour_error_papers_parabola_stays_within_half_an_lsb():
    # y = (x - 15)^2 / 15 - 15 mm at 1 um per LSB, from x = 0 to 15 mm (vertex) and on to 30.
    for xe, ye, vp in ((15000, -15000, -11250), (15000, 15000, 3750)):
        path, points, error = visited(Block.parabola(xe, ye, xe // 2, vp))
        assert not error and (path.x, path.y) == (xe, ye)
        assert curve_distances(path, points).max() <= 0.5 + 1e-9


def test_parabola_fp_count_counts_its_steps():
    block = Block.parabola(40, 10, 20, -5, sqrt2=True)
    result = plan(block)
    assert result.end == (40, 10) and not result.error
    assert result.fp == result.steps + (result.diagonal + 1) // 2
    assert result.pulses["x+"] == 40 and result.pulses["x-"] == 0
    assert result.pulses["y+"] - result.pulses["y-"] == 10


def test_parabola_with_no_abscissa_is_refused():
    with pytest.raises(BlockError, match="non-zero X extent"):
        make_path(Block.parabola(0, 10, 0, 5))
    with pytest.raises(BlockError, match="outside"):
        make_path(Block.parabola(10, -COORD_MAX - 1, 5, 0))


@settings(max_examples=8, deadline=None, derandomize=True)
@given(block=parabolas(span=25), fp=fp_kinds, seed=st.integers(0, 1000))
def test_parabolic_gateware_matches_model_cycle_by_cycle(block, fp, seed):
    check_clean_end_on_gateware(block, fp, seed)


@pytest.mark.slow
@settings(max_examples=80, deadline=None, derandomize=True)
@given(block=parabolas(span=60), fp=fp_kinds, seed=st.integers(0, 1000))
def test_many_parabolas_on_gateware_match_model_cycle_by_cycle(block, fp, seed):
    check_clean_end_on_gateware(block, fp, seed)


@pytest.mark.parametrize("block", [
    Block.parabola(0, 7, 0, 3),                   # no abscissa: ERROR after the setup
    Block.parabola(1, 0, 0, 0),                    # one step
    Block.parabola(-9, 30, -4, 2, swap=False),     # steep: the ordinate is the long axis
    Block.parabola(30, -9, 2, -15, swap=True),
])
def test_parabolic_gateware_matches_model_on_edge_cases(block):
    model, _, _ = compare_with_model(block, fp_source("saturated", 0), 5000)
    assert model.out.irq
