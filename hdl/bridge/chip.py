"""The host bridge in gateware: the protocol of :mod:`k37.hdl.bridge.protocol` on a UART, driving
the chipset's 8-bit bus."""

from __future__ import annotations

import operator
from functools import reduce

from amaranth.hdl import Cat, Const, Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.fifo import SyncFIFOBuffered
from amaranth.lib.wiring import In, Out

from k37.hdl.bridge.protocol import (
    COMMANDS,
    COUNT_BITS,
    COUNTER_BITS,
    CRC_INIT,
    END,
    ERROR,
    ESC,
    ESCAPES,
    OK,
    REPLY_MAX,
    RX_FIFO_DEPTH,
    START,
    Error,
    Identity,
    Op,
    check_cycles_per_bit,
    crc8,
)
from k37.hdl.bridge.uart import UartRx, UartTx
from k37.hdl.bus.hostbus import HostBus

__all__ = ["UartBridge"]


class UartBridge(wiring.Component):
    """A UART to the chipset's host bus: a PC host in the 8085's place.

    Runs in the chipset's clock domain (``sync``, which may be clock-enabled): every timing
    below is in its cycles. Frames are unstuffed and checked byte by byte as they arrive (CRC,
    escapes, framing errors, length); a frame is executed only when its closing END finds it
    whole, and answered with its reply again, unexecuted, when its sequence byte is the last
    executed frame's (:mod:`k37.hdl.bridge.protocol`). A command starts in cycle E, three cycles
    after its closing END's stop bit is sampled (:func:`k37.hdl.bridge.protocol.command_start`);
    what it does in E and after is :data:`k37.hdl.bridge.protocol.COMMANDS`'s. The reply's first
    start bit is on ``tx`` two cycles after the cycle the command ends in (E for WRITE, IDENT,
    STATUS and CYCLE, E + 1 for READ, E + N for an IDLE of N, E + n for a WAIT that returned n,
    E - 1 for an error or a repeated reply), each next start bit one cycle after the stop bit
    before (:func:`k37.hdl.bridge.protocol.reply_end`).

    Parameters
    ----------
    cycles_per_bit : int
        The UART bit time in clock cycles, 4 to 65536 (8: 125 kBd at a 1 MHz chipset clock).
    identity : Identity
        What the IDENT command tells of the chipset behind the bridge.

    Members
    -------
    rx : In(1)
        Serial data from the host, 8N1, idle high; passes a two-stage synchroniser.
    tx : Out(1)
        Serial data to the host, 8N1, idle high; registered.
    bus : Out(HostBus(8))
        The chipset's host bus, driven as an 8085 would: ``w_stb`` high in a WRITE's cycle E,
        ``r_stb`` high in a READ's cycle E (``r_data`` taken in E + 1), both low otherwise.
    irq_interp : In(1)
        The K3701's data request (the 8085's RST 7.5), sampled every cycle.
    irq_alarm : In(1)
        The K3702s' alarm (RST 6.5), sampled every cycle.
    frame : Out(1)
        High in the cycle a whole frame's END is taken (a frame executed or answered again,
        not one answered with an error): the host is there (the board's watchdog,
        :class:`k37.hdl.board.machine_io.MachineIO`).
    """

    def __init__(self, cycles_per_bit: int, identity: Identity):
        self.cycles_per_bit = check_cycles_per_bit(cycles_per_bit)
        if not isinstance(identity, Identity):
            raise TypeError(f"identity must be an Identity, not {identity!r}")
        self.identity = identity
        super().__init__({"rx": In(1, init=1), "tx": Out(1, init=1), "bus": Out(HostBus(8)),
                          "irq_interp": In(1), "irq_alarm": In(1), "frame": Out(1)})

    def elaborate(self, platform) -> Module:
        m = Module()
        m.submodules.receiver = rx = UartRx(self.cycles_per_bit)
        m.submodules.transmitter = tx = UartTx(self.cycles_per_bit)
        m.submodules.fifo = fifo = SyncFIFOBuffered(width=9, depth=RX_FIFO_DEPTH)
        m.d.comb += [rx.rx.eq(self.rx), self.tx.eq(tx.tx),
                     fifo.w_data.eq(Cat(rx.data, rx.error)), fifo.w_en.eq(rx.valid | rx.error)]
        byte, framing = fifo.r_data[:8], fifo.r_data[8]

        cycle = Signal(COUNTER_BITS)
        m.d.sync += cycle.eq(cycle + 1)
        irq = Cat(self.irq_interp, self.irq_alarm)

        # the frame being received: its payload's bytes so far (saturating), their CRC, ...
        length = Signal(range(16))
        crc = Signal(8, init=CRC_INIT)
        opened, escaped, framing_seen, bad_escape = Signal(), Signal(), Signal(), Signal()
        op, seq = Signal(8), Signal(8)
        args = Signal(COUNT_BITS)
        # the last executed frame's sequence byte and reply (no reply after IDENT)
        last_seq, has_last = Signal(8), Signal()
        last = Signal(8 * REPLY_MAX)
        last_len = Signal(range(REPLY_MAX + 1))

        repeated = (op != Op.IDENT) & has_last & (seq == last_seq)

        count = Signal(COUNT_BITS)
        out = Signal(8 * REPLY_MAX)
        out_len = Signal(range(REPLY_MAX + 1))

        def answer(value, remember: bool) -> None:
            """Send the reply payload ``value`` (Cat order: the first byte first) next."""
            m.d.sync += [out.eq(value), out_len.eq(len(value) // 8)]
            if remember:
                m.d.sync += [last.eq(value), last_len.eq(len(value) // 8), last_seq.eq(seq),
                             has_last.eq(op != Op.IDENT)]
            m.next = "Reply"

        def ok(*results) -> None:
            answer(Cat(Const(OK, 8), seq, *results), remember=True)

        def error(code: Error) -> None:
            answer(Cat(Const(ERROR, 8), Const(code, 8)), remember=False)

        def take(data) -> None:
            m.d.sync += [crc.eq(_crc8_next(crc, data)), length.eq(length + (length != 15))]
            with m.Switch(length):
                with m.Case(0):
                    m.d.sync += op.eq(data)
                with m.Case(1):
                    m.d.sync += seq.eq(data)
                for k in range(COUNT_BITS // 8):
                    with m.Case(2 + k):
                        m.d.sync += args.word_select(k, 8).eq(data)

        restart = [length.eq(0), crc.eq(CRC_INIT), escaped.eq(0), framing_seen.eq(0),
                   bad_escape.eq(0)]
        with m.FSM():
            with m.State("Receive"):
                m.d.comb += fifo.r_en.eq(1)
                with m.If(fifo.r_rdy & (opened | (byte == START) & ~framing)):
                    with m.If(framing):
                        m.d.sync += framing_seen.eq(1)
                    with m.Elif(byte == START):  # drops a frame cut short
                        m.d.sync += [*restart, opened.eq(1)]
                    with m.Elif(byte == END):
                        m.d.sync += [*restart, opened.eq(0)]
                        with m.If(framing_seen):
                            error(Error.FRAMING)
                        with m.Elif(escaped | bad_escape | (crc != 0)):
                            error(Error.CHECK)
                        with m.Else():
                            with m.Switch(op):
                                for command in COMMANDS.values():
                                    with m.Case(command.op):
                                        with m.If(length != command.frame_bytes):
                                            error(Error.LENGTH)
                                        with m.Elif(repeated):
                                            m.d.comb += self.frame.eq(1)
                                            m.d.sync += [out.eq(last), out_len.eq(last_len)]
                                            m.next = "Reply"
                                        with m.Else():
                                            m.d.comb += self.frame.eq(1)
                                            m.next = "Execute"
                                with m.Default():
                                    error(Error.OPCODE)
                    with m.Elif(escaped):
                        m.d.sync += escaped.eq(0)
                        with m.Switch(byte):
                            for unescaped, code in ESCAPES.items():
                                with m.Case(code):
                                    take(Const(unescaped, 8))
                            with m.Default():
                                m.d.sync += bad_escape.eq(1)
                    with m.Elif(byte == ESC):
                        m.d.sync += escaped.eq(1)
                    with m.Else():
                        take(byte)
            with m.State("Execute"):  # cycle E
                with m.Switch(op):
                    with m.Case(Op.IDENT):
                        identity = self.identity.encode()
                        ok(Const(int.from_bytes(identity, "little"), 8 * len(identity)))
                    with m.Case(Op.WRITE):
                        m.d.comb += [self.bus.addr.eq(args[:8]), self.bus.w_data.eq(args[8:16]),
                                     self.bus.w_stb.eq(1)]
                        ok()
                    with m.Case(Op.READ):
                        m.d.comb += [self.bus.addr.eq(args[:8]), self.bus.r_stb.eq(1)]
                        m.next = "Read"
                    with m.Case(Op.IDLE, Op.WAIT):
                        m.d.sync += count.eq(1)
                        with m.If(args == 0):
                            with m.If(op == Op.WAIT):
                                ok(Const(0, COUNT_BITS))
                            with m.Else():
                                ok()
                        with m.Else():
                            m.next = "Count"
                    with m.Case(Op.STATUS):
                        ok(irq, Const(0, 6))
                    with m.Case(Op.CYCLE):
                        ok(cycle)
            with m.State("Read"):  # cycle E + 1
                ok(self.bus.r_data)
            with m.State("Count"):  # cycle E + count
                m.d.sync += count.eq(count + 1)
                with m.If(op == Op.IDLE):
                    with m.If(count == args):
                        ok()
                with m.Elif(irq.any() | (count == args)):
                    ok(count)
            with m.State("Reply"):
                self._send(m, tx, out, out_len)
        return m

    def _send(self, m: Module, tx: UartTx, out, out_len) -> None:
        """Send ``out_len`` bytes of ``out`` and their CRC, escaped, between START and END,
        back to back; then receive the next frame."""
        index = Signal(range(REPLY_MAX + 3))  # 0: START, then payload, CRC, END
        crc = Signal(8, init=CRC_INIT)
        pending = Signal()  # ESC was sent, the escaped byte is next
        current = Signal(8)
        # index k > 0 is payload byte k - 1: ``out`` after a byte for START
        m.d.comb += current.eq(Mux(index > out_len, crc,
                                   Cat(Const(0, 8), out).word_select(index, 8)))
        special = Signal()
        escape = Signal(8)
        with m.Switch(current):
            for byte, code in ESCAPES.items():
                with m.Case(byte):
                    m.d.comb += [special.eq(1), escape.eq(code)]
        with m.If(~tx.busy):
            m.d.comb += tx.start.eq(1)
            with m.If(index == 0):
                m.d.comb += tx.data.eq(START)
                m.d.sync += [index.eq(1), crc.eq(CRC_INIT)]
            with m.Elif(index == out_len + 2):
                m.d.comb += tx.data.eq(END)
                m.d.sync += index.eq(0)
                m.next = "Receive"
            with m.Elif(special & ~pending):
                m.d.comb += tx.data.eq(ESC)
                m.d.sync += pending.eq(1)
            with m.Else():
                m.d.comb += tx.data.eq(Mux(pending, escape, current))
                m.d.sync += [pending.eq(0), index.eq(index + 1)]
                with m.If(index <= out_len):
                    m.d.sync += crc.eq(_crc8_next(crc, current))


def _crc8_next(crc, data):
    """The CRC-8 register after ``data`` (:func:`k37.hdl.bridge.protocol.crc8`, in gates).

    The step is linear over GF(2) in ``crc ^ data``: each bit of the result is the XOR of the
    bits of ``crc ^ data`` whose own step sets it (one XOR tree a bit, not eight nested muxes).
    """
    value = crc ^ data
    columns = [crc8([1 << i], 0) for i in range(8)]
    return Cat(*(reduce(operator.xor, [value[i] for i in range(8) if columns[i] >> j & 1],
                        Const(0, 1)) for j in range(8)))
