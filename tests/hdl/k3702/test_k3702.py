"""KM3702 position controller: gateware against the reference model, counters, D/A word,
zones, alarm interrupt and torn-free host reads."""

from dataclasses import dataclass, fields

import pytest
from amaranth.back import verilog
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from k37.hdl.k3702.chip import K3702
from k37.hdl.k3702.map import K3702_MAP
from k37.hdl.k3702.model import K3702Model, K3702Outputs, wrap
from k37.sim.backends.contract import CLOCK_PERIOD
from tests.testbench import (
    BusOp,
    bus_write,
    drive_bus,
    read_ops,
    read_reg,
    simulate,
    write_ops,
    write_reg,
)

INPUTS = ("com_pos", "com_neg", "fb_pos", "fb_neg")
PORTS = tuple(f.name for f in fields(K3702Outputs) if f.name != "status")
MAX = (1 << 23) - 1
MIN = -(1 << 23)
CMD = K3702_MAP["CMD"]
STATUS = K3702_MAP["STATUS"]

# No shrinking: a shrink of a multi-thousand-cycle stream takes minutes in the simulator, and
# the failing cycle is named by the assertion anyway.
SLOW = settings(derandomize=True, deadline=None, max_examples=6,
                phases=(Phase.explicit, Phase.reuse, Phase.generate),
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                       HealthCheck.large_base_example])


@dataclass(frozen=True)
class Cycle:
    """One clock cycle of stimulus: the four count inputs and an optional bus operation."""

    inputs: tuple[int, int, int, int] = (0, 0, 0, 0)
    op: BusOp | None = None
    #: (register name, value) when ``op`` is the committing byte of a write.
    commit: tuple[str, int] | None = None


def _write(name: str, value: int, inputs=(0, 0, 0, 0)) -> list[Cycle]:
    reg = K3702_MAP[name]
    ops = write_ops(reg, value, check=False)
    return [Cycle(inputs, op, (name, value) if k == len(ops) - 1 else None)
            for k, op in enumerate(ops)]


def _snapshot(name: str, out: K3702Outputs) -> int:
    """The raw value a read of ``name`` snapshots when byte 0 is read in the step of ``out``."""
    value = out.status if name == "STATUS" else getattr(out, name.lower())
    return value & ((1 << K3702_MAP[name].width) - 1)


def _lockstep(cycles: list[Cycle]):
    """Run ``cycles`` on the gateware and the model side by side, comparing every cycle.

    Every port is compared after every clock edge, and each byte the host reads is compared
    with the model's counter or status value of the snapshot cycle.
    """
    dut = K3702()
    model = K3702Model()

    async def bench(ctx):
        await ctx.tick()  # cycles count from the first rising edge (see K3702's docstring)
        expected_read = 0
        for t, cycle in enumerate(cycles):
            for name, value in zip(INPUTS, cycle.inputs, strict=True):
                ctx.set(getattr(dut, name), value)
            drive_bus(ctx, dut.bus, cycle.op)
            if cycle.commit:
                model.write(*cycle.commit)
            out = model.step(*cycle.inputs)
            await ctx.tick()
            for name in PORTS:
                assert ctx.get(getattr(dut, name)) == getattr(out, name), (t, name, out)
            if cycle.op is not None and cycle.op.data is None:
                reg, k = K3702_MAP.at(cycle.op.addr)
                if k == 0:
                    expected_read = _snapshot(reg.name, out)
                assert ctx.get(dut.bus.r_data) == (expected_read >> (8 * k)) & 0xFF, (t, reg)

    simulate(dut, bench)


# -- random streams -----------------------------------------------------------------------

_EDGES = [MAX, MIN, MAX - 2, MIN + 2, 0, -1, 127, -128, 255, -256, 0x7FFF, -0x8000, 0xFFFF]
_COUNTER_VALUES = st.one_of(st.sampled_from(_EDGES), st.integers(MIN, MAX))
_BITS = st.integers(0, 15).map(lambda v: tuple((v >> i) & 1 for i in range(4)))


