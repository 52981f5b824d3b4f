# amaranth: UnusedElaboratable=no
"""The chipset as a board runs it: at its own 1 MHz cycle inside a faster FPGA clock.

Everything a board adds around :class:`k37.hdl.chipset.chip.Chipset`, whatever the board: the
clock enable that keeps the chipset's cycle at the paper's 1 MHz, the synchronisers of the
encoder lines, one sigma-delta D/A per axis, the alarm outputs and the machine I/O (the
watchdog, E-stop, limits and drive-enable of :class:`k37.hdl.board.machine_io.MachineIO`,
between the bus and the chipset). The board's top
(:mod:`k37.hdl.board.ulx3s`) puts it on pins with the host bridge. (The first line of this file
lets a core be built for its signature and chipset parameters alone, without Amaranth's
unused-elaboratable warning for the chipset it holds.)
"""

from __future__ import annotations

from amaranth.hdl import EnableInserter, Module, Signal
from amaranth.lib import wiring
from amaranth.lib.cdc import FFSynchronizer
from amaranth.lib.wiring import In, Out, connect, flipped

from k37.hdl.board.machine_io import MachineIO
from k37.hdl.board.sigma_delta import SigmaDelta
from k37.hdl.bus.hostbus import HostBus
from k37.hdl.chipset.chip import Chipset
from k37.hdl.chipset.map import axis_names
from k37.hdl.common.constants import CHIP_HZ
from k37.hdl.common.params import positive_int

__all__ = ["BoardCore"]


