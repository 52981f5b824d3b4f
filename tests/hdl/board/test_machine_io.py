"""The board's watchdog and machine I/O: the gateware against its model cycle by cycle, and what
the model does with a silent host, an E-stop, a limit and a clear."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from k37.hdl.board.machine_io import MachineIO
from k37.hdl.board.map import BOARD_MAP, DECEL_CTRL_PORT, board_port
from k37.hdl.board.model.machine_io import BusCycle, MachineIOModel, MachineIOOutputs
from tests.testbench import simulate

IDLE = BusCycle()


def _write(name: str, value: int) -> list[BusCycle]:
    reg = BOARD_MAP[name]
    return [BusCycle(board_port(name, k), value >> 8 * k & 0xFF, w_stb=True)
            for k in range(reg.nbytes)]


def _read(name: str) -> list[BusCycle]:
    return [BusCycle(board_port(name, k), r_stb=True) for k in range(BOARD_MAP[name].nbytes)]


#: A cycle's inputs: the host's bus, the feed (a whole frame), E-stop, limits, D/A words and
#: the chipset's read data.
Cycle = tuple[BusCycle, bool, bool, tuple[bool, ...], tuple[int, ...], int]


def _run_gateware(axes: int, cycles: list[Cycle]) -> list[MachineIOOutputs]:
    dut = MachineIO(axes)
    names = dut.axes
    seen: list[MachineIOOutputs] = []

    async def bench(ctx):
        for host, feed, estop_n, limit_n, dac, chip_r_data in cycles:
            ctx.set(dut.feed, feed)
            ctx.set(dut.host.addr, host.addr)
            ctx.set(dut.host.w_data, host.w_data)
            ctx.set(dut.host.w_stb, host.w_stb)
            ctx.set(dut.host.r_stb, host.r_stb)
            ctx.set(dut.estop_n, estop_n)
            for axis, level, word in zip(names, limit_n, dac, strict=True):
                ctx.set(getattr(dut, f"{axis}_limit_n"), level)
                ctx.set(getattr(dut, f"{axis}_dac_in"), word)
            ctx.set(dut.chip.r_data, chip_r_data)
            chip = BusCycle(ctx.get(dut.chip.addr), ctx.get(dut.chip.w_data),
                            bool(ctx.get(dut.chip.w_stb)), bool(ctx.get(dut.chip.r_stb)))
            seen.append(MachineIOOutputs(
                chip, tuple(ctx.get(getattr(dut, f"{axis}_dac")) for axis in names),
                bool(ctx.get(dut.drive_enable)), ctx.get(dut.host.r_data)))
            await ctx.tick()

    simulate(dut, bench)
    return seen


def _run_model(axes: int, cycles: list[Cycle]) -> list[MachineIOOutputs]:
    model = MachineIOModel(axes)
    return [model.step(*cycle) for cycle in cycles]


def _normalised(outputs: list[MachineIOOutputs]) -> list[tuple]:
    # the chip's address and data matter only under a strobe
    return [(o.chip if o.chip.w_stb or o.chip.r_stb else None, o.dac, o.drive_enable, o.r_data)
            for o in outputs]


def _check(axes: int, cycles: list[Cycle]) -> list[MachineIOOutputs]:
    model = _run_model(axes, cycles)
    assert _normalised(_run_gateware(axes, cycles)) == _normalised(model)
    return model


def _fed(host: BusCycle) -> bool:
    """A frame for each bus access (the bridge's WRITE and READ)."""
    return host.w_stb or host.r_stb


def _quiet(host: list[BusCycle], axes: int = 2) -> list[Cycle]:
    return [(h, _fed(h), True, (True,) * axes, (0x1234,) * axes, 0x5A) for h in host]


def test_a_silent_host_trips_the_watchdog_which_zeroes_the_dac_and_drops_drive_enable():
    host = [*_write("DAC_ZERO", 0x8000), *_write("WATCHDOG", 20), *[IDLE] * 30,
            *_read("STATUS"), IDLE]
    out = _check(2, _quiet(host))
    last_frame = 4  # the WATCHDOG write's committing byte
    trip = last_frame + 20 + 2  # the first cycle the drives are stopped
    assert all(o.drive_enable and o.dac == (0x1234, 0x1234) for o in out[:trip])
    assert all(not o.drive_enable and o.dac == (0x8000, 0x8000) for o in out[trip:])
    hold = out[trip]  # the board's own write: DECEL CTRL hold, no host access pending
    assert hold.chip == BusCycle(DECEL_CTRL_PORT, 1, w_stb=True)
    status = BOARD_MAP["STATUS"].decode(out[-1].r_data)
    assert status["watchdog"] == 1 and status["drive_enable"] == 0 and status["held"] == 1


def test_a_host_that_keeps_sending_frames_keeps_the_watchdog_from_tripping():
    host = [*_write("WATCHDOG", 10)]
    for _ in range(12):
        host += [*[IDLE] * 8, *_read("STATUS")]
    out = _check(2, _quiet(host))
    assert all(o.drive_enable for o in out)
    assert not any(o.chip.w_stb and o.chip.addr == DECEL_CTRL_PORT for o in out)


def test_frames_without_a_bus_access_feed_the_watchdog_too():
    """IDLE and WAIT frames: the bridge takes a whole frame, the bus stays idle."""
    cycles = _quiet(_write("WATCHDOG", 10))
    cycles += [(IDLE, k % 8 == 0, True, (True, True), (5, 5), 0) for k in range(100)]
    out = _check(2, cycles)
    assert all(o.drive_enable for o in out)


def test_the_estop_latches_until_cleared_once_released():
    cycles = [(IDLE, False, False, (True, True), (7, 7), 0)] * 3
    cycles += [(c, _fed(c), True, (True, True), (7, 7), 0) for c in
               [IDLE, *_read("STATUS"), IDLE, *_write("CLEAR", 0x02), IDLE, IDLE,
                *_read("STATUS"), IDLE]]
    out = _check(2, cycles)
    assert out[0].drive_enable and not out[1].drive_enable  # latched at the first edge
    status = BOARD_MAP["STATUS"].decode(out[5].r_data)
    assert status["estop"] == 1 and status["estop_in"] == 0 and status["drive_enable"] == 0
    assert out[-1].drive_enable
    assert BOARD_MAP["STATUS"].decode(out[-1].r_data)["estop"] == 0


def test_a_limit_holds_the_feed_but_keeps_the_drives_on():
    cycles = [(IDLE, False, True, (True, False), (9, 9), 0)] * 4
    out = _check(2, cycles)
    assert all(o.drive_enable and o.dac == (9, 9) for o in out)
    assert out[1].chip == BusCycle(DECEL_CTRL_PORT, 1, w_stb=True)


def test_while_held_a_host_write_to_decel_ctrl_keeps_the_hold_bit():
    cycles = [(IDLE, False, True, (False, True), (0, 0), 0)] * 2
    cycles += _quiet([BusCycle(DECEL_CTRL_PORT, 0, w_stb=True), IDLE])
    out = _check(2, cycles)
    assert out[2].chip == BusCycle(DECEL_CTRL_PORT, 1, w_stb=True)


def test_board_ports_never_reach_the_chipset():
    out = _check(3, [(c, _fed(c), True, (True,) * 3, (0,) * 3, 0xEE) for c in
                     [*_write("WATCHDOG", 0x123456), *_read("WATCHDOG"), IDLE]])
    assert not any(o.chip.w_stb or o.chip.r_stb for o in out)
    assert [o.r_data for o in out[4:]] == [0x56, 0x34, 0x12]


_BUS = st.one_of(
    st.just(IDLE), st.just(IDLE), st.just(IDLE),
    st.builds(BusCycle, st.integers(0xD0, 0xD7), st.integers(0, 255), st.just(True)),
    st.builds(BusCycle, st.integers(0xD0, 0xD7), st.just(0), st.just(False), st.just(True)),
    st.builds(BusCycle, st.sampled_from([0x00, 0xC6, 0xC7, 0xD8, 0xE0]), st.integers(0, 255),
              st.booleans()).map(lambda c: c if c.w_stb else BusCycle(c.addr, r_stb=True)),
)


_INPUT = st.integers(0, 9).map(lambda n: n != 0)  # an input mostly inactive (high)


@settings(max_examples=25, deadline=None)
@given(st.integers(2, 3).flatmap(lambda axes: st.tuples(st.just(axes), st.lists(st.tuples(
    _BUS, st.booleans(), _INPUT, st.lists(_INPUT, min_size=axes, max_size=axes).map(tuple),
    st.lists(st.integers(0, 0xFFFF), min_size=axes, max_size=axes).map(tuple),
    st.integers(0, 255)), min_size=1, max_size=120))))
def test_machine_io_matches_its_model_cycle_by_cycle(case):
    axes, cycles = case
    _check(axes, cycles)


@pytest.mark.parametrize("silent", [0, 5])
def test_cycles_to_trip_counts_down_to_the_tripping_edge(silent):
    model = MachineIOModel(2)
    for cycle in _write("WATCHDOG", 8):
        model.step(cycle)
    for _ in range(silent):
        model.step(IDLE)
    left = model.cycles_to_trip()
    assert left is not None
    for _ in range(left):
        assert not model.trips()
        model.step(IDLE)
    assert model.trips()
