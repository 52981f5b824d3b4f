"""K3701 interpolator: gateware against the reference model, and the model against geometry."""

from __future__ import annotations

import itertools
import random

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from k37.hdl.k3701.block import (
    CIRCLE_SETUP_CYCLES,
    COORD_MAX,
    LATENCY_CIRCULAR,
    LATENCY_LINEAR,
    Block,
    BlockError,
    Kind,
)
from k37.hdl.k3701.chip import K3701
from k37.hdl.k3701.datapaths.circular import CircularDatapath
from k37.hdl.k3701.datapaths.linear import LinearDatapath
from k37.hdl.k3701.map import K3701_MAP, block_registers
from k37.hdl.k3701.model.chip import K3701Model, make_path, plan
from tests.testbench import bus_write, read_reg, simulate, write_reg

OUTPUTS = ("x_pos", "x_neg", "y_pos", "y_neg", "busy", "irq", "error", "overrun")
CMD = K3701_MAP["CMD"]
CTRL = K3701_MAP["CTRL"]


def ctrl_word(block: Block) -> int:
    return block_registers(block)["CTRL"]


async def load(ctx, dut: K3701, block: Block) -> None:
    for name, value in (("X", block.xe), ("Y", block.ye), ("I", block.i), ("J", block.j),
                        ("E", block.frac)):
        await write_reg(ctx, dut.bus, K3701_MAP[name], value)
    await write_reg(ctx, dut.bus, CTRL, ctrl_word(block))


def fp_source(kind: str, seed: int):
    """An FP stream: cycle -> 0/1."""
    rng = random.Random(seed)
    if kind == "saturated":
        return lambda _t: 1
    if kind == "periodic":
        period = rng.randint(2, 40)
        return lambda t: int(t % period == 0)
    if kind == "random":
        p = rng.uniform(0.02, 0.9)
        return lambda _t: int(rng.random() < p)
    bursts = {}

    def burst(t: int) -> int:
        frame = t // 64
        if frame not in bursts:
            bursts[frame] = (rng.randint(0, 63), rng.randint(0, 30))
        start, length = bursts[frame]
        return int(start <= t % 64 < start + length)
    return burst


def compare_with_model(block: Block, fp, max_cycles: int,
                       model: K3701Model | None = None) -> tuple[K3701Model, int, list[int]]:
    """Run one block on gateware and model side by side, asserting equal outputs each cycle.

    Returns the model, the cycles run and the X/Y registers read back at the end.
    """
    return compare_sequence([block], fp, max_cycles, model)


def compare_sequence(blocks: list[Block], fp, max_cycles: int,
                     model: K3701Model | None = None) -> tuple[K3701Model, int, list[int]]:
    """:func:`compare_with_model` for blocks run one after another on one chip.

    Each block is loaded and started (with ``ack`` and ``clear``) once the previous one
    requested data.
    Returns the model, the last block's cycles and the X/Y registers read back at the end.
    """
    dut = K3701()
    model = model or K3701Model()
    result: dict = {}

    async def bench(ctx):
        for block in blocks:
            await load(ctx, dut, block)
            await bus_write(ctx, dut.bus, CMD.addr, CMD.encode(start=1, ack=1, clear=1))
            for t in range(max_cycles):
                f = fp(t)
                ctx.set(dut.fp, f)
                got = {name: ctx.get(getattr(dut, name)) for name in OUTPUTS}
                out = model.cycle(fp=bool(f), start=block if t == 0 else None,
                                  ack=t == 0, clear=t == 0)
                want = {name: getattr(out, name) for name in OUTPUTS}
                assert got == want, f"{block} cycle {t}: gateware {got} != model {want}"
                await ctx.tick()
                if t > 0 and out.irq:
                    break
            ctx.set(dut.fp, 0)
            result["cycles"] = t
        result["xy"] = [await read_reg(ctx, dut.bus, K3701_MAP[n]) for n in ("X", "Y")]

    simulate(dut, bench)
    return model, result["cycles"], result["xy"]


