"""A small UART, 8 data bits, no parity, one stop bit, for the host bridge.

The bit time is a whole number of clock cycles
(:func:`k37.hdl.bridge.protocol.check_cycles_per_bit`); both ends run in the ``sync`` domain, which
may be a clock-enabled one. """

from __future__ import annotations

from amaranth.hdl import Cat, Const, Module, Signal
from amaranth.lib import wiring
from amaranth.lib.cdc import FFSynchronizer
from amaranth.lib.wiring import In, Out

from k37.hdl.bridge.protocol import check_cycles_per_bit

__all__ = ["UartRx", "UartTx"]


class UartRx(wiring.Component):
    """The receiver: one byte out per frame on ``rx``.

    ``rx`` passes a two-stage synchroniser; a low level seen there in cycle *s* is a start bit
    if it is still low at *s* + ``cycles_per_bit // 2`` (else a glitch, ignored); data bit *k*
    is sampled at *s* + ``cycles_per_bit // 2`` + (*k* + 1) * ``cycles_per_bit``, the stop bit
    one bit time after bit 7.

    Members
    -------
    rx : In(1)
        The serial line, idle high.
    data : Out(8)
        The byte received; valid while ``valid`` or ``error`` is high.
    valid : Out(1)
        High for the one cycle in which the stop bit is sampled high.
    error : Out(1)
        High instead of ``valid`` when the stop bit is sampled low (a framing error); the
        receiver then waits for the line to go high before it looks for a start bit.
    """

    def __init__(self, cycles_per_bit: int):
        self.cycles_per_bit = check_cycles_per_bit(cycles_per_bit)
        super().__init__({"rx": In(1, init=1), "data": Out(8), "valid": Out(1),
                          "error": Out(1)})

    def elaborate(self, platform) -> Module:
        m = Module()
        bit = self.cycles_per_bit
        rx = Signal(init=1)
        m.submodules.sync = FFSynchronizer(self.rx, rx, init=1)
        timer = Signal(range(bit))
        count = Signal(range(8))
        shift = Signal(8)
        m.d.comb += self.data.eq(shift)
        with m.FSM():
            with m.State("Idle"):
                with m.If(~rx):
                    m.d.sync += timer.eq(bit // 2 - 1)
                    m.next = "Start"
            with m.State("Start"):
                m.d.sync += timer.eq(timer - 1)
                with m.If(timer == 0):
                    m.d.sync += [timer.eq(bit - 1), count.eq(0)]
                    with m.If(rx):
                        m.next = "Idle"
                    with m.Else():
                        m.next = "Data"
            with m.State("Data"):
                m.d.sync += timer.eq(timer - 1)
                with m.If(timer == 0):
                    m.d.sync += [timer.eq(bit - 1), shift.eq(Cat(shift[1:], rx)),
                                 count.eq(count + 1)]
                    with m.If(count == 7):
                        m.next = "Stop"
            with m.State("Stop"):
                m.d.sync += timer.eq(timer - 1)
                with m.If(timer == 0):
                    with m.If(rx):
                        m.d.comb += self.valid.eq(1)
                        m.next = "Idle"
                    with m.Else():
                        m.d.comb += self.error.eq(1)
                        m.next = "Break"
            with m.State("Break"):
                with m.If(rx):
                    m.next = "Idle"
        return m


class UartTx(wiring.Component):
    """The transmitter: one frame on ``tx`` per byte given.

    Members
    -------
    data : In(8)
        The byte to send, taken while ``start`` is high.
    start : In(1)
        Send ``data``; ignored while ``busy``. The start bit is on ``tx`` from the next cycle,
        for ``cycles_per_bit`` cycles, then bits 0 to 7 and the stop bit.
    busy : Out(1)
        High from the cycle after ``start`` until the stop bit's last cycle.
    tx : Out(1)
        The serial line, idle high.
    """

    def __init__(self, cycles_per_bit: int):
        self.cycles_per_bit = check_cycles_per_bit(cycles_per_bit)
        super().__init__({"data": In(8), "start": In(1), "busy": Out(1), "tx": Out(1, init=1)})

    def elaborate(self, platform) -> Module:
        m = Module()
        bit = self.cycles_per_bit
        shift = Signal(10, init=0x3FF)
        count = Signal(range(11))
        timer = Signal(range(bit))
        m.d.comb += [self.tx.eq(shift[0]), self.busy.eq(count != 0)]
        with m.If(count == 0):
            with m.If(self.start):
                m.d.sync += [shift.eq(Cat(Const(0, 1), self.data, Const(1, 1))),
                             count.eq(10), timer.eq(bit - 1)]
        with m.Elif(timer == 0):
            m.d.sync += [shift.eq(Cat(shift[1:], Const(1, 1))), count.eq(count - 1),
                         timer.eq(bit - 1)]
        with m.Else():
            m.d.sync += timer.eq(timer - 1)
        return m
