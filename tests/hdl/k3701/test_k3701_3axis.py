"""The three-axis K3701: 3-D lines, arcs in the G17/G18/G19 planes and helices, gateware
against the reference model cycle by cycle, and the model against geometry."""

from __future__ import annotations

import math

from hypothesis import assume, given, settings
from hypothesis import strategies as st

from k37.hdl.k3701.block import Block, BlockError, route, step_cost
from k37.hdl.k3701.chip import K3701
from k37.hdl.k3701.datapaths.model.linear import LinearPath
from k37.hdl.k3701.map import K3701_MAP_3, block_registers
from k37.hdl.k3701.model.chip import K3701Model, plan, walk
from tests.hdl.k3701.test_k3701 import fp_source
from tests.testbench import bus_write, read_reg, simulate, write_reg

OUTPUTS = ("x_pos", "x_neg", "y_pos", "y_neg", "z_pos", "z_neg", "busy", "irq", "error",
           "overrun")
CMD = K3701_MAP_3["CMD"]


def compare3(block: Block, fp, max_cycles: int) -> tuple[K3701Model, list[int]]:
    """One block on the three-axis gateware and model side by side, outputs equal in every
    cycle; returns the model and the X, Y, Z registers read back at the end."""
    dut = K3701(axes=3)
    model = K3701Model(axes=3)
    result: dict = {}

    async def bench(ctx):
        for name, value in block_registers(block, axes=3).items():
            await write_reg(ctx, dut.bus, K3701_MAP_3[name], value)
        await bus_write(ctx, dut.bus, CMD.addr, CMD.encode(start=1, ack=1, clear=1))
        for t in range(max_cycles):
            f = fp(t)
            ctx.set(dut.fp, f)
            got = {name: ctx.get(getattr(dut, name)) for name in OUTPUTS}
            out = model.cycle(fp=bool(f), start=block if t == 0 else None, ack=t == 0,
                              clear=t == 0)
            want = {name: getattr(out, name) for name in OUTPUTS}
            assert got == want, f"{block} cycle {t}: gateware {got} != model {want}"
            await ctx.tick()
            if t > 0 and out.irq:
                break
        result["xyz"] = [await read_reg(ctx, dut.bus, K3701_MAP_3[n]) for n in "XYZ"]

    simulate(dut, bench)
    return model, result["xyz"]


def helix(xe, ye, i, j, ze, *, cw=False, sqrt2=False, plane=0) -> Block:
    """A helical arc with its step count as the host loads it (from the plan)."""
    steps = plan(Block.arc(xe, ye, i, j, cw=cw)).steps
    return Block.arc(xe, ye, i, j, cw=cw, sqrt2=sqrt2, ze=ze, plane=plane, helix_steps=steps)


small = st.integers(-30, 30)


@settings(max_examples=6, deadline=None, derandomize=True)
@given(xe=small, ye=small, ze=small, sqrt2=st.booleans(),
       fp=st.sampled_from(["saturated", "random", "bursts"]), seed=st.integers(0, 2**32))
def test_three_axis_lines_match_the_model_cycle_by_cycle_and_end_exactly(xe, ye, ze, sqrt2,
                                                                         fp, seed):
    model, remaining = compare3(Block.line(xe, ye, ze, sqrt2=sqrt2), fp_source(fp, seed), 2000)
    assert remaining == [0, 0, 0] and not model.out.error


@settings(max_examples=8, deadline=None, derandomize=True)
@given(r=st.integers(3, 12), ze=st.integers(-20, 20), plane=st.integers(0, 2),
       cw=st.booleans(), sqrt2=st.booleans(), seed=st.integers(0, 2**32))
def test_helical_arcs_in_every_plane_match_the_model_and_end_with_the_arc(r, ze, plane, cw,
                                                                          sqrt2, seed):
    block = helix(r, r if not cw else -r, r, 0, ze, cw=cw, sqrt2=sqrt2, plane=plane)
    assume(abs(ze) <= block.helix_steps)
    model, remaining = compare3(block, fp_source("random", seed), 4000)
    assert remaining == [0, 0, 0] and not model.out.error


def test_a_helix_steeper_than_one_move_per_arc_step_is_refused_after_the_radius_check():
    block = Block.arc(0, 0, -3, 0, ze=500, helix_steps=20)
    model, _ = compare3(block, fp_source("saturated", 0), 100)
    assert model.out.error and model.out.irq


def test_plane_codes_route_block_axes_to_machine_axes_as_linuxcnc_orders_them():
    step = walk(Block.line(1, 0)).__next__()
    assert route(step, 0) == (1, 0, 0)      # G17: first = X
    assert route(step, 1) == (0, 0, 1)      # G18: first = Z
    assert route(step, 2) == (0, 1, 0)      # G19: first = Y


def test_3d_line_steps_stay_within_half_an_lsb_of_the_segment_on_each_short_axis():
    for xe, ye, ze in ((1000, 370, -220), (-13, 977, 500), (40, -40, 40), (5, 3, 900)):
        pos = [0, 0, 0]
        n = max(map(abs, (xe, ye, ze)))
        for k, step in enumerate(walk(Block.line(xe, ye, ze)), 1):
            pos = [p + d for p, d in zip(pos, (step.dx, step.dy, step.dz), strict=True)]
            for p, e in zip(pos, (xe, ye, ze), strict=True):
                assert abs(p - e * k / n) <= 0.5
        assert pos == [xe, ye, ze]


def test_3d_fp_counts_weigh_steps_by_the_axes_they_move():
    for block in (Block.line(300, 200, 100, sqrt2=True), Block.line(-7, 7, 7, sqrt2=True),
                  helix(50, 50, 50, 0, 30, sqrt2=True, plane=1)):
        steps = list(walk(block))
        cost = sum(step_cost(s, True, axes=3) for s in steps)
        assert plan(block).fp == math.ceil(cost / 4)
    # a 3-D diagonal: 1.75 FP per step, sqrt(3) = 1.73 of the path per LSB
    assert plan(Block.line(400, 400, 400, sqrt2=True)).fp == 700


def test_two_axis_blocks_plan_alike_on_the_three_axis_chip():
    for block in (Block.line(17, -5, sqrt2=True), Block.arc(0, 0, -9, 4, sqrt2=True)):
        p = plan(block)
        assert p.fp == p.steps + (p.diagonal + 1) // 2
        assert [step_cost(s, True, 3) for s in walk(block)] == [
            2 * step_cost(s, True, 2) for s in walk(block)]


def test_line_path_refuses_a_third_coordinate_of_minus_2_pow_23():
    try:
        LinearPath(0, 0, -(1 << 23))
    except BlockError:
        return
    raise AssertionError("not refused")