class BoardCore(wiring.Component):
    """The chipset clocked at :data:`CHIP_HZ` by a clock enable, with its board I/O.

    The board's clock runs at ``clock_hz``; a counter makes ``tick`` high in one cycle of
    every ``clock_hz / CHIP_HZ`` (25 on a 25 MHz board), and the chipset is built under
    Amaranth's ``EnableInserter(tick)``: its rising-edge registers change only at the edge
    ending a tick cycle and the K3702's falling-edge ones only at the falling edge inside it,
    so each of its cycles is one microsecond long and every count, rate and latency of the
    datasheets holds unchanged. Whatever drives ``bus`` must run under the same enable
    (one byte access per tick cycle, as the 8085's bus cycle on the real chips).

    Encoder lines come in asynchronous: each passes two flip-flops at the board clock, so the
    chipset sees a line at most 2 board cycles plus one chipset cycle after it changes, and
    takes ``a_n = ~a``, ``b_n = ~b`` (single-ended encoders; its line-break check never fires).
    The D/A outputs run at the full board clock (:class:`~k37.hdl.board.sigma_delta.SigmaDelta`).
    The E-stop and limit inputs pass two flip-flops as the encoder lines do into the machine
    I/O, which runs under the same enable as the chipset and sits between ``bus`` and it.

    Parameters
    ----------
    axes : int
        2 or 3 (:class:`~k37.hdl.chipset.chip.Chipset`).
    clock_hz : int
        The board clock; a multiple of :data:`CHIP_HZ`, at least twice it.
    **chipset : dict
        Further :class:`~k37.hdl.chipset.chip.Chipset` parameters (``accel``, ``accel_shape``...).

    Members
    -------
    bus : In(HostBus(8))
        The chipset's host bus (chip select and register address), sampled at the edge ending
        a tick cycle; a read's byte is on ``r_data`` from the board cycle after that edge until
        the next read.
    feed : In(1)
        The host is there (the bridge took a whole frame), under the same enable: the
        watchdog's feed (:class:`~k37.hdl.board.machine_io.MachineIO`).
    tick : Out(1)
        The chipset's clock enable: high in one board cycle of every ``clock_hz / CHIP_HZ``.
    irq_interp, irq_alarm : Out(1)
        The chipset's interrupts (data request; an axis alarm), held for whole chipset cycles.
    <axis>_a, <axis>_b : In(1)
        An axis's encoder lines, asynchronous to the board clock.
    <axis>_dac : Out(1)
        An axis's D/A word as a sigma-delta bit stream at the board clock.
    <axis>_alarm : Out(1)
        An axis's ALARM, active high (an LED lights on alarm).
    estop_n, <axis>_limit_n : In(1)
        E-stop and an axis's limit input, active low, asynchronous to the board clock.
    drive_enable : Out(1)
        Drive-enable (servo-on) of every axis: low while a watchdog trip or the E-stop is
        latched.
    """

    def __init__(self, *, axes: int = 3, clock_hz: int = 25_000_000, **chipset):
        self.axes = axis_names(axes)
        positive_int("clock_hz", clock_hz)
        if clock_hz % CHIP_HZ or clock_hz < 2 * CHIP_HZ:
            raise ValueError(f"clock_hz must be a multiple of {CHIP_HZ} Hz and at least twice "
                             f"it, not {clock_hz!r}")
        self.clock_hz = clock_hz
        self.ratio = clock_hz // CHIP_HZ
        #: The chipset inside (its ports are observable in simulation).
        self.chipset = Chipset(axes=axes, **chipset)
        super().__init__({
            "bus": In(HostBus(8)), "feed": In(1), "tick": Out(1),
            "irq_interp": Out(1), "irq_alarm": Out(1),
            **{f"{axis}_{line}": In(1) for axis in self.axes for line in ("a", "b")},
            **{f"{axis}_{pin}": Out(1) for axis in self.axes for pin in ("dac", "alarm")},
            "estop_n": In(1, init=1), **{f"{axis}_limit_n": In(1, init=1) for axis in self.axes},
            "drive_enable": Out(1),
        })

    def elaborate(self, platform) -> Module:
        m = Module()
        count = Signal(range(self.ratio))
        m.d.comb += self.tick.eq(count == self.ratio - 1)
        m.d.sync += count.eq(count + 1)
        with m.If(self.tick):
            m.d.sync += count.eq(0)

        chipset = self.chipset
        # Both edges' registers (the K3702's counters change on the falling edge, in its
        # local domain "neg"): the falling edge of the tick cycle stands for the middle of the
        # chipset's cycle.
        m.submodules.chipset = EnableInserter({"sync": self.tick, "neg": self.tick})(chipset)
        m.submodules.machine_io = machine_io = EnableInserter(self.tick)(
            MachineIO(len(self.axes)))
        connect(m, flipped(self.bus), machine_io.host)
        connect(m, machine_io.chip, chipset.bus)
        m.d.comb += [machine_io.feed.eq(self.feed),
                     self.drive_enable.eq(machine_io.drive_enable)]
        for name in ("estop_n", *(f"{axis}_limit_n" for axis in self.axes)):
            m.submodules[f"{name}_sync"] = FFSynchronizer(
                getattr(self, name), getattr(machine_io, name), init=1, stages=2)
        m.d.comb += [self.irq_interp.eq(chipset.irq_interp),
                     self.irq_alarm.eq(chipset.irq_alarm)]
        for axis in self.axes:
            pins = getattr(chipset, axis)
            for line in ("a", "b"):
                synced = Signal(name=f"{axis}_{line}_sync")
                m.submodules[f"{axis}_{line}_sync"] = FFSynchronizer(
                    getattr(self, f"{axis}_{line}"), synced, stages=2)
                m.d.comb += [getattr(pins, line).eq(synced),
                             getattr(pins, f"{line}_n").eq(~synced)]
            m.submodules[f"{axis}_dac"] = dac = SigmaDelta(len(pins.dac))
            m.d.comb += [getattr(machine_io, f"{axis}_dac_in").eq(pins.dac),
                         dac.word.eq(getattr(machine_io, f"{axis}_dac")),
                         getattr(self, f"{axis}_dac").eq(dac.out),
                         getattr(self, f"{axis}_alarm").eq(~pins.alarm_n)]
        return m
