"""The three-axis K3701's parabolas and exponentials: in each plane, gateware against the
reference model cycle by cycle, ending exactly on their end points; a curve with a third
coordinate refused; the registers that load them."""

from __future__ import annotations

from dataclasses import replace

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from k37.hdl.k3701.block import PLANES, Block, BlockError, Kind, route
from k37.hdl.k3701.map import K3701_MAP_3, block_registers
from k37.hdl.k3701.model.chip import plan, walk
from tests.hdl.k3701.test_k3701 import fp_kinds, fp_source
from tests.hdl.k3701.test_k3701_3axis import compare3
from tests.hdl.k3701.test_k3701_exponential import exponentials
from tests.hdl.k3701.test_k3701_parabolic import parabolas

planes = st.integers(0, 2)


def check_clean_end(block: Block, fp: str, seed: int) -> None:
    """``block`` on the three-axis gateware equals the model in every cycle and ends on its
    end point (nothing left on any axis) without ERROR."""
    model, remaining = compare3(block, fp_source(fp, seed), 20000)
    assert remaining == [0, 0, 0] and model.out.irq and not model.out.error


@settings(max_examples=8, deadline=None, derandomize=True)
@given(block=parabolas(span=20), plane=planes, fp=fp_kinds, seed=st.integers(0, 1000))
def test_three_axis_parabolas_in_every_plane_match_the_model_and_end_exactly(block, plane,
                                                                           fp, seed):
    check_clean_end(replace(block, plane=plane), fp, seed)


@settings(max_examples=8, deadline=None, derandomize=True)
@given(block=exponentials(span=20), plane=planes, fp=fp_kinds, seed=st.integers(0, 1000))
def test_three_axis_exponentials_in_every_plane_match_the_model_and_end_exactly(block, plane,
                                                                              fp, seed):
    check_clean_end(replace(block, plane=plane), fp, seed)


@pytest.mark.slow
@settings(max_examples=40, deadline=None, derandomize=True)
@given(block=st.one_of(parabolas(span=50), exponentials(span=50)), plane=planes, fp=fp_kinds,
       seed=st.integers(0, 1000))
def test_many_three_axis_curves_match_the_model_and_end_exactly(block, plane, fp, seed):
    check_clean_end(replace(block, plane=plane), fp, seed)


@pytest.mark.parametrize("block", [
    replace(Block.parabola(12, 5, 6, 4, sqrt2=True), plane=1),
    replace(Block.parabola(-9, 30, -4, 2), plane=2),             # steep: v is the long axis
    replace(Block.parabola(30, -9, 2, -15, swap=True), plane=0),
    replace(Block.exponential(25, 9, 20, 3, 15, sqrt2=True), plane=1),
    replace(Block.exponential(-9, 20, -16, 12, 7, swap=True), plane=2),   # a logarithm
])
def test_hand_picked_three_axis_curves_match_the_model_and_end_exactly(block):
    check_clean_end(block, "random", 7)


@pytest.mark.parametrize("block", [
    replace(Block.parabola(12, 5, 6, 4), ze=3),
    replace(Block.exponential(25, 9, 20, 3, 2), ze=-1, plane=1),
    replace(Block.parabola(0, 7, 0, 3), plane=2),               # no abscissa
])
def test_a_curve_with_a_third_coordinate_or_bad_data_is_refused_after_its_setup(block):
    model, _ = compare3(block, fp_source("saturated", 0), 200)
    assert model.out.error and model.out.irq and not model.out.busy
    with pytest.raises(BlockError):
        plan(block)


def test_a_curve_steps_the_machine_axes_its_plane_names():
    block = Block.parabola(12, 5, 6, 4)
    for plane in range(3):
        moved = [route(step, plane) for step in walk(replace(block, plane=plane))]
        totals = [sum(m[axis] for m in moved) for axis in range(3)]
        first, second, third = PLANES[plane]
        assert (totals[first], totals[second], totals[third]) == (12, 5, 0)


def test_mode_holds_the_curve_type_and_is_written_for_every_block():
    mode = K3701_MAP_3["MODE"]
    for block, kind in ((Block.line(3, 4, 5), None), (Block.arc(0, 0, -3, 0), None),
                        (Block.parabola(12, 5, 6, 4, swap=True), Kind.PARABOLIC),
                        (Block.exponential(25, 9, 20, 3, 2), Kind.EXPONENTIAL)):
        values = block_registers(block, axes=3)
        assert list(values)[-2:] == ["MODE", "CTRL"]
        fields = mode.decode(values["MODE"])
        assert fields["parabolic"] == (kind is Kind.PARABOLIC)
        assert fields["exponential"] == (kind is Kind.EXPONENTIAL)
        assert fields["swap"] == block.swap
    assert block_registers(Block.exponential(25, 9, 20, 3, 2), axes=3)["E"] == -2
