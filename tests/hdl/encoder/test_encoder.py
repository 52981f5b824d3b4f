"""Encoder interface: gateware against the reference model, glitch filter, decoding modes,
direction, latency, quadrature errors and broken lines."""

import random
from dataclasses import dataclass

import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from k37.hdl.encoder.chip import EncoderInterface
from k37.hdl.encoder.map import ENCODER_MAP, Decode
from k37.hdl.encoder.model import EncoderModel
from tests.testbench import BusOp, bus_write, drive_bus, read_ops, read_reg, simulate, write_ops

WIRES = ("a", "a_n", "b", "b_n")
#: (A, B) at x4 position p (index p mod 4): A leading B, 00 -> 10 -> 11 -> 01, counts up.
STATES = ((0, 0), (1, 0), (1, 1), (0, 1))
K_INIT = ENCODER_MAP["FILTER"].init
CMD = ENCODER_MAP["CMD"]
STATUS = ENCODER_MAP["STATUS"]


def _wires(p: int) -> tuple[int, int, int, int]:
    """The four clean lines at x4 position ``p``."""
    a, b = STATES[p % 4]
    return a, 1 - a, b, 1 - b


def _set(ctx, dut, wires) -> None:
    """Drive the four encoder lines."""
    for name, value in zip(WIRES, wires, strict=True):
        ctx.set(getattr(dut, name), value)