@st.composite
def _streams(draw, length: int) -> list[Cycle]:
    cycles: list[Cycle] = []
    while len(cycles) < length:
        bits = draw(_BITS)
        kind = draw(st.sampled_from(["count"] * 6 + ["write", "read"]))
        if kind == "count":
            cycles += [Cycle(bits)] * draw(st.integers(1, 12))
        elif kind == "read":
            name = draw(st.sampled_from(["COMMAND", "ERROR", "STATUS"]))
            cycles += [Cycle(bits, op) for op in read_ops(K3702_MAP[name])]
        else:
            name, value = draw(st.one_of(
                st.tuples(st.just("CMD"), st.integers(0, 15)),
                st.tuples(st.just("DAC_BITS"), st.integers(6, 18)),  # 6, 7, 17, 18 refused
                st.tuples(st.just("POSITION_ZONE"), st.integers(0, 300)),
                st.tuples(st.just("ALARM_ZONE"), st.integers(0, 300)),
                st.tuples(st.sampled_from(["COMMAND", "ERROR"]), _COUNTER_VALUES),
                st.tuples(st.just("CORRECT"), st.integers(-128, 127)),
            ))
            cycles += _write(name, value, bits)
    return cycles


@SLOW
@given(_streams(1500))
def test_gateware_equals_model_on_random_streams(cycles):
    _lockstep(cycles)


@SLOW
@given(st.lists(_BITS, min_size=400, max_size=400), _COUNTER_VALUES, _COUNTER_VALUES)
def test_actual_position_is_command_minus_error_every_cycle(inputs, command0, error0):
    dut = K3702()

    async def bench(ctx):
        await write_reg(ctx, dut.bus, K3702_MAP["COMMAND"], command0)
        await write_reg(ctx, dut.bus, K3702_MAP["ERROR"], error0)
        await ctx.tick()  # the ERROR load acts in the cycle after its last byte
        position = wrap(command0 - error0)
        for bits in inputs:
            for name, value in zip(INPUTS, bits, strict=True):
                ctx.set(getattr(dut, name), value)
            # The feedback pulses alone move the axis: +FB one step forward, -FB back.
            position = wrap(position + bits[2] - bits[3])
            await ctx.tick()
            assert wrap(ctx.get(dut.command) - ctx.get(dut.error)) == position

    simulate(dut, bench)


# -- counters -------------------------------------------------------------------------------

def _hold(inputs, cycles: int) -> list[Cycle]:
    return [Cycle(inputs)] * cycles


def test_counters_wrap_silently_at_both_ends():
    dut = K3702()

    async def bench(ctx):
        for name in ("COMMAND", "ERROR"):
            await write_reg(ctx, dut.bus, K3702_MAP[name], MAX)
        await ctx.tick()
        assert (ctx.get(dut.command), ctx.get(dut.error)) == (MAX, MAX)
        ctx.set(dut.com_pos, 1)
        await ctx.tick()
        ctx.set(dut.com_pos, 0)
        assert (ctx.get(dut.command), ctx.get(dut.error)) == (MIN, MIN)  # 0x7FFFFF + 1
        assert await read_reg(ctx, dut.bus, K3702_MAP["ERROR"]) == MIN
        ctx.set(dut.com_neg, 1)
        await ctx.tick()
        ctx.set(dut.com_neg, 0)
        assert (ctx.get(dut.command), ctx.get(dut.error)) == (MAX, MAX)  # 0x800000 - 1
        ctx.set(dut.fb_neg, 1)  # -FB adds to the error counter only
        await ctx.tick()
        assert (ctx.get(dut.command), ctx.get(dut.error)) == (MAX, MIN)
        assert await read_reg(ctx, dut.bus, K3702_MAP["COMMAND"]) == MAX

    simulate(dut, bench)


def test_wraparound_matches_the_model_for_every_input():
    cycles = []
    for bits in ((1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1), (1, 0, 0, 1),
                 (0, 1, 1, 0)):
        for start in (MAX - 1, MIN + 1):
            cycles += _write("COMMAND", start) + _write("ERROR", start) + [Cycle()]
            cycles += _hold(bits, 4)
    _lockstep(cycles)


def test_input_held_n_cycles_counts_n_times():
    dut = K3702()

    async def bench(ctx):
        await ctx.tick()
        expected_command = expected_error = 0
        for port, n, d_command, d_error in (("com_pos", 7, 7, 7), ("com_neg", 3, -3, -3),
                                            ("fb_pos", 5, 0, -5), ("fb_neg", 2, 0, 2)):
            ctx.set(getattr(dut, port), 1)
            await ctx.tick().repeat(n)
            ctx.set(getattr(dut, port), 0)
            expected_command += d_command
            expected_error += d_error
            assert (ctx.get(dut.command), ctx.get(dut.error)) == (expected_command,
                                                                  expected_error)

    simulate(dut, bench)