def check_clean_end_on_gateware(block: Block, fp: str, seed: int) -> None:
    """``block`` on gateware equals the model cycle by cycle under the FP stream ``fp`` (see
    :func:`fp_source`), and ends on its end point without ERROR."""
    model, _, xy = compare_with_model(block, fp_source(fp, seed), 20000)
    assert xy == [0, 0]
    assert not model.out.error


def on_path_end(i: int, j: int, cw: bool, steps: int) -> tuple[int, int]:
    """A point of the digital circle ``steps`` steps after the start (relative to the start)."""
    path = make_path(Block.arc(0, 0, i, j, cw=cw))
    x0, y0 = path.x, path.y
    for _ in range(steps):
        path.advance()
    return path.x - x0, path.y - y0


# --- gateware against the model ---------------------------------------------------------------

fp_kinds = st.sampled_from(["saturated", "periodic", "random", "bursts"])
small = st.integers(-40, 40)


@settings(max_examples=25, deadline=None, derandomize=True)
@given(xe=small, ye=small, sqrt2=st.booleans(), fp=fp_kinds, seed=st.integers(0, 2**32))
def test_gateware_equals_model_on_random_lines(xe, ye, sqrt2, fp, seed):
    block = Block.line(xe, ye, sqrt2=sqrt2)
    model, _, xy = compare_with_model(block, fp_source(fp, seed), 2500)
    assert model.out.irq, "the line did not finish"
    assert xy == [0, 0]


@settings(max_examples=12, deadline=None, derandomize=True)
@given(xe=st.integers(-COORD_MAX, COORD_MAX), ye=st.integers(-COORD_MAX, COORD_MAX),
       sqrt2=st.booleans(), seed=st.integers(0, 2**32))
def test_gateware_equals_model_on_the_first_steps_of_long_lines(xe, ye, sqrt2, seed):
    compare_with_model(Block.line(xe, ye, sqrt2=sqrt2), fp_source("random", seed), 600)


@settings(max_examples=25, deadline=None, derandomize=True)
@given(i=st.integers(-12, 12), j=st.integers(-12, 12), cw=st.booleans(), sqrt2=st.booleans(),
       frac=st.floats(0.0, 1.0), fp=fp_kinds, seed=st.integers(0, 2**32))
def test_gateware_equals_model_on_random_arcs(i, j, cw, sqrt2, frac, fp, seed):
    if i == 0 and j == 0:
        i = 3
    full = plan(Block.arc(0, 0, i, j, cw=cw)).steps
    xe, ye = on_path_end(i, j, cw, max(1, round(frac * full)))
    block = Block.arc(xe, ye, i, j, cw=cw, sqrt2=sqrt2)
    model, _, xy = compare_with_model(block, fp_source(fp, seed), 6000)
    assert model.out.irq and not model.out.error
    assert xy == [0, 0]


@settings(max_examples=10, deadline=None, derandomize=True)
@given(i=st.integers(-COORD_MAX, COORD_MAX), j=st.integers(-COORD_MAX, COORD_MAX),
       cw=st.booleans(), sqrt2=st.booleans(), seed=st.integers(0, 2**32))
def test_gateware_equals_model_on_the_first_steps_of_large_arcs(i, j, cw, sqrt2, seed):
    # Ends a quarter of the way round: the end point is exact, far beyond the compared steps.
    if i * i + j * j > (1 << 46) - (1 << 23) or (i == 0 and j == 0):
        i, j = i // 2 or 1, j // 2
    while max(abs(i + j), abs(i - j)) > COORD_MAX:  # the end, relative to the start, fits
        i, j = i // 2 or 1, j // 2
    x, y = -i, -j
    ex, ey = (-y, x) if not cw else (y, -x)
    block = Block.arc(ex - x, ey - y, i, j, cw=cw, sqrt2=sqrt2)
    compare_with_model(block, fp_source("random", seed), 900)


