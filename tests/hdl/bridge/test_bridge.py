# amaranth: UnusedElaboratable=no
"""The host bridge: its protocol, its reference model, and the gateware against the model at the
bit level (random frames, garbage and framing errors included), with the real chipset behind it
for an end-to-end check."""

import pytest
from amaranth.hdl import Array, Module, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out, connect
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from k37.hdl.bridge.chip import UartBridge
from k37.hdl.bridge.model import FRAMING, BridgeModel, LineTimed
from k37.hdl.bridge.protocol import (
    COMMANDS,
    END,
    ERROR,
    ESC,
    ESC_END,
    ESC_ESC,
    ESC_START,
    OK,
    RX_FIFO_DEPTH,
    START,
    Error,
    Identity,
    Op,
    check_cycles_per_bit,
    command_start,
    crc8,
    encode,
    map_fingerprint,
    stuff,
    unstuff,
)
from k37.hdl.bus.hostbus import HostBus
from k37.hdl.chipset.chip import Chipset
from k37.hdl.chipset.map import chip_selects, port
from tests.testbench import simulate

IDENTITY = Identity(axes=2, fingerprint=0x12345678)
#: Addresses the tests write and read.
ADDRESSES = st.sampled_from([0, 1, 7, 14, 15, 0x3F])
#: The test target's registers: 16 bytes; writing TIMER starts a countdown that raises
#: irq_alarm when it ends, bit 0 of LEVEL is irq_interp.
TIMER, LEVEL = 14, 15


class Target(wiring.Component):
    """A small bus target with interrupts, for the bridge's tests."""

    bus: In(HostBus(8))
    irq_interp: Out(1)
    irq_alarm: Out(1)

    def elaborate(self, platform) -> Module:
        m = Module()
        regs = Array(Signal(8, name=f"reg{k}") for k in range(16))
        timer, fired = Signal(8), Signal()
        with m.If(timer != 0):
            m.d.sync += timer.eq(timer - 1)
            with m.If(timer == 1):
                m.d.sync += fired.eq(1)
        with m.If(self.bus.w_stb):
            m.d.sync += regs[self.bus.addr[:4]].eq(self.bus.w_data)
            with m.If(self.bus.addr[:4] == TIMER):
                m.d.sync += [timer.eq(self.bus.w_data), fired.eq(0)]
        with m.If(self.bus.r_stb):
            m.d.sync += self.bus.r_data.eq(regs[self.bus.addr[:4]])
        m.d.comb += [self.irq_interp.eq(regs[LEVEL][0]), self.irq_alarm.eq(fired)]
        return m


class TargetModel:
    """:class:`Target`, cycle by cycle (a :class:`k37.hdl.bridge.model.Target`)."""

    def __init__(self):
        self.cycle = 0
        self.regs = [0] * 16
        self.timer = 0
        self.fired = False
        #: The writes done, as (address, data).
        self.writes: list[tuple[int, int]] = []

    def _tick(self, write: tuple[int, int] | None = None) -> None:
        if self.timer:
            self.fired |= self.timer == 1
            self.timer -= 1
        if write is not None:
            address, data = write[0] & 15, write[1]
            self.regs[address] = data
            if address == TIMER:
                self.timer, self.fired = data, False
        self.cycle += 1

    def idle(self, cycles: int) -> None:
        for _ in range(cycles):
            self._tick()

    def write(self, address: int, data: int) -> None:
        self.writes.append((address, data))
        self._tick((address, data))

    def read(self, address: int) -> int:
        value = self.regs[address & 15]
        self._tick()
        return value

    def interrupts(self) -> tuple[bool, bool]:
        return bool(self.regs[LEVEL] & 1), self.fired

    def wait_interrupt(self, max_cycles: int) -> int:
        n = 0
        while n < max_cycles:
            self._tick()
            n += 1
            if any(self.interrupts()):
                break
        return n


class Board(wiring.Component):
    """The bridge with a target behind it: ``target`` is :class:`Target` or the chipset."""

    rx: In(1, init=1)
    tx: Out(1, init=1)

    def __init__(self, cycles_per_bit: int, target: wiring.Component):
        super().__init__()
        self.bridge = UartBridge(cycles_per_bit, IDENTITY)
        self.target = target

    def elaborate(self, platform) -> Module:
        m = Module()
        m.submodules.bridge = bridge = self.bridge
        m.submodules.target = target = self.target
        connect(m, bridge.bus, target.bus)
        m.d.comb += [bridge.rx.eq(self.rx), self.tx.eq(bridge.tx),
                     bridge.irq_interp.eq(target.irq_interp),
                     bridge.irq_alarm.eq(target.irq_alarm)]
        return m


