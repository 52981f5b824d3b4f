"""K3701 exponential and logarithmic interpolation: the model against the true curve, the
host's choice of the chip's data, the gateware against the model cycle by cycle."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from k37.firmware_model.motion.curves import (
    MAX_GROWTH,
    MIN_CONSTANT,
    CurveError,
    curve_distances,
    exponential_block,
    exponential_frame,
)
from k37.hdl.k3701.block import COORD_MAX, Block, BlockError
from k37.hdl.k3701.datapaths.model.parabolic import ExponentialPath
from k37.hdl.k3701.model.chip import make_path, walk
from tests.hdl.k3701.test_k3701 import (
    check_clean_end_on_gateware,
    compare_with_model,
    fp_kinds,
    fp_source,
)
from tests.hdl.k3701.test_k3701_parabolic import visited


@st.composite
def exponentials(draw, span: int = 60) -> Block:
    """A curve the host accepts: any extent, direction, constant (growing or flattening) and
    orientation (an exponential of X, or a logarithm: an exponential of Y)."""
    pe = draw(st.integers(1, span)) * draw(st.sampled_from([1, -1]))
    ve = draw(st.integers(-span, span))
    constant = draw(st.floats(math.log(MIN_CONSTANT), math.log(8 * span)).map(math.exp))
    log = draw(st.booleans())
    xe, ye = (ve, pe) if log else (pe, ve)
    try:
        block, _ = exponential_block(xe, ye, constant * draw(st.sampled_from([1, -1])),
                                     log=log, sqrt2=draw(st.booleans()))
    except CurveError:
        assume(False)
    return block


def check_points_and_end(block: Block) -> float:
    """The block ends on its end point; returns the largest distance of its points from the
    chip's exponential through the start and the end."""
    path, points, error = visited(block)
    assert isinstance(path, ExponentialPath) and not error
    assert (path.x, path.y) == (block.xe, block.ye)
    distance = curve_distances(exponential_frame(path), points, (0, path.pe)).max()
    # 0.5 LSB from the |F| rule, the offset's rounding to 1/(2|k|) LSB, grown by at most
    # MAX_GROWTH |k|, and F's fraction below 1 / |k| LSB (a few where v is long).
    assert distance <= min(0.5 + MAX_GROWTH / 2 + 4 / path.k, 1)
    return distance


@settings(max_examples=60, deadline=None, derandomize=True)
@given(block=exponentials(span=200))
def test_exponential_visits_points_within_an_lsb_and_ends_exactly(block):
    check_points_and_end(block)


@pytest.mark.slow
@settings(max_examples=1500, deadline=None, derandomize=True)
@given(block=exponentials(span=2000))
def test_many_exponentials_visit_points_within_an_lsb_and_end_exactly(block):
    check_points_and_end(block)


def test_long_exponential_and_logarithm_end_exactly():
    # 20 mm at 1 um per LSB, growing 8 times (constant 9.6 mm), and its logarithm flattening.
    for xe, ye, constant, log in ((20000, 7000, 9618.0, False), (-15000, 20000, -9618.0, True)):
        block, result = exponential_block(xe, ye, constant, log=log, sqrt2=True)
        assert result.end == (xe, ye) and not result.error
        assert check_points_and_end(block) <= 0.51


def test_host_takes_the_ratio_nearest_the_constant():
    block, _ = exponential_block(40, 30, 40.0, log=False, sqrt2=False)
    assert block.i == round(1 / math.expm1(1 / 40))       # 39.5 rounds to 40 (even)
    flattening, _ = exponential_block(-40, 30, 40.0, log=False, sqrt2=False)
    assert flattening.cw                                    # p runs towards -X: e^(-p / K)


def test_exponential_fp_count_counts_its_steps():
    block, result = exponential_block(40, 25, 30.0, log=False, sqrt2=True)
    moves = [(step.dx, step.dy) for step in walk(block)]
    assert result.steps == len(moves)
    assert result.diagonal == sum(dx != 0 and dy != 0 for dx, dy in moves)
    assert result.fp == result.steps + (result.diagonal + 1) // 2
    assert [sum(axis) for axis in zip(*moves, strict=True)] == [40, 25]


@pytest.mark.parametrize(("args", "match"), [
    ((0, 10, 5, 1, 0), "non-zero X extent"),
    ((10, 5, 1, 1, 0), "I >= 2"),
    ((10, 5, -1, 1, 0), "I >= 2"),
    ((10, 5, 5, -1, 0), "J >= 0"),
    ((10, -COORD_MAX - 1, 5, 1, 0), "outside"),
])
def test_exponential_with_bad_data_is_refused(args, match):
    with pytest.raises(BlockError, match=match):
        make_path(Block.exponential(*args))


@pytest.mark.parametrize(("xe", "ye", "constant", "log", "match"), [
    (10, 0, 50.0, True, "non-zero Y extent"),
    (100, 10, 4.0, False, "below the K3701's 8 LSB"),
    (200, 10, 20.0, False, "grows too fast"),
    (100, 1000000, 1e9, False, "too nearly straight"),
])
def test_host_refuses_curves_the_chip_cannot_draw(xe, ye, constant, log, match):
    with pytest.raises(CurveError, match=match):
        exponential_block(xe, ye, constant, log=log, sqrt2=False)


@settings(max_examples=8, deadline=None, derandomize=True)
@given(block=exponentials(span=25), fp=fp_kinds, seed=st.integers(0, 1000))
def test_exponential_gateware_matches_model_cycle_by_cycle(block, fp, seed):
    check_clean_end_on_gateware(block, fp, seed)


@pytest.mark.slow
@settings(max_examples=80, deadline=None, derandomize=True)
@given(block=exponentials(span=60), fp=fp_kinds, seed=st.integers(0, 1000))
def test_many_exponentials_on_gateware_match_model_cycle_by_cycle(block, fp, seed):
    check_clean_end_on_gateware(block, fp, seed)


@pytest.mark.parametrize("block", [
    Block.exponential(0, 7, 5, 3, 0),                    # no abscissa: ERROR after the setup
    Block.exponential(10, 5, 1, 1, 0),                   # |k| < 2
    replace(Block.exponential(60, 9, 4, 2, 0), frac=1 - 2**23),  # E no host loads
    Block.exponential(1, 0, 5, 0, 0),                    # one step
    Block.exponential(-9, 30, 5, 3, 2, swap=True),       # data no host picks: passes an end
    Block.exponential(25, -40, -20, 60, 3),              # the same, flattening
    Block.exponential(5, 291, 239, 13800, 5),            # steep: v is the long axis
])
def test_exponential_gateware_matches_model_on_edge_cases(block):
    model, _, _ = compare_with_model(block, fp_source("saturated", 0), 20000)
    assert model.out.irq