def test_full_circles_in_both_directions_match_and_return_to_start():
    for cw in (False, True):
        model, _, xy = compare_with_model(Block.arc(0, 0, -5, 2, cw=cw, sqrt2=True),
                                          fp_source("saturated", 0), 4000)
        assert xy == [0, 0]
        assert not model.out.error


def test_invalid_minus_2_pow_23_sets_error_and_emits_nothing():
    model, cycles, _ = compare_with_model(Block.line(-(1 << 23), 5), fp_source("saturated", 0), 5)
    assert model.out.error and model.out.irq and not model.out.busy
    assert cycles == 1


def test_circle_leaving_the_24_bit_range_is_refused_after_the_radius_check():
    big = Block(Kind.CIRCULAR, 0, 0, COORD_MAX, COORD_MAX, quadrant=1)
    model, cycles, _ = compare_with_model(big, fp_source("saturated", 0), 100)
    assert model.out.error and model.out.irq
    assert cycles == CIRCLE_SETUP_CYCLES + 1


def test_largest_valid_circle_starts():
    block = Block.arc(COORD_MAX, COORD_MAX, COORD_MAX, 0)
    model, _, _ = compare_with_model(block, fp_source("saturated", 0), 200)
    assert model.out.busy and not model.out.error


def test_end_point_quadrant_mismatch_is_refused():
    block = Block(Kind.CIRCULAR, -10, 10, -10, 0, quadrant=3)  # end (0, 10) is in quadrant 2
    model, _, _ = compare_with_model(block, fp_source("saturated", 0), 100)
    assert model.out.error


def test_zero_length_line_requests_data_at_once_without_busy():
    model, cycles, _ = compare_with_model(Block.line(0, 0), fp_source("saturated", 0), 5)
    assert model.out.irq and not model.out.error
    assert cycles == 1


def test_steps_come_exactly_latency_cycles_after_the_credit_completing_fp():
    # One FP at a time, far apart: each step lands L cycles after its FP.
    for block, latency, first in ((Block.line(3, 1), LATENCY_LINEAR, 1),
                                  (Block.arc(-4, 4, -4, 0), LATENCY_CIRCULAR,
                                   1 + CIRCLE_SETUP_CYCLES)):
        fp_cycles = [first + 50 * k for k in range(3)]
        dut = K3701()
        steps: list[int] = []

        async def bench(ctx, dut=dut, block=block, fp_cycles=fp_cycles, steps=steps):
            await load(ctx, dut, block)
            await bus_write(ctx, dut.bus, CMD.addr, CMD.encode(start=1))
            for t in range(200):
                ctx.set(dut.fp, int(t in fp_cycles))
                if any(ctx.get(getattr(dut, n)) for n in OUTPUTS[:4]):
                    steps.append(t)
                await ctx.tick()

        simulate(dut, bench)
        assert steps[:3] == [c + latency for c in fp_cycles]


@pytest.mark.parametrize(("block", "latency"), [
    (Block.line(200, 0), LATENCY_LINEAR),
    (Block.line(200, 77), LATENCY_LINEAR),
    (Block.arc(0, 0, -1000, 0), LATENCY_CIRCULAR),
])
def test_saturated_fp_gives_one_step_per_latency(block, latency):
    """With FP every cycle at 1 MHz: 1e6/11 steps/s linear, 1e6/21 circular."""
    dut = K3701()
    steps: list[int] = []
    flags: dict = {}

    async def bench(ctx):
        await load(ctx, dut, block)
        await bus_write(ctx, dut.bus, CMD.addr, CMD.encode(start=1))
        ctx.set(dut.fp, 1)
        for t in range(40 * latency):
            if any(ctx.get(getattr(dut, n)) for n in OUTPUTS[:4]):
                steps.append(t)
            await ctx.tick()
        flags["overrun"] = ctx.get(dut.overrun)

    simulate(dut, bench)
    gaps = {b - a for a, b in itertools.pairwise(steps)}
    assert gaps == {latency}
    assert 1e6 / gaps.pop() == pytest.approx(1e6 / latency)
    assert flags["overrun"], "saturated FP must overrun the one-FP hold (never silently)"