def _decoded(p: int, decode: Decode) -> int:
    """The net count for a walk from position 0 to ``p`` in a decoding mode.

    x2 counts the A edges (between states 0|1 and 2|3), x1 the A edge between states 0|1.
    """
    return {Decode.X4: p, Decode.X2: (p + 1) // 2, Decode.X1: (p + 3) // 4}[decode]


def glitchy_walk(seed: int, edges: int, k: int, *, extra: int = 3,
                 glitch_rate: float = 0.8) -> tuple[list[tuple[tuple[int, ...], int]], int]:
    """A random quadrature walk with glitches shorter than ``k``: (wires, cycles) segments.

    Returns the segments and the true final x4 position. Each line holds every true level
    for at least ``k`` samples; the walk reverses now and then. A glitch (1..k-1 samples,
    on a random line: both wires flipped, or only one, which breaks the pair) is placed
    where the filter must reject it without shifting a true edge: at least ``k`` samples
    after its line's last edge and ending at least one clean sample before the next edge.
    """
    rng = random.Random(seed)
    rand = rng.random
    segments: list[tuple[tuple[int, ...], int]] = []
    p, direction, t = 0, 1, 0
    last_edge = [0, 0]  # per line; reset counts as an edge (the first sample sets the level)
    for _ in range(edges):
        if rand() < 0.1:
            direction = -direction
        line = 0 if STATES[(p + direction) % 4][0] != STATES[p % 4][0] else 1
        t_next = max(t + 1, last_edge[line] + k) + int(rand() * (extra + 1))
        clean = _wires(p)
        length = 1 + int(rand() * (k - 1)) if k > 1 else 0
        first = int(rand() * 2)
        for x in (first, 1 - first):  # a random line, else the other one if only it has room
            start = max(t, last_edge[x] + k)
            room = t_next - 1 - length - start  # the glitch ends at t_next - 2 at the latest
            if room >= 0:
                break
        if length and room >= 0 and rand() < glitch_rate:
            g0 = start + int(rand() * (room + 1))
            flips = ((1, 1), (1, 0), (0, 1))[int(rand() * 3)]
            glitch = list(clean)
            glitch[2 * x] ^= flips[0]
            glitch[2 * x + 1] ^= flips[1]
            segments += [(clean, g0 - t), (tuple(glitch), length), (clean, t_next - g0 - length)]
        else:
            segments.append((clean, t_next - t))
        last_edge[line] = t_next
        t = t_next
        p += direction
    segments.append((_wires(p), k + 1))  # let the last edge through the filter
    return [s for s in segments if s[1]], p


# -- lockstep against the model -------------------------------------------------------------

@dataclass(frozen=True)
class Cycle:
    """One clock cycle of stimulus: the four lines and an optional bus operation."""

    wires: tuple[int, ...]
    op: BusOp | None = None
    #: (register name, value) when ``op`` is the committing byte of a write.
    commit: tuple[str, int] | None = None


def _lockstep(cycles: list[Cycle]) -> None:
    """Run ``cycles`` on the gateware and the model side by side, comparing every cycle."""
    dut = EncoderInterface()
    model = EncoderModel()

    async def bench(ctx):
        expected_read = 0
        for t, cycle in enumerate(cycles):
            _set(ctx, dut, cycle.wires)
            drive_bus(ctx, dut.bus, cycle.op)
            if cycle.commit:
                model.write(*cycle.commit)
            reading = cycle.op is not None and cycle.op.data is None
            if reading:
                # Registers update at the edge that ends the cycle; the snapshot is taken at
                # that same edge, so it holds the values from before it.
                reg, k = ENCODER_MAP.at(cycle.op.addr)
                assert k == 0
                expected_read = (model.status if reg.name == "STATUS"
                                 else model.bank.values[reg.name])
            pulse = model.step(*cycle.wires)
            await ctx.tick()
            got = tuple(ctx.get(getattr(dut, n))
                        for n in ("fb_pos", "fb_neg", "line_fault", "quad_error"))
            assert got == (pulse == 1, pulse == -1, model.line_fault, model.quad_error), t
            if reading:
                assert ctx.get(dut.bus.r_data) == expected_read, (t, reg.name)

    simulate(dut, bench)


def _write(name: str, value: int, wires: tuple[int, ...]) -> list[Cycle]:
    (op,) = write_ops(ENCODER_MAP[name], value, check=False)
    return [Cycle(wires, op, (name, value))]


@st.composite
def _streams(draw, length: int) -> list[Cycle]:
    wires = list(_wires(draw(st.integers(0, 3))))
    cycles = _write("FILTER", draw(st.integers(1, 4)), tuple(wires))
    while len(cycles) < length:
        kind = draw(st.sampled_from(["hold", "step", "step", "step", "both", "glitch",
                                     "break", "write", "read"]))
        if kind == "step":    # one line changes: a quadrature edge
            x = draw(st.integers(0, 1))
            wires[2 * x] ^= 1
            wires[2 * x + 1] ^= 1
        elif kind == "both":  # both lines change at once: illegal
            wires = [w ^ 1 for w in wires]
        elif kind in ("glitch", "break"):  # some wires flip for a while, then return
            flips = draw(st.lists(st.integers(0, 3), min_size=1, max_size=4))
            bad = list(wires)
            for w in flips:
                bad[w] ^= 1
            span = draw(st.integers(1, 6))
            cycles += [Cycle(tuple(bad))] * span
        if kind == "write":
            name, value = draw(st.one_of(
                st.tuples(st.just("FILTER"), st.integers(0, 6)),  # 0 is refused
                st.tuples(st.just("MODE"), st.integers(0, 3)),    # 3 is refused
                st.tuples(st.just("CMD"), st.integers(0, 1)),
            ))
            cycles += _write(name, value, tuple(wires))
        elif kind == "read":
            (op,) = read_ops(ENCODER_MAP[draw(st.sampled_from(["STATUS", "FILTER", "MODE"]))])
            cycles.append(Cycle(tuple(wires), op))
        cycles += [Cycle(tuple(wires))] * draw(st.integers(1, 8))
    return cycles


# No shrinking: a shrink of a multi-thousand-cycle stream takes minutes in the simulator, and
# the failing cycle is named by the assertion anyway.
@settings(derandomize=True, deadline=None, max_examples=6,
          phases=(Phase.explicit, Phase.reuse, Phase.generate),
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                 HealthCheck.large_base_example])
@given(_streams(2000))
def test_gateware_equals_model_on_random_streams(cycles):
    _lockstep(cycles)


def test_gateware_equals_model_on_a_glitchy_walk_in_every_mode():
    segments, _ = glitchy_walk(7, 120, K_INIT, extra=4)
    cycles = []
    for decode in Decode:
        cycles += _write("MODE", decode, segments[0][0])
        cycles += [Cycle(wires) for wires, n in segments for _ in range(n)]
    _lockstep(cycles)


# -- counting -------------------------------------------------------------------------------

