# amaranth: UnusedElaboratable=no
"""The bridge resynchronises: a cut frame, a lost, extra or corrupted byte or garbage on the line
never becomes a bus write the host did not send whole, on the reference model (thousands of
fuzzed streams) and on the gateware (fewer, bit by bit in Amaranth's simulator, against the
model byte for byte)."""

from collections import Counter

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from k37.hdl.bridge.model import BridgeModel
from k37.hdl.bridge.protocol import COMMANDS, END, OK, Op, encode, stuff, unstuff
from tests.hdl.bridge.test_bridge import (
    IDENTITY,
    Board,
    Host,
    Target,
    TargetModel,
    _frames,
    _item_bytes,
)
from tests.testbench import simulate


def _numbered(items: list[tuple]) -> list[tuple]:
    """``items`` with the k-th WRITE writing k (its address kept), so that every write a stream
    holds is told apart from the others."""
    out, k = [], 0
    for item in items:
        if item[0] != "garbage" and item[1] is Op.WRITE:
            item = (item[0], Op.WRITE, (item[2][0], k % 256), *item[3:])
            k += 1
        out.append(item)
    return out


def _sent_whole(items: list[tuple]) -> Counter:
    """The writes the host sent whole: its frames, and a frame cut short whose missing bytes
    are the very bytes that follow it on the line (a cut that lost only the END, then garbage
    that starts with END: the line carries the whole frame, which no bridge can tell apart)."""
    line = [byte for item in items for byte in _item_bytes(item)]
    whole: Counter = Counter()
    at = 0
    for item in items:
        if item[0] != "garbage" and item[1] is Op.WRITE:
            frame = list(encode(Op.WRITE, *item[2], seq=item[3]))
            if item[0] == "frame" or (item[0] == "cut" and line[at:at + len(frame)] == frame):
                whole[item[2]] += 1
        at += len(_item_bytes(item))
    return whole


def _unsent(done: list[tuple[int, int]], items: list[tuple]) -> Counter:
    return Counter(done) - _sent_whole(items)


_STREAMS = st.lists(_frames(), min_size=1, max_size=20).map(_numbered)


def _model_writes(items: list[tuple]) -> list[tuple[int, int]]:
    model = BridgeModel(TargetModel(), IDENTITY)
    for item in items:
        for byte in _item_bytes(item):
            model.receive(byte)
    return model.target.writes


@settings(max_examples=500, deadline=None)
@given(_STREAMS)
# a frame that lost only its END, then garbage that starts with END: the whole frame
@example(_numbered([("cut", Op.WRITE, (0, 0), 0, 5, False), ("garbage", [END])]))
def test_a_fuzzed_stream_writes_only_what_the_host_sent_whole(items):
    assert not _unsent(_model_writes(items), items)


@pytest.mark.slow
@settings(max_examples=10_000, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(_STREAMS)
def test_ten_thousand_fuzzed_streams_write_only_what_the_host_sent_whole(items):
    assert not _unsent(_model_writes(items), items)


_EXAMPLES = [(Op.WRITE, (3, 0xC0)), (Op.WRITE, (0xDB, 0x57)), (Op.READ, (3,)), (Op.IDLE, (7,)),
             (Op.WAIT, (0xC0DB,)), (Op.IDENT, ()), (Op.STATUS, ()), (Op.CYCLE, ())]
assert {op for op, _ in _EXAMPLES} == set(COMMANDS)


@pytest.mark.parametrize(("op", "args"), _EXAMPLES)
def test_a_half_frame_then_any_command_writes_only_that_command_s_write(op, args):
    for cut_op, cut_args in _EXAMPLES:
        frame = encode(cut_op, *cut_args, seq=1)
        for cut in range(1, len(frame)):
            model = BridgeModel(TargetModel(), IDENTITY)
            replies = _feed(model, frame[:cut] + encode(op, *args, seq=2))
            assert model.target.writes == ([args] if op is Op.WRITE else [])
            # the cut frame is dropped unanswered: one reply, the command's
            assert replies.count(END) == 1
            assert unstuff(replies[1:-1])[:2] == bytes([OK, 2])


def _feed(model: BridgeModel, data: bytes) -> bytes:
    return b"".join(model.receive(byte) for byte in data)


def test_a_repeated_frame_is_answered_again_and_not_executed_until_ident():
    model = BridgeModel(TargetModel(), IDENTITY)
    write = encode(Op.WRITE, 4, 9, seq=6)
    assert _feed(model, write) == stuff(bytes([OK, 6]))
    assert _feed(model, write) == stuff(bytes([OK, 6]))  # a retry
    assert model.target.writes == [(4, 9)]
    assert _feed(model, encode(Op.IDENT, seq=6)) == stuff(bytes([OK, 6])
                                                                + IDENTITY.encode())
    _feed(model, write)  # a new host's frame after its IDENT
    assert model.target.writes == [(4, 9), (4, 9)]


def _gateware(cycles_per_bit: int, items: list[tuple]) -> tuple[list, list, list]:
    """The replies of the gateware and the model to ``items``, and the gateware's bus writes."""
    board = Board(cycles_per_bit, Target())
    model = BridgeModel(TargetModel(), IDENTITY)
    host = Host(board)
    pairs, writes = [], []

    async def watch(ctx):
        bus = board.bridge.bus
        async for _, _, w_stb, addr, data in ctx.tick().sample(bus.w_stb, bus.addr, bus.w_data):
            if w_stb:
                writes.append((addr, data))

    async def bench(ctx):
        host.ctx = ctx
        await host.tick(3)
        for item in items:
            pairs.append(await host.exchange(_item_bytes(item), model))

    simulate(board, bench, background=(host.listen, watch))
    return pairs, writes, model.target.writes


def _check_gateware(cycles_per_bit: int, items: list[tuple]) -> None:
    pairs, writes, model_writes = _gateware(cycles_per_bit, items)
    for got, expected in pairs:
        assert got == expected
    assert writes == model_writes
    assert not _unsent(writes, items)


@settings(max_examples=4, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from([4, 5, 8]), st.lists(_frames(), min_size=1, max_size=6).map(_numbered))
def test_the_gateware_resynchronises_as_the_model_on_fuzzed_streams(cycles_per_bit, items):
    _check_gateware(cycles_per_bit, items)


@pytest.mark.slow
@settings(max_examples=12, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.large_base_example])
@given(st.lists(_frames(), min_size=20, max_size=40).map(_numbered))
def test_many_fuzzed_streams_on_the_gateware_write_only_what_was_sent_whole(items):
    _check_gateware(4, items)