def test_bytes_written_while_busy_do_not_disturb_the_running_block():
    block = Block.line(12, -5)
    dut = K3701()
    model = K3701Model()

    async def bench(ctx):
        await load(ctx, dut, block)
        await bus_write(ctx, dut.bus, CMD.addr, CMD.encode(start=1))
        model.cycle(start=block)
        # Overwrite every data register, and try to start again, while the block runs.
        for name, value in (("X", 1000), ("Y", -999), ("I", 5), ("J", 6)):
            for k, byte in enumerate(K3701_MAP[name].to_bytes(value)):
                ctx.set(dut.fp, 1)
                await bus_write(ctx, dut.bus, K3701_MAP[name].addr + k, byte)
                model.cycle(fp=True)
        ctx.set(dut.fp, 1)
        for _ in range(400):
            await ctx.tick()
            model.cycle(fp=True)
        assert ctx.get(dut.irq) and not ctx.get(dut.busy)
        assert await read_reg(ctx, dut.bus, K3701_MAP["X"]) == 0
        assert await read_reg(ctx, dut.bus, K3701_MAP["Y"]) == 0
        assert not ctx.get(dut.error)

    simulate(dut, bench)
    assert plan(block).end == (12, -5)


def test_start_while_busy_is_refused_with_error_and_ack_clears_irq():
    block = Block.line(30, 0)
    dut = K3701()

    async def bench(ctx):
        await load(ctx, dut, block)
        await bus_write(ctx, dut.bus, CMD.addr, CMD.encode(start=1))
        await bus_write(ctx, dut.bus, CMD.addr, CMD.encode(start=1))
        await ctx.tick()
        assert ctx.get(dut.error) and ctx.get(dut.busy)
        await bus_write(ctx, dut.bus, CMD.addr, CMD.encode(clear=1))
        await ctx.tick()
        assert not ctx.get(dut.error)
        ctx.set(dut.fp, 1)
        for _ in range(30 * LATENCY_LINEAR + 5):
            await ctx.tick()
        assert ctx.get(dut.irq)
        await bus_write(ctx, dut.bus, CMD.addr, CMD.encode(ack=1))
        await ctx.tick()
        assert not ctx.get(dut.irq)

    simulate(dut, bench)


# --- each datapath alone, against the model's step decisions --------------------------------