@pytest.mark.slow
@pytest.mark.slow
def test_glitches_shorter_than_k_never_change_the_count_over_a_million_edges():
    # The reference model (equal to the gateware above) runs what the Amaranth simulator
    # cannot: 10^6 edges, about 3 x 10^6 samples.
    edges = 1_000_000
    segments, position = glitchy_walk(2024, edges, K_INIT)
    clean = {_wires(p) for p in range(4)}
    assert sum(1 for wires, _ in segments if wires not in clean) > edges // 4
    model = EncoderModel()
    step = model.step
    count = 0
    for wires, n in segments:
        for _ in range(n):
            count += step(*wires)
    assert count == position
    assert (model.line_fault, model.quad_error) == (0, 0)


def test_gateware_counts_a_glitchy_walk_exactly():
    segments, position = glitchy_walk(11, 300, K_INIT)
    dut = EncoderInterface()

    async def bench(ctx):
        count = 0
        for wires, n in segments:
            _set(ctx, dut, wires)
            for _ in range(n):
                await ctx.tick()
                count += ctx.get(dut.fb_pos) - ctx.get(dut.fb_neg)
        assert count == position
        assert (ctx.get(dut.line_fault), ctx.get(dut.quad_error)) == (0, 0)

    simulate(dut, bench)


def test_glitch_of_k_samples_is_accepted():
    # A differential glitch as long as the filter is a real edge there and back: +1, -1.
    dut = EncoderInterface()

    async def bench(ctx):
        pulses = []
        for wires, n in ((_wires(0), 10), (_wires(1), K_INIT), (_wires(0), 10)):
            _set(ctx, dut, wires)
            for _ in range(n):
                await ctx.tick()
                pulses.append(ctx.get(dut.fb_pos) - ctx.get(dut.fb_neg))
        assert [p for p in pulses if p] == [1, -1]

    simulate(dut, bench)


def _walk(dut, direction: int, edges: int, spacing: int, start: int = 0):
    """A bench walking ``edges`` clean edges from ``start``; and the (fb_pos, fb_neg) seen."""
    seen = []

    async def bench(ctx):
        for i in range(edges + 1):
            _set(ctx, dut, _wires(start + direction * i))
            for _ in range(spacing):
                await ctx.tick()
                seen.append((ctx.get(dut.fb_pos), ctx.get(dut.fb_neg)))

    return bench, seen


@pytest.mark.parametrize("p0", [1, 2, 3])
def test_first_sample_after_reset_sets_the_origin_without_counting(p0):
    dut = EncoderInterface()
    walk, seen = _walk(dut, 1, 3, spacing=K_INIT + 1, start=p0)

    async def bench(ctx):
        await walk(ctx)  # the encoder rests away from state 00 at reset, then moves on
        assert sum(p for p, _ in seen) == 3
        assert sum(n for _, n in seen) == ctx.get(dut.quad_error) == 0

    simulate(dut, bench)


@pytest.mark.parametrize("decode", list(Decode))
@pytest.mark.parametrize("direction", [1, -1])
def test_reverse_direction_counts_down_in_every_mode(decode, direction):
    edges = 21
    dut = EncoderInterface()
    walk, seen = _walk(dut, direction, edges, spacing=K_INIT + 1)

    async def bench(ctx):
        _set(ctx, dut, _wires(0))
        await bus_write(ctx, dut.bus, ENCODER_MAP["MODE"].addr, decode)
        await walk(ctx)

    simulate(dut, bench)
    assert (1, 1) not in seen
    ups = sum(p for p, _ in seen)
    downs = sum(n for _, n in seen)
    assert ups - downs == _decoded(direction * edges, decode)
    assert (downs if direction > 0 else ups) == 0  # never a count against the motion


def test_edge_reaches_fb_after_k_cycles_as_a_one_cycle_pulse():
    for k in (1, 2, K_INIT, 7):
        dut = EncoderInterface()

        async def bench(ctx, k=k, dut=dut):
            _set(ctx, dut, _wires(0))
            await bus_write(ctx, dut.bus, ENCODER_MAP["FILTER"].addr, k)
            await ctx.tick().repeat(10)
            _set(ctx, dut, _wires(1))  # cycle t: A rises
            trace = []
            for _ in range(k + 3):
                await ctx.tick()
                trace.append(ctx.get(dut.fb_pos))
            assert trace == [int(i == k) for i in range(1, k + 4)], k

        simulate(dut, bench)


