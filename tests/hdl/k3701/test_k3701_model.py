"""The K3701's algorithms on its reference model, over many cases: lines and arcs end exactly
and stay within half an LSB of the true path, the FP a block needs (Table 1), the quadrants,
the errors a block is refused with; and block sequences on the gateware against the model."""

from __future__ import annotations

import itertools
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from k37.hdl.k3701.block import (
    CIRCLE_SETUP_CYCLES,
    COORD_MAX,
    Block,
    BlockError,
    Kind,
    quadrant_of,
)
from k37.hdl.k3701.model.chip import K3701Model, make_path, plan, walk
from k37.sim.reproduce.paper import table1
from tests.hdl.k3701.test_k3701 import compare_sequence, fp_source, on_path_end

# --- the algorithms, on the model (fast, many cases) ------------------------------------------

@settings(max_examples=300, derandomize=True)
@given(xe=st.integers(-COORD_MAX, COORD_MAX), ye=st.integers(-COORD_MAX, COORD_MAX))
def test_lines_end_exactly_at_the_end_point(xe, ye):
    p = plan(Block.line(xe, ye))
    assert p.end == (xe, ye)
    assert p.steps == max(abs(xe), abs(ye))


@settings(max_examples=200, derandomize=True)
@given(xe=st.integers(-300, 300), ye=st.integers(-300, 300))
def test_line_steps_stay_within_half_an_lsb_of_the_true_line(xe, ye):
    x = y = 0
    length = math.hypot(xe, ye) or 1.0
    for step in walk(Block.line(xe, ye)):
        x += step.dx
        y += step.dy
        assert abs(x * ye - y * xe) / length <= 0.5 * max(abs(xe), abs(ye)) / length + 1e-9
    assert (x, y) == (xe, ye)


radii = st.integers(1, (1 << 23) - 1)


@settings(max_examples=60, derandomize=True, deadline=None)
@given(r=st.integers(3, 3000), angle=st.floats(0, 2 * math.pi), cw=st.booleans())
def test_every_arc_point_lies_within_half_an_lsb_of_the_circle(r, angle, cw):
    i, j = -round(r * math.cos(angle)), -round(r * math.sin(angle))
    path = make_path(Block.arc(0, 0, i, j, cw=cw))
    radius = math.hypot(i, j)
    final = False
    while not final:
        _, final, error = path.advance()
        assert abs(math.hypot(path.x, path.y) - radius) <= 0.5 + 1e-9
    assert not error
    assert (path.x, path.y) == (-i, -j), "a full circle must return to its start"


@settings(max_examples=40, derandomize=True, deadline=None)
@given(r=radii, angle=st.floats(0, 2 * math.pi), cw=st.booleans(),
       steps=st.integers(1, 400))
def test_arcs_end_exactly_at_an_end_point_on_the_digital_path(r, angle, cw, steps):
    i, j = -round(r * math.cos(angle)), -round(r * math.sin(angle))
    if i * i + j * j > (1 << 46) - (1 << 23) or (i == 0 and j == 0):
        return
    xe, ye = on_path_end(i, j, cw, steps)
    p = plan(Block.arc(xe, ye, i, j, cw=cw))
    assert not p.error
    assert p.end == (xe, ye)


@settings(max_examples=200, derandomize=True, deadline=None)
@given(r=st.integers(2, 400), a0=st.floats(0, 2 * math.pi), a1=st.floats(0, 2 * math.pi),
       cw=st.booleans())
def test_arcs_end_within_one_lsb_of_an_end_point_off_the_path(r, a0, a1, cw):
    i, j = -round(r * math.cos(a0)), -round(r * math.sin(a0))
    radius = math.hypot(i, j)
    # Below a radius of 4 the end rule can stop 2 LSB short of a rounded end point (radii
    # sqrt(5) and sqrt(13), checked exhaustively below); the planner moves such ends and adds
    # the correction line (firmware_model/motion/program.py, REPAIR_REACH).
    if radius < 4:
        return
    ex, ey = round(radius * math.cos(a1)), round(radius * math.sin(a1))
    if ex == 0 and ey == 0:
        return
    p = plan(Block.arc(ex + i, ey + j, i, j, cw=cw))
    assert not p.error
    assert math.dist(p.end, (ex + i, ey + j)) <= 1.0 + 1e-9


def test_tiny_arcs_end_at_most_two_lsb_short_of_a_rounded_end_point():
    worst = {}
    for i, j in itertools.product(range(-3, 4), repeat=2):
        radius = math.hypot(i, j)
        if not 2 <= radius < 4:
            continue
        for k, cw in itertools.product(range(72), (False, True)):
            a = 2 * math.pi * k / 72
            ex, ey = round(radius * math.cos(a)), round(radius * math.sin(a))
            p = plan(Block.arc(ex + i, ey + j, i, j, cw=cw))
            assert not p.error
            worst[round(radius**2)] = max(worst.get(round(radius**2), 0),
                                          math.dist(p.end, (ex + i, ey + j)))
    assert max(worst.values()) == 2.0
    assert {r2 for r2, d in worst.items() if d > 1} == {5, 13}