def decisions_alone(block: Block, latency: int, gaps: list[int], max_steps: int) -> list[tuple]:
    """Drive the datapath of ``block``'s type alone through its ports, as the core does, with
    the ``latency`` and the idle cycles ``gaps`` (cycled) between steps.

    Returns what it answered: ("end", error) if it ended the block without a step, else one
    (dx, dy, diag, final, error) per step, up to the final one or ``max_steps``.
    """
    datapath = {Kind.LINEAR: LinearDatapath, Kind.CIRCULAR: CircularDatapath}[block.kind]()
    assert latency >= 2 + datapath.STAGES
    answers: list[tuple] = []

    async def bench(ctx):
        for name, value in (("xe", block.xe), ("ye", block.ye), ("i", block.i),
                            ("j", block.j), ("cw", int(block.cw)),
                            ("quadrant", block.quadrant - 1)):
            ctx.set(getattr(datapath.block, name), value)
        ctx.set(datapath.start, 1)
        if not datapath.SETUP and ctx.get(datapath.end):
            answers.append(("end", ctx.get(datapath.error)))
            return
        await ctx.tick()
        ctx.set(datapath.start, 0)
        ctx.set(datapath.setup, datapath.SETUP)
        setup_cycles = 0
        while datapath.SETUP and not ctx.get(datapath.ready):
            if ctx.get(datapath.end):
                answers.append(("end", ctx.get(datapath.error)))
                return
            setup_cycles += 1
            await ctx.tick()
        if datapath.SETUP:
            assert setup_cycles + 1 == CIRCLE_SETUP_CYCLES
            await ctx.tick()
            ctx.set(datapath.setup, 0)
        step = datapath.step
        for gap in itertools.islice(itertools.cycle(gaps), max_steps):
            diag = ctx.get(step.diag)  # C: the credit completes (the cost is read)
            await ctx.tick()
            for k in range(latency - 2):  # C+1 .. C+L-2, the stages first
                ctx.set(datapath.stage, 1 << k if k < datapath.STAGES else 0)
                await ctx.tick()
            ctx.set(datapath.stage, 0)
            ctx.set(datapath.advance, 1)  # C+L-1: the step is taken
            assert ctx.get(step.diag) == diag
            answers.append((ctx.get(step.x) * (-1 if ctx.get(step.x_neg) else 1),
                            ctx.get(step.y) * (-1 if ctx.get(step.y_neg) else 1),
                            diag, ctx.get(step.final), ctx.get(step.error)))
            await ctx.tick()
            ctx.set(datapath.advance, 0)
            if answers[-1][3]:
                return
            for _ in range(gap):
                await ctx.tick()

    simulate(datapath, bench)
    return answers


def model_decisions(block: Block) -> list[tuple]:
    """:func:`decisions_alone` as the reference model's paths decide them."""
    try:
        path = make_path(block)
    except BlockError:
        return [("end", 1)]
    if path.done:  # a zero-length line
        return [("end", 0)]
    answers = []
    final = False
    while not final:
        step, final, error = path.advance()
        answers.append((step.dx, step.dy, int(step.diagonal), int(final), int(error)))
    return answers


@settings(max_examples=30, deadline=None, derandomize=True)
@given(xe=small, ye=small, latency=st.integers(2, 12),
       gaps=st.lists(st.integers(0, 5), min_size=1, max_size=4))
def test_linear_datapath_alone_decides_the_models_steps(xe, ye, latency, gaps):
    block = Block.line(xe, ye)
    want = model_decisions(block)
    assert decisions_alone(block, latency, gaps, len(want) + 1) == want


@settings(max_examples=20, deadline=None, derandomize=True)
@given(i=st.integers(-12, 12), j=st.integers(-12, 12), cw=st.booleans(),
       frac=st.floats(0.0, 1.0), latency=st.integers(6, 12),
       gaps=st.lists(st.integers(0, 5), min_size=1, max_size=4))
def test_circular_datapath_alone_decides_the_models_steps(i, j, cw, frac, latency, gaps):
    if i == 0 and j == 0:
        i = 3
    full = plan(Block.arc(0, 0, i, j, cw=cw)).steps
    xe, ye = on_path_end(i, j, cw, max(1, round(frac * full)))
    block = Block.arc(xe, ye, i, j, cw=cw)
    want = model_decisions(block)
    assert decisions_alone(block, latency, gaps, len(want) + 1) == want


@pytest.mark.parametrize("block", [
    Block.line(-(1 << 23), 5),                               # refused in S
    Block.line(0, 0),                                        # nothing to do
    Block(Kind.CIRCULAR, 0, 0, COORD_MAX, COORD_MAX, quadrant=1),  # radius too large
    Block(Kind.CIRCULAR, -10, 10, -10, 0, quadrant=3),       # end not in its quadrant
    Block(Kind.CIRCULAR, 10, 15, -10, 0, quadrant=1),        # leaves its end quadrant
])
def test_datapaths_alone_end_refused_and_empty_blocks_as_the_model(block):
    want = model_decisions(block)
    assert decisions_alone(block, 6, [0], len(want) + 1) == want
