"""The host's fast arc plan equals the reference walk exactly, and is fast."""

from __future__ import annotations

import math
import re

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from k37.firmware_model.motion.arcs import plan_block
from k37.hdl.k3701.block import Block, BlockError
from k37.hdl.k3701.model.chip import plan


def _both(xe, ye, i, j, cw, sqrt2):
    try:
        block = Block.arc(xe, ye, i, j, cw=cw, sqrt2=sqrt2)
        expected = plan(block)
    except BlockError:
        with pytest.raises(BlockError):
            plan_block(Block.arc(xe, ye, i, j, cw=cw, sqrt2=sqrt2))
        return
    assert plan_block(block) == expected, block


def test_the_fast_plan_equals_the_walk_for_every_small_arc():
    # every centre within 4 LSB and every end within 6 LSB of the start, both directions
    for i in range(-4, 5):
        for j in range(-4, 5):
            if i == j == 0:
                continue
            for xe in range(-6, 7, 2):
                for ye in range(-6, 7, 3):
                    _both(xe, ye, i, j, cw=(xe + ye) % 2 == 0, sqrt2=True)


@settings(max_examples=300, deadline=None)
@given(radius=st.integers(1, 3000), start=st.floats(0, math.tau), end=st.floats(0, math.tau),
       jitter=st.tuples(st.integers(-2, 2), st.integers(-2, 2)), full=st.booleans(),
       cw=st.booleans(), sqrt2=st.booleans())
def test_the_fast_plan_equals_the_walk_on_random_arcs(radius, start, end, jitter, full, cw,
                                                      sqrt2):
    i, j = round(-radius * math.cos(start)), round(-radius * math.sin(start))
    if i == j == 0:
        return
    if full:
        xe = ye = 0
    else:
        xe = i + round(radius * math.cos(end)) + jitter[0]
        ye = j + round(radius * math.sin(end)) + jitter[1]
    _both(xe, ye, i, j, cw, sqrt2)


def test_a_large_circle_plans_to_its_start_with_consistent_counts():
    # a full circle of radius 200,000 LSB: about 1.1 million steps for the walk (its speed
    # against the walk is in bench/bench_planning.py)
    block = Block.arc(0, 0, -200_000, 0, sqrt2=True)
    result = plan_block(block)
    assert result.end == (0, 0) and not result.error
    assert result.steps == sum(result.pulses.values()) - result.diagonal
    assert result.fp == result.steps + (result.diagonal + 1) // 2



def _both_helix(xe, ye, i, j, ze, cw, sqrt2):
    try:
        block = Block.arc(xe, ye, i, j, cw=cw, sqrt2=sqrt2, ze=ze)
    except BlockError:
        return  # refused before any plan
    try:
        expected = plan(block)
    except BlockError as e:
        message = str(e)
    else:
        assert plan_block(block) == expected, block
        return
    with pytest.raises(BlockError, match=f"^{re.escape(message)}$"):
        plan_block(block)


def test_the_fast_helix_plan_equals_the_walk_for_every_small_helix():
    for i in range(-3, 4):
        for j in range(-3, 4):
            if i == j == 0:
                continue
            for xe in range(-4, 5, 2):
                for ze in (-9, -3, 1, 5):
                    _both_helix(xe, (xe + i) % 5 - 2, i, j, ze, cw=xe % 4 == 0, sqrt2=True)


@settings(max_examples=200, deadline=None)
@given(radius=st.integers(1, 3000), start=st.floats(0, math.tau), end=st.floats(0, math.tau),
       full=st.booleans(), steep=st.floats(0, 1.2), down=st.booleans(), cw=st.booleans(),
       sqrt2=st.booleans())
def test_the_fast_helix_plan_equals_the_walk_on_random_helices(radius, start, end, full,
                                                               steep, down, cw, sqrt2):
    # the third axis from a few LSB to beyond one move per arc step (refused by both)
    i, j = round(-radius * math.cos(start)), round(-radius * math.sin(start))
    if i == j == 0:
        return
    xe = ye = 0
    if not full:
        xe, ye = i + round(radius * math.cos(end)), j + round(radius * math.sin(end))
    ze = max(1, round(steep * 4 * radius)) * (-1 if down else 1)
    _both_helix(xe, ye, i, j, ze, cw, sqrt2)


def test_a_large_helix_plans_in_closed_form_with_consistent_counts():
    # a full turn of radius 2,000,000 LSB (2 m at 1 um) rising 5,000,000 LSB: about 11
    # million steps, which the walk takes minutes for (the time is in bench/bench_planning.py)
    block = Block.arc(0, 0, -2_000_000, 0, sqrt2=True, ze=5_000_000)
    result = plan_block(block)
    arc = plan_block(Block.arc(0, 0, -2_000_000, 0, sqrt2=True))
    assert result.end == (0, 0) and not result.error and result.ze == 5_000_000
    assert (result.steps, result.pulses["z+"], result.pulses["z-"]) == (arc.steps, 5_000_000, 0)
    three = arc.diagonal + 5_000_000 - result.diagonal  # steps moving all three axes
    assert 0 < three < arc.diagonal
    two = result.diagonal - three
    assert result.fp == -(-(4 * result.steps + 2 * two + 3 * three) // 4)