@pytest.mark.parametrize(("bits", "d_command", "d_error"), [
    ((1, 0, 1, 0), 1, 0),    # +COM with +FB: the axis keeps up
    ((1, 1, 0, 0), 0, 0),    # +COM with -COM
    ((1, 0, 0, 1), 1, 2),    # +COM with -FB
    ((0, 1, 1, 0), -1, -2),  # -COM with +FB
    ((1, 1, 1, 1), 0, 0),
])
def test_simultaneous_inputs_all_count(bits, d_command, d_error):
    dut = K3702()

    async def bench(ctx):
        await ctx.tick()
        for name, value in zip(INPUTS, bits, strict=True):
            ctx.set(getattr(dut, name), value)
        await ctx.tick().repeat(3)
        assert (ctx.get(dut.command), ctx.get(dut.error)) == (3 * d_command, 3 * d_error)

    simulate(dut, bench)


def test_counters_change_on_the_falling_edge():
    dut = K3702()
    zero = 1 << (K3702_MAP["DAC_BITS"].init - 1)

    async def bench(ctx):
        await ctx.tick()
        ctx.set(dut.com_pos, 1)
        await ctx.delay(0.4 * CLOCK_PERIOD)  # before the falling edge (mid-cycle)
        assert ctx.get(dut.error) == 0
        await ctx.delay(0.2 * CLOCK_PERIOD)  # just after it, before the next rising edge
        assert (ctx.get(dut.command), ctx.get(dut.error), ctx.get(dut.dac)) == (1, 1, zero + 1)
        await ctx.tick()
        assert ctx.get(dut.error) == 1
        await ctx.tick()
        assert ctx.get(dut.error) == 2  # the input is still high: counted again

    simulate(dut, bench)


def test_clear_keeps_the_counts_of_its_own_cycle():
    # +COM held throughout; the clears act in the cycle after the CMD write and that cycle's
    # count lands on the cleared counter, so nothing is dropped but the old contents.
    clear = CMD.encode(clear_command=1, clear_error=1)
    cycles = (_hold((1, 0, 0, 0), 5) + _write("CMD", clear, (1, 0, 0, 0))
              + _hold((1, 0, 0, 0), 3))
    _lockstep(cycles)
    dut = K3702()

    async def bench(ctx):
        await ctx.tick()
        ctx.set(dut.com_pos, 1)
        await ctx.tick().repeat(5)
        await bus_write(ctx, dut.bus, CMD.addr, clear)
        assert ctx.get(dut.error) == 6
        await ctx.tick()  # the clear cycle, +COM still high
        assert (ctx.get(dut.command), ctx.get(dut.error)) == (1, 1)

    simulate(dut, bench)


@pytest.mark.parametrize("inputs", [(0, 0, 0, 0), (1, 0, 0, 0), (0, 1, 1, 0), (1, 1, 1, 1)])
def test_correction_pulses_move_command_and_error_together(inputs):
    # Each CORRECT write adds its value to both counters, with the counts of its own cycle;
    # the actual position (COMMAND - ERROR) only follows the feedback.
    cycles = []
    for value in (127, -128, 5, -1, 0):
        cycles += _write("CORRECT", value, inputs) + _hold(inputs, 2)
    _lockstep(cycles)
    dut = K3702()

    async def bench(ctx):
        await ctx.tick()
        for name, value in zip(INPUTS, inputs, strict=True):
            ctx.set(getattr(dut, name), value)
        await bus_write(ctx, dut.bus, K3702_MAP["CORRECT"].addr, (-100) & 0xFF)
        com = inputs[0] - inputs[1]
        fb = inputs[2] - inputs[3]
        assert (ctx.get(dut.command), ctx.get(dut.error)) == (com, com - fb)
        await ctx.tick()  # the correction acts here, with this cycle's counts
        assert (ctx.get(dut.command), ctx.get(dut.error)) == (2 * com - 100,
                                                              2 * (com - fb) - 100)
        assert ctx.get(dut.command) - ctx.get(dut.error) == 2 * fb

    simulate(dut, bench)


def test_correction_pulses_wrap_with_the_counters():
    cycles = (_write("COMMAND", MAX - 3) + _write("ERROR", MIN + 3) + [Cycle()]
              + _write("CORRECT", 100) + _write("CORRECT", -128) + _hold((0, 0, 0, 0), 3))
    _lockstep(cycles)


# -- D/A word, zones, alarm -------------------------------------------------------------------

def _offset_binary(error: int, n: int) -> int:
    return min(max(error, -(1 << (n - 1))), (1 << (n - 1)) - 1) + (1 << (n - 1))