class Host:
    """The bench's side of the serial line: sends frames bit by bit, decodes the replies, counts
    cycles (the bridge's cycle counter counts the same)."""

    def __init__(self, board: Board):
        self.ctx = None
        self.board = board
        self.bit = board.bridge.cycles_per_bit
        self.cycle = 0
        #: The cycle the last byte sent began in.
        self.last_byte = 0
        #: Bytes received and not yet taken.
        self.received: list[int] = []
        #: The last cycle of the last stop bit received.
        self.stop_end = 0

    async def tick(self, n: int = 1) -> None:
        for _ in range(n):
            await self.ctx.tick()
            self.cycle += 1

    async def send(self, byte: int) -> None:
        """One 8N1 frame; ``FRAMING``: a frame of 0x55 with its stop bit low."""
        self.last_byte = self.cycle
        data = 0x55 if byte == FRAMING else byte
        bits = [0, *((data >> k) & 1 for k in range(8)), 0 if byte == FRAMING else 1]
        for level in bits:
            self.ctx.set(self.board.rx, level)
            await self.tick(self.bit)
        self.ctx.set(self.board.rx, 1)
        if byte == FRAMING:
            await self.tick(self.bit)

    async def listen(self, ctx) -> None:
        """Decode ``tx`` for ever into :attr:`received` (a background bench), noting the cycle
        each byte's stop bit ends in (:attr:`stop_end`)."""
        cycle = 0
        while True:
            while ctx.get(self.board.tx):
                await ctx.tick()
                cycle += 1
            self.stop_end = cycle + 10 * self.bit - 1
            for _ in range(self.bit // 2):
                await ctx.tick()
                cycle += 1
            assert ctx.get(self.board.tx) == 0, "start bit too short"
            byte = 0
            for k in range(8):
                for _ in range(self.bit):
                    await ctx.tick()
                    cycle += 1
                byte |= ctx.get(self.board.tx) << k
            for _ in range(self.bit):
                await ctx.tick()
                cycle += 1
            assert ctx.get(self.board.tx) == 1, "stop bit low"
            self.received.append(byte)

    async def receive(self, n: int, timeout: int) -> bytes:
        """The next ``n`` bytes from ``tx``, each within ``timeout`` cycles."""
        waited = 0
        while len(self.received) < n:
            await self.tick()
            waited += 1
            assert waited < timeout * n, f"no reply after {bytes(self.received)!r}"
        out, self.received[:] = bytes(self.received[:n]), self.received[n:]
        return out

    async def exchange(self, sent: list[int], model: BridgeModel) -> tuple[bytes, bytes]:
        """Send ``sent``; the gateware's reply and the model's."""
        expected = b""
        for byte in sent:
            await self.send(byte)
            expected += model.receive(byte, command_start(self.last_byte, self.bit))
        got = await self.receive(len(expected), timeout=400 + 40 * self.bit)
        return got, expected


def _item_bytes(item: tuple) -> list[int]:
    """The bytes a host puts on the line for ``item``: a frame, garbage, a frame cut short
    (and maybe ended by a framing error), or a frame with one bit flipped."""
    kind, *rest = item
    if kind == "garbage":
        return list(rest[0])
    op, args, seq, *how = rest
    frame = list(encode(op, *args, seq=seq))
    if kind == "frame":
        return frame
    if kind == "cut":
        cut, framing = how
        return frame[:1 + cut % (len(frame) - 1)] + ([FRAMING] if framing else [])
    bit = how[0] % (8 * (len(frame) - 2))  # a flipped bit between START and END
    frame[1 + bit // 8] ^= 1 << bit % 8
    return frame


def _commands(address: st.SearchStrategy = ADDRESSES) -> st.SearchStrategy:
    small = st.integers(0, 40)
    return st.one_of(
        st.tuples(st.just(Op.WRITE), st.tuples(address, st.integers(0, 255))),
        st.tuples(st.just(Op.WRITE), st.tuples(st.just(TIMER), st.integers(1, 30))),
        st.tuples(st.just(Op.READ), st.tuples(address)),
        st.tuples(st.just(Op.IDLE), st.tuples(small)),
        st.tuples(st.just(Op.WAIT), st.tuples(small)),
        st.tuples(st.sampled_from([Op.IDENT, Op.STATUS, Op.CYCLE]), st.just(())))


def _numbered_commands(commands: st.SearchStrategy | None = None) -> st.SearchStrategy:
    """Commands with a sequence byte among few values, so that repeats are common."""
    return st.tuples(commands or _commands(), st.integers(0, 3)).map(
        lambda t: (t[0][0], t[0][1], t[1]))


def _whole_frames() -> st.SearchStrategy:
    return _numbered_commands().map(lambda c: ("frame", *c))


def _frames(commands: st.SearchStrategy | None = None) -> st.SearchStrategy:
    """Items of a host's byte stream (:func:`_item_bytes`)."""
    command = _numbered_commands(commands)
    return st.one_of(
        command.map(lambda c: ("frame", *c)),
        st.lists(st.integers(0, 255), min_size=1, max_size=4).map(lambda b: ("garbage", b)),
        st.tuples(command, st.integers(0, 20), st.booleans()).map(
            lambda t: ("cut", *t[0], t[1], t[2])),
        st.tuples(command, st.integers(0, 200)).map(lambda t: ("flip", *t[0], t[1])))


def _run(cycles_per_bit: int, items: list[tuple]) -> list[tuple[bytes, bytes]]:
    board = Board(cycles_per_bit, Target())
    model = BridgeModel(TargetModel(), IDENTITY)
    pairs = []
    host = Host(board)

    async def bench(ctx):
        host.ctx = ctx
        await host.tick(3)
        for item in items:
            pairs.append(await host.exchange(_item_bytes(item), model))

    simulate(board, bench, background=(host.listen,))
    return pairs


@settings(max_examples=5, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from([4, 6, 8]), st.integers(0, 40),
       st.lists(_whole_frames(), min_size=1, max_size=5))
def test_the_line_timed_model_knows_when_a_stop_and_wait_host_s_commands_run(
        cycles_per_bit, turnaround, items):
    board = Board(cycles_per_bit, Target())
    model = LineTimed(BridgeModel(TargetModel(), IDENTITY), cycles_per_bit, turnaround)
    host = Host(board)
    pairs = []

    async def bench(ctx):
        host.ctx = ctx
        for item in items:
            sent = _item_bytes(item)
            for byte in sent:
                await host.send(byte)
            expected = b"".join(model.receive(byte) for byte in sent)
            got = await host.receive(len(expected), timeout=400 + 40 * host.bit)
            pairs.append((got, expected))
            next_frame = host.stop_end + 1 + turnaround
            assert host.cycle <= next_frame
            await host.tick(next_frame - host.cycle)

    simulate(board, bench, background=(host.listen,))
    for got, expected in pairs:
        assert got == expected


@pytest.mark.parametrize("cycles_per_bit", [4, 7, 8, 16])
def test_a_timer_interrupt_is_waited_for_to_the_cycle(cycles_per_bit):
    items = [("frame", Op.CYCLE, (), 0), ("frame", Op.WRITE, (TIMER, 25), 1),
             ("frame", Op.WAIT, (1000,), 2), ("frame", Op.STATUS, (), 3),
             ("frame", Op.CYCLE, (), 4)]
    pairs = _run(cycles_per_bit, items)
    for got, expected in pairs:
        assert got == expected
    # the write is in cycle E, the countdown ends 25 cycles later: the wait (which starts
    # after the write's reply) sees it before its max, and STATUS shows it
    waited = int.from_bytes(unstuff(pairs[2][0][1:-1])[2:], "little")
    assert 0 < waited < 25
    assert pairs[3][0] == stuff(bytes([OK, 3, 0b10]))


def test_a_write_starts_in_the_documented_cycle():
    board = Board(8, Target())
    seen = []
    host = Host(board)

    async def bench(ctx):
        host.ctx = ctx
        await host.tick(2)
        for byte in encode(Op.WRITE, 3, 0xA5):
            await host.send(byte)
        start = command_start(host.last_byte, host.bit)
        while not ctx.get(board.bridge.bus.w_stb):
            await host.tick()
        seen.append((host.cycle, start, ctx.get(board.bridge.bus.addr),
                     ctx.get(board.bridge.bus.w_data)))
        await host.tick()
        assert not ctx.get(board.bridge.bus.w_stb)  # one cycle only

    simulate(board, bench, background=(host.listen,))
    (cycle, start, address, data), = seen
    assert (cycle, address, data) == (start, 3, 0xA5)


def test_errors_have_their_replies_and_the_next_frame_works():
    items = [("garbage", [0x00, END]), ("garbage", [START, 0x57, 0x01, ESC, 0x01, END]),
             ("cut", Op.WRITE, (1, 2), 1, 2, True), ("garbage", [END]),
             ("garbage", [*encode(Op.IDLE, 3, seq=0)[:-2], END]),
             ("garbage", [*stuff(bytes([Op.WRITE, 5, 1]))]),
             ("garbage", [*stuff(bytes([0x99, 0]))]),
             ("cut", Op.WRITE, (1, 2), 1, 5, False),
             ("frame", Op.IDENT, (), 7)]
    pairs = _run(8, items)
    for got, expected in pairs:
        assert got == expected
    # bytes outside a frame are dropped, and so is a frame cut short, both unanswered
    assert [got for got, _ in pairs] == [
        b"", stuff(bytes([ERROR, Error.CHECK])), b"", stuff(bytes([ERROR, Error.FRAMING])),
        stuff(bytes([ERROR, Error.CHECK])), stuff(bytes([ERROR, Error.LENGTH])),
        stuff(bytes([ERROR, Error.OPCODE])), b"", stuff(bytes([OK, 7]) + IDENTITY.encode())]


def test_a_half_frame_then_any_command_writes_nothing_on_the_gateware():
    """Every command cut after each of its bytes but its END, then a whole STATUS: the cut
    frames are dropped, the STATUS gets its reply, and no bus write happens."""
    items = []
    for op, args in ((Op.WRITE, (TIMER, 9)), (Op.READ, (3,)), (Op.IDLE, (5,)), (Op.IDENT, ())):
        frame = encode(op, *args, seq=1)
        items += [("garbage", list(frame[:cut])) for cut in range(1, len(frame))]
    items.append(("frame", Op.STATUS, (), 2))
    board = Board(4, Target())
    writes = []
    host = Host(board)

    async def watch(ctx):
        async for _, _, w_stb in ctx.tick().sample(board.bridge.bus.w_stb):
            if w_stb:
                writes.append(host.cycle)

    async def bench(ctx):
        host.ctx = ctx
        await host.tick(3)
        model = BridgeModel(TargetModel(), IDENTITY)
        for item in items:
            got, expected = await host.exchange(_item_bytes(item), model)
            assert got == expected
        assert model.target.writes == []

    simulate(board, bench, background=(host.listen, watch))
    assert writes == []


def test_a_chipset_register_written_through_the_bridge_reads_back():
    board = Board(8, Chipset())
    model = BridgeModel(TargetModel(), IDENTITY)
    value = 0x012345
    replies = []
    host = Host(board)

    async def bench(ctx):
        host.ctx = ctx
        await host.tick(2)
        for k in range(3):
            replies.append(await host.exchange(
                list(encode(Op.WRITE, port("K3702_X", "POSITION_ZONE", k),
                            (value >> 8 * k) & 0xFF, seq=k)), model))
        for k in range(3):
            replies.append(await host.exchange(
                list(encode(Op.READ, port("K3702_X", "POSITION_ZONE", k), seq=3 + k)), model))

    simulate(board, bench, background=(host.listen,))
    assert [got for got, _ in replies[:3]] == [stuff(bytes([OK, k])) for k in range(3)]
    read = [unstuff(got[1:-1]) for got, _ in replies[3:]]
    assert all(r is not None and r[0] == OK for r in read)
    assert int.from_bytes(bytes(r[2] for r in read), "little") == value


@pytest.mark.parametrize("bad", [3, 0, 1 << 16 | 1, True, 8.0, "8"])
def test_a_bit_time_out_of_range_is_refused(bad):
    with pytest.raises(ValueError, match=r"cycles per UART bit must be an integer in 4\.\.65536"):
        check_cycles_per_bit(bad)
    with pytest.raises(ValueError, match="cycles per UART bit"):
        UartBridge(bad, IDENTITY)


def test_frames_are_checked_and_the_fingerprint_tells_chipsets_apart():
    assert encode(Op.WRITE, 0x20, 0x7F, seq=3) == bytes(
        [START, 0x57, 3, 0x20, 0x7F, crc8(b"W\x03\x20\x7f"), END])
    assert encode(Op.WAIT, 1000) == stuff(b"Q\x00\xe8\x03\x00\x00")
    special = bytes([START, END, ESC, 1])
    assert stuff(special) == bytes([START, ESC, ESC_START, ESC, ESC_END, ESC, ESC_ESC, 1,
                                    crc8(special), END])
    assert unstuff(stuff(special)[1:-1]) == special
    assert crc8(b"123456789") == 0xFB  # CRC-8 with polynomial 0x07 preset to 0xFF
    # the longest frame on the line, START, every byte escaped and END, fits the receive FIFO
    assert max(2 + 2 * c.frame_bytes for c in COMMANDS.values()) == RX_FIFO_DEPTH
    with pytest.raises(ValueError, match="WRITE takes 2 arguments, not 1"):
        encode(Op.WRITE, 1)
    with pytest.raises(ValueError, match=r"IDLE cycles must be in 0\.\.4294967295"):
        encode(Op.IDLE, 1 << 32)
    two, three = (map_fingerprint((name, cs, regmap) for name, (cs, regmap)
                                  in chip_selects(axes).items()) for axes in (2, 3))
    assert two != three
    assert Identity.decode(Identity(3, three).encode()) == Identity(3, three)