def test_both_lines_changing_in_one_sample_is_a_sticky_quadrature_error():
    dut = EncoderInterface()

    async def bench(ctx):
        pulses = 0
        for p, n in ((0, 10), (2, 10), (3, 10), (0, 10)):  # 00 -> 11 illegal, then legal
            _set(ctx, dut, _wires(p))
            for i in range(n):
                await ctx.tick()
                pulses += ctx.get(dut.fb_pos) + ctx.get(dut.fb_neg)
                if p == 2 and i == K_INIT - 1:
                    assert ctx.get(dut.quad_error) == 1
        assert pulses == 2  # the two legal edges only
        assert STATUS.field("quad_error").decode(await read_reg(ctx, dut.bus, STATUS)) == 1
        await bus_write(ctx, dut.bus, CMD.addr, CMD.encode(clear=1))
        await ctx.tick()
        assert ctx.get(dut.quad_error) == 0

    simulate(dut, bench)


@pytest.mark.parametrize("wire", WIRES)
def test_broken_line_is_flagged_after_k_samples(wire):
    dut = EncoderInterface()
    line = "ab"[WIRES.index(wire) // 2]

    async def bench(ctx):
        _set(ctx, dut, _wires(0))
        await ctx.tick().repeat(5)
        # A wire stuck at its partner's level for K - 1 samples is a glitch, for K a fault.
        for n, fault in ((K_INIT - 1, 0), (K_INIT, 1)):
            ctx.set(getattr(dut, wire), 1 - ctx.get(getattr(dut, wire)))
            await ctx.tick().repeat(n)
            assert ctx.get(dut.line_fault) == fault, n
            ctx.set(getattr(dut, wire), 1 - ctx.get(getattr(dut, wire)))
            await ctx.tick()
        status = await read_reg(ctx, dut.bus, STATUS)
        assert STATUS.field(f"line_fault_{line}").decode(status) == 1
        assert STATUS.field(f"line_fault_{'ba'[line == 'b']}").decode(status) == 0
        assert (ctx.get(dut.fb_pos), ctx.get(dut.fb_neg), ctx.get(dut.quad_error)) == (0, 0, 0)
        # The flag holds until cleared; a line still broken is flagged again after K samples.
        await bus_write(ctx, dut.bus, CMD.addr, CMD.encode(clear=1))
        await ctx.tick()
        assert ctx.get(dut.line_fault) == 0
        ctx.set(getattr(dut, wire), 1 - ctx.get(getattr(dut, wire)))
        await ctx.tick().repeat(K_INIT)
        assert ctx.get(dut.line_fault) == 1

    simulate(dut, bench)


def test_out_of_range_settings_are_ignored_and_flagged():
    dut = EncoderInterface()

    async def bench(ctx):
        for name, bad in (("FILTER", 0), ("MODE", 3)):
            reg = ENCODER_MAP[name]
            await bus_write(ctx, dut.bus, reg.addr, bad)
            await ctx.tick()
            assert await read_reg(ctx, dut.bus, reg) == reg.init
            assert STATUS.field("bad_config").decode(await read_reg(ctx, dut.bus, STATUS))
            await bus_write(ctx, dut.bus, CMD.addr, CMD.encode(clear=1))
            await ctx.tick()
            assert not STATUS.field("bad_config").decode(await read_reg(ctx, dut.bus, STATUS))

    simulate(dut, bench)
    with pytest.raises(ValueError, match=r"register FILTER: 0 is outside 1\.\.255"):
        ENCODER_MAP["FILTER"].to_bytes(0)


def test_model_decoding_modes_follow_the_position_over_a_random_walk():
    rng = random.Random(5)
    for decode in Decode:
        model = EncoderModel()
        model.write("MODE", decode)
        p = count = 0
        for _ in range(K_INIT):  # the first sample after reset sets the origin
            count += model.step(*_wires(p))
        for _ in range(3000):
            p += rng.choice((-1, 1))
            for _ in range(K_INIT + rng.randrange(3)):
                count += model.step(*_wires(p))
            assert count == _decoded(p, decode), (decode, p)