def test_dac_word_saturates_with_flags_for_every_width():
    dut = K3702()

    async def bench(ctx):
        for n in range(8, 17):
            await write_reg(ctx, dut.bus, K3702_MAP["DAC_BITS"], n)
            half = 1 << (n - 1)
            for error in (0, 1, -1, half - 1, half, -half, -half - 1, MAX, MIN):
                await write_reg(ctx, dut.bus, K3702_MAP["ERROR"], error)
                await ctx.tick()
                assert ctx.get(dut.error) == error
                assert ctx.get(dut.dac) == _offset_binary(error, n), (n, error)
                assert ctx.get(dut.sat_pos) == (error > half - 1), (n, error)
                assert ctx.get(dut.sat_neg) == (error < -half), (n, error)
                status = await read_reg(ctx, dut.bus, STATUS)
                assert STATUS.field("sat_pos").decode(status) == (error > half - 1)
                assert STATUS.field("sat_neg").decode(status) == (error < -half)
                assert STATUS.field("negative").decode(status) == (error < 0)

    simulate(dut, bench)


def test_dac_word_tracks_the_model_for_every_width_while_counting():
    cycles = []
    for n in range(8, 17):
        half = 1 << (n - 1)
        cycles += _write("DAC_BITS", n) + _write("ERROR", half - 3)
        cycles += _hold((1, 0, 0, 0), 6) + _write("ERROR", -half + 2) + _hold((0, 1, 0, 0), 6)
    _lockstep(cycles)


def test_in_position_and_alarm_zones_at_their_bounds():
    w, a = 20, 300
    dut = K3702()

    async def bench(ctx):
        await write_reg(ctx, dut.bus, K3702_MAP["POSITION_ZONE"], w)
        await write_reg(ctx, dut.bus, K3702_MAP["ALARM_ZONE"], a)
        for error in (0, w, -w, w + 1, -w - 1, a, -a, a + 1, -a - 1, MIN, MAX):
            await write_reg(ctx, dut.bus, K3702_MAP["ERROR"], error)
            await ctx.tick()
            assert ctx.get(dut.in_position) == (abs(error) <= w), error
            assert ctx.get(dut.alarm_n) == (abs(error) <= a), error
            assert ctx.get(dut.negative) == (error < 0), error

    simulate(dut, bench)


def test_alarm_interrupts_and_holds_until_acknowledged():
    a = 4
    ack = CMD.encode(ack=1)
    dut = K3702()

    async def bench(ctx):
        await write_reg(ctx, dut.bus, K3702_MAP["ALARM_ZONE"], a)
        ctx.set(dut.com_pos, 1)
        await ctx.tick().repeat(a)
        assert (ctx.get(dut.alarm_n), ctx.get(dut.irq)) == (1, 0)
        await ctx.tick()  # |error| = A + 1: ALARM low and the interrupt in the same cycle
        ctx.set(dut.com_pos, 0)
        assert (ctx.get(dut.alarm_n), ctx.get(dut.irq)) == (0, 1)
        ctx.set(dut.fb_pos, 1)  # the axis catches up: the alarm ends, the interrupt holds
        await ctx.tick().repeat(a + 1)
        ctx.set(dut.fb_pos, 0)
        assert (ctx.get(dut.error), ctx.get(dut.alarm_n), ctx.get(dut.irq)) == (0, 1, 1)
        await ctx.tick().repeat(10)
        assert ctx.get(dut.irq) == 1
        assert STATUS.field("irq").decode(await read_reg(ctx, dut.bus, STATUS)) == 1
        await bus_write(ctx, dut.bus, CMD.addr, ack)
        assert ctx.get(dut.irq) == 1  # acted on at the falling edge of the next cycle
        await ctx.tick()
        assert ctx.get(dut.irq) == 0
        # Acknowledged while still in the alarm zone: no new interrupt until a new entry.
        ctx.set(dut.com_neg, 1)
        await ctx.tick().repeat(a + 1)
        ctx.set(dut.com_neg, 0)
        assert (ctx.get(dut.alarm_n), ctx.get(dut.irq)) == (0, 1)
        await bus_write(ctx, dut.bus, CMD.addr, ack)
        await ctx.tick().repeat(5)
        assert (ctx.get(dut.alarm_n), ctx.get(dut.irq)) == (0, 0)

    simulate(dut, bench)