def test_arc_whose_end_is_off_its_circle_stops_with_error_instead_of_circling():
    # End point (20, 15) relative to the centre of a radius-10 circle: its long-axis
    # coordinate y = 15 is never reached, so the arc stops on leaving quadrant 1.
    p = plan(Block(Kind.CIRCULAR, 10, 15, -10, 0, quadrant=1))
    assert p.error
    assert p.end == (-10, 10)


def test_a_line_after_an_arc_that_ended_in_error_ends_without_error():
    # The arc stops with ERROR on leaving quadrant 1 (its end is off the circle); the
    # line's START clears it, and the line's own end must not raise it again.
    arc = Block(Kind.CIRCULAR, 10, 15, -10, 0, quadrant=1)
    line = Block.line(-9, 6)
    model, _, xy = compare_sequence([arc, line], fp_source("saturated", 0), 5000)
    assert not model.out.error
    assert xy == [0, 0]


@settings(max_examples=30, derandomize=True, deadline=None)
@given(blocks=st.lists(st.one_of(
    st.builds(Block.line, st.integers(-40, 40), st.integers(-40, 40)),
    st.builds(lambda i, j, k, cw: Block.arc(i + k, j - k, i, j, cw=cw),
              st.integers(-20, 20), st.integers(-20, 20), st.integers(-30, 30).filter(bool),
              st.booleans())),
    min_size=2, max_size=4), seed=st.integers(0, 1000))
def test_gateware_equals_model_on_block_sequences(blocks, seed):
    compare_sequence(blocks, fp_source("random", seed), 20000)


@settings(max_examples=100, derandomize=True, deadline=None)
@given(xe=st.integers(-500, 500), ye=st.integers(-500, 500), i=st.integers(-300, 300),
       j=st.integers(-300, 300), cw=st.booleans(), kind=st.sampled_from(list(Kind)))
def test_fp_per_block_is_n_long_plus_half_the_diagonals(xe, ye, i, j, cw, kind):
    if kind is Kind.CIRCULAR:
        if i == 0 and j == 0:
            return
        xe, ye = on_path_end(i, j, cw, abs(xe) + 1)
        blocks = [Block.arc(xe, ye, i, j, cw=cw, sqrt2=s) for s in (False, True)]
    else:
        blocks = [Block.line(xe, ye, sqrt2=s) for s in (False, True)]
    off, on = (plan(b) for b in blocks)
    assert off.fp == off.steps
    assert on.fp == on.steps + (on.diagonal + 1) // 2
    # And the cycle model consumes exactly that many FP: one FP fewer does not end the block.
    for b, p in zip(blocks, (off, on), strict=True):
        if p.steps <= 200:
            assert fp_to_finish(b) == p.fp


def fp_to_finish(block: Block) -> int:
    """FP the cycle model needs to end a block, fed one FP per 30 cycles."""
    model = K3701Model()
    out = model.cycle(start=block)
    fed = 0
    for t in range(1, 10**6):
        fp = (t - 1) % 30 == 0 and t > CIRCLE_SETUP_CYCLES
        fed += fp
        out = model.cycle(fp=fp)
        if out.irq:
            return fed
    raise AssertionError("block never ended")


@pytest.mark.parametrize("r", [10, 100, 1000, 10000])
@pytest.mark.parametrize("sqrt2", [False, True])
def test_fp_counts_agree_with_table_1_within_one(r, sqrt2):
    path = make_path(Block.arc(0, 0, -r, 0))
    n = diag = 0
    while path.x > 0:
        step, _, _ = path.advance()
        n += 1
        diag += step.diagonal
        fp = n + (diag + 1) // 2 if sqrt2 else n
        assert abs(fp - table1(r, math.atan2(path.y, path.x), sqrt2)) <= 1.0
        if n % 97 == 0:  # and the plan of an arc ending here says the same
            assert plan(Block.arc(path.x - r, path.y, -r, 0, sqrt2=sqrt2)).fp == fp


def test_quadrant_membership_follows_the_direction_of_motion():
    assert quadrant_of(5, 0, cw=False) == 1
    assert quadrant_of(5, 0, cw=True) == 4
    assert quadrant_of(0, 5, cw=False) == 2
    assert quadrant_of(0, 5, cw=True) == 1
    assert quadrant_of(-5, 0, cw=False) == 3
    assert quadrant_of(0, -5, cw=True) == 3


def test_block_errors_name_the_problem():
    with pytest.raises(BlockError, match=r"Xe = -8388608 is outside"):
        plan(Block.line(-(1 << 23), 0))
    with pytest.raises(BlockError, match="leaves the 24-bit coordinate range"):
        plan(Block(Kind.CIRCULAR, 0, 0, COORD_MAX, COORD_MAX, quadrant=1))
    with pytest.raises(BlockError, match="radius 0"):
        plan(Block(Kind.CIRCULAR, 0, 0, 0, 0))
    with pytest.raises(BlockError, match="not in end-point quadrant 3"):
        plan(Block(Kind.CIRCULAR, -10, 10, -10, 0, quadrant=3))
