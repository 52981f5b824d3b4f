"""The host bridge in gateware: the protocol of :mod:`k37.hdl.bridge.protocol` on a UART, driving
the chipset's 8-bit bus."""

from __future__ import annotations

from amaranth.hdl import Cat, Const, Module, Signal
from amaranth.lib import wiring
from amaranth.lib.fifo import SyncFIFOBuffered
from amaranth.lib.wiring import In, Out

from k37.hdl.bridge.protocol import (
    COMMANDS,
    COUNT_BITS,
    COUNTER_BITS,
    ERROR,
    OK,
    REPLY_MAX,
    RX_FIFO_DEPTH,
    Error,
    Identity,
    Op,
    check_cycles_per_bit,
)
from k37.hdl.bridge.uart import UartRx, UartTx
from k37.hdl.bus.hostbus import HostBus

__all__ = ["UartBridge"]


class UartBridge(wiring.Component):
    """A UART to the chipset's host bus: a PC host in the 8085's place.

    Runs in the chipset's clock domain (``sync``, which may be clock-enabled): every timing
    below is in its cycles. A command starts in cycle E, three cycles after its last byte's
    stop bit is sampled (:func:`k37.hdl.bridge.protocol.command_start`); what it does in E and
    after is :data:`k37.hdl.bridge.protocol.COMMANDS`'s. The reply's first start bit is on ``tx``
    two cycles after the cycle the command ends in (E for WRITE, IDENT, STATUS and CYCLE, E + 1
    for READ, E + N for an IDLE of N, E + n for a WAIT that returned n, E - 1 for an error),
    each next start bit one cycle after the stop bit before
    (:func:`k37.hdl.bridge.protocol.reply_end`).

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
    """

    def __init__(self, cycles_per_bit: int, identity: Identity):
        self.cycles_per_bit = check_cycles_per_bit(cycles_per_bit)
        if not isinstance(identity, Identity):
            raise TypeError(f"identity must be an Identity, not {identity!r}")
        self.identity = identity
        super().__init__({"rx": In(1, init=1), "tx": Out(1, init=1), "bus": Out(HostBus(8)),
                          "irq_interp": In(1), "irq_alarm": In(1)})

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

        op = Signal(8)
        args = Signal(COUNT_BITS)
        index = Signal(range(COUNT_BITS // 8))
        count = Signal(COUNT_BITS)
        reply = Signal(8 * REPLY_MAX)
        reply_left = Signal(range(REPLY_MAX + 1))

        def answer(*fields) -> None:
            """Send the reply ``fields`` (Cat order: the first byte first) next."""
            value = Cat(*fields)
            m.d.sync += [reply.eq(value), reply_left.eq(len(value) // 8)]
            m.next = "Reply"

        def ok(*results) -> None:
            answer(Const(OK, 8), *results)

        def error(code: Error) -> None:
            answer(Const(ERROR, 8), Const(code, 8))

        with m.FSM():
            with m.State("Opcode"):
                m.d.comb += fifo.r_en.eq(1)
                with m.If(fifo.r_rdy):
                    m.d.sync += [op.eq(byte), index.eq(0)]
                    with m.If(framing):
                        error(Error.FRAMING)
                    with m.Else():
                        with m.Switch(byte):
                            for command in COMMANDS.values():
                                with m.Case(command.op):
                                    m.next = "Args" if command.args else "Execute"
                            with m.Default():
                                error(Error.OPCODE)
            with m.State("Args"):
                m.d.comb += fifo.r_en.eq(1)
                with m.If(fifo.r_rdy):
                    m.d.sync += [args.word_select(index, 8).eq(byte), index.eq(index + 1)]
                    with m.If(framing):
                        error(Error.FRAMING)
                    with m.Else():
                        with m.Switch(op):
                            for command in COMMANDS.values():
                                if command.args:
                                    with m.Case(command.op):
                                        with m.If(index == command.frame_bytes - 2):
                                            m.next = "Execute"
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
                with m.If(reply_left == 0):
                    m.next = "Opcode"
                with m.Elif(~tx.busy):
                    m.d.comb += [tx.data.eq(reply[:8]), tx.start.eq(1)]
                    m.d.sync += [reply.eq(reply[8:]), reply_left.eq(reply_left - 1)]
        return m