def test_acknowledge_never_hides_a_new_alarm_entry():
    # The ack acts in the cycle in which the error re-enters the alarm zone.
    cycles = (_write("ALARM_ZONE", 2) + _hold((1, 0, 0, 0), 3) + _hold((0, 0, 1, 0), 1)
              + _write("CMD", CMD.encode(ack=1)) + [Cycle((1, 0, 0, 0))] + _hold((0,) * 4, 3))
    _lockstep(cycles)


def test_out_of_range_dac_width_is_ignored_and_flagged():
    dut = K3702()
    reg = K3702_MAP["DAC_BITS"]

    async def bench(ctx):
        await write_reg(ctx, dut.bus, reg, 10)
        for bad in (0, 7, 17, 255):
            await bus_write(ctx, dut.bus, reg.addr, bad)
            await ctx.tick()
            assert await read_reg(ctx, dut.bus, reg) == 10
            assert STATUS.field("bad_config").decode(await read_reg(ctx, dut.bus, STATUS))
            assert ctx.get(dut.dac) == 1 << 9
            await bus_write(ctx, dut.bus, CMD.addr, CMD.encode(clear=1))
            await ctx.tick()
            assert not STATUS.field("bad_config").decode(await read_reg(ctx, dut.bus, STATUS))
    simulate(dut, bench)
    with pytest.raises(ValueError, match=r"register DAC_BITS: 17 is outside 8\.\.16"):
        reg.to_bytes(17)


def test_settings_read_back():
    dut = K3702()

    async def bench(ctx):
        for name, value in (("POSITION_ZONE", 0x123456), ("ALARM_ZONE", 0xABCDEF),
                            ("DAC_BITS", 16)):
            reg = K3702_MAP[name]
            assert await read_reg(ctx, dut.bus, reg) == reg.init
            await write_reg(ctx, dut.bus, reg, value)
            assert await read_reg(ctx, dut.bus, reg) == value

    simulate(dut, bench)


# -- host reads -------------------------------------------------------------------------------

@pytest.mark.parametrize(("start", "inputs"), [
    (0x00FFF8, (1, 0, 0, 0)),   # counting up through 0x00FFFF -> 0x010000
    (0x010008, (0, 0, 1, 0)),   # counting down through 0x010000 -> 0x00FFFF
    (-8, (1, 0, 0, 0)),         # through -1 -> 0: every byte changes
    (MAX - 8, (0, 0, 0, 1)),    # through the wrap 0x7FFFFF -> 0x800000
])
def test_byte_by_byte_read_of_running_error_counter_is_never_torn(start, inputs):
    dut = K3702()
    reg = K3702_MAP["ERROR"]

    async def bench(ctx):
        await write_reg(ctx, dut.bus, reg, start)
        await ctx.tick()
        for name, value in zip(INPUTS, inputs, strict=True):
            ctx.set(getattr(dut, name), value)
        for _ in range(6):
            # Byte 0 read in cycle t snapshots the value the counter shows in cycle t + 1.
            held = []
            data = []
            for op in read_ops(reg):
                drive_bus(ctx, dut.bus, op)
                await ctx.tick()
                held.append(ctx.get(dut.error))
                data.append(ctx.get(dut.bus.r_data))
            drive_bus(ctx, dut.bus, None)
            value = reg.from_bytes(data)
            assert value == held[0], (value, held)
            assert len(set(held)) == reg.nbytes  # the counter moved during the read

    simulate(dut, bench)


def test_register_map_has_the_documented_layout():
    regs = {r.name: r for r in K3702_MAP}
    assert K3702_MAP.version == 1  # CORRECT took a free address: no new version
    assert (regs["CORRECT"].addr, regs["CORRECT"].width, regs["CORRECT"].signed) == (0x0F, 8,
                                                                                     True)
    assert (regs["COMMAND"].width, regs["COMMAND"].signed) == (24, True)
    assert (regs["ERROR"].width, regs["ERROR"].signed) == (24, True)
    assert regs["DAC_BITS"].valid == (8, 16)
    assert {f.name for f in CMD.fields} >= {"clear_command", "clear_error", "ack"}
    assert all(r.doc for r in K3702_MAP)
    assert K3702_MAP.size <= 1 << K3702_MAP.addr_width
    assert "Valid 8..16; other values are ignored." in K3702_MAP.markdown()


def test_verilog_export_keeps_the_counters_on_the_falling_edge():
    text = verilog.convert(K3702(), name="k3702", emit_src=False)
    assert "negedge clk" in text  # a local domain left undriven would export as negedge 1'h0
    assert "negedge 1'h0" not in text
