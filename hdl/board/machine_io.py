"""The board's watchdog and machine I/O: E-stop, limits and drive-enable, between the host bridge
and the chipset (``docs/chips/board.md``).

The reference model is :class:`k37.hdl.board.model.machine_io.MachineIOModel`; the registers are
:data:`k37.hdl.board.map.BOARD_MAP`.
"""

from __future__ import annotations

from amaranth.hdl import Cat, Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from k37.hdl.board.map import (
    BOARD_MAP,
    BOARD_SELECT,
    BOARD_WINDOW,
    DECEL_CTRL_PORT,
    LATCHED,
    STOPPING,
    WATCHDOG_BITS,
)
from k37.hdl.bus.hostbus import HostBus, RegisterBank
from k37.hdl.chipset.map import REG_BITS, axis_names

__all__ = ["MachineIO"]


class MachineIO(wiring.Component):
    """The board's registers on the host bus, its watchdog and its stops.

    Runs in the chipset's cycle (its ``sync`` domain is clock-enabled as the chipset's). Host
    accesses to the board's ports (:data:`k37.hdl.board.map.BOARD_MAP`) go to its registers,
    every other one on to ``chip`` unchanged. ``silent`` counts the cycles since ``feed`` was
    last high (the bridge took a whole frame); the watchdog trips at the edge ending a cycle
    in which WATCHDOG is not 0 and ``silent`` has reached it, so with the last frame in cycle
    *t* the STATUS bit is set from cycle *t* + WATCHDOG + 2. At the same edge an active E-stop
    input or limit input sets its bit. A latched bit makes the board hold: in the first cycle
    after a bit rises from none in which the host makes no access, the board writes 1 to the
    DECEL chip's CTRL (hold) on ``chip``, and while held a host write to that port has its
    hold bit forced to 1. A latched watchdog or E-stop bit also puts DAC_ZERO on every axis's
    ``<axis>_dac`` and drive-enable low, from the cycle after the edge that latched it.
    CLEAR's write takes effect at the edge after its ``w_stb`` cycle (a bit whose input is
    still active is set again at once).

    Members
    -------
    host : In(HostBus(8))
        The host's bus (the bridge's).
    feed : In(1)
        The host is there: the bridge took a whole frame in this cycle.
    chip : Out(HostBus(8))
        The chipset's bus.
    estop_n : In(1)
        E-stop, active low, synchronised by the board.
    <axis>_limit_n : In(1)
        An axis's limit input, active low, synchronised by the board.
    <axis>_dac_in : In(16)
        An axis's D/A word from the chipset.
    <axis>_dac : Out(16)
        The D/A word to the pin: ``<axis>_dac_in``, or DAC_ZERO while the drives are stopped.
    drive_enable : Out(1)
        High unless a watchdog trip or the E-stop is latched.
    """

    def __init__(self, axes: int = 3):
        self.axes = axis_names(axes)
        super().__init__({
            "host": In(HostBus(8)), "feed": In(1), "chip": Out(HostBus(8)),
            "estop_n": In(1, init=1),
            **{f"{axis}_limit_n": In(1, init=1) for axis in self.axes},
            **{f"{axis}_dac_in": In(16) for axis in self.axes},
            **{f"{axis}_dac": Out(16) for axis in self.axes},
            "drive_enable": Out(1),
        })

    def elaborate(self, platform) -> Module:
        m = Module()
        host, chip = self.host, self.chip
        m.submodules.regs = regs = RegisterBank(BOARD_MAP)
        width = len(regs.bus.addr)
        hit = host.addr[width:] == (BOARD_SELECT << REG_BITS | BOARD_WINDOW) >> width
        access = host.w_stb | host.r_stb

        silent = Signal(WATCHDOG_BITS)
        latched = Signal(5)
        pending = Signal()
        read_board = Signal()
        held = latched.any()
        stopping = (latched & STOPPING).any()
        inject = pending & ~access

        m.d.comb += [regs.bus.addr.eq(host.addr[:width]), regs.bus.w_data.eq(host.w_data),
                     regs.bus.w_stb.eq(host.w_stb & hit), regs.bus.r_stb.eq(host.r_stb & hit)]
        with m.If(inject):
            m.d.comb += [chip.addr.eq(DECEL_CTRL_PORT), chip.w_data.eq(1), chip.w_stb.eq(1)]
        with m.Else():
            forced = held & host.w_stb & (host.addr == DECEL_CTRL_PORT)
            m.d.comb += [chip.addr.eq(host.addr), chip.w_data.eq(host.w_data | forced),
                         chip.w_stb.eq(host.w_stb & ~hit), chip.r_stb.eq(host.r_stb & ~hit)]
        with m.If(host.r_stb):
            m.d.sync += read_board.eq(hit)
        m.d.comb += host.r_data.eq(Mux(read_board, regs.bus.r_data, chip.r_data))

        estop_in = ~self.estop_n
        watchdog = regs.watchdog.w_data
        trips = (watchdog != 0) & (silent >= watchdog)
        limits = Cat(~getattr(self, f"{axis}_limit_n") for axis in self.axes)
        set_bits = Cat(trips, estop_in, limits)
        clear = Mux(regs.clear.w_stb, regs.clear.w_data & LATCHED, 0)
        new = (latched & ~clear) | set_bits
        m.d.sync += [latched.eq(new),
                     pending.eq((pending & ~inject) | (new.any() & ~held)),
                     silent.eq(Mux(self.feed, 0, Mux(silent.all(), silent, silent + 1)))]

        m.d.comb += [
            regs.watchdog.r_data.eq(watchdog), regs.dac_zero.r_data.eq(regs.dac_zero.w_data),
            regs.status.r_data.eq(Cat(latched, estop_in, ~stopping, held)),
            self.drive_enable.eq(~stopping),
            *(getattr(self, f"{axis}_dac").eq(Mux(stopping, regs.dac_zero.w_data,
                                                  getattr(self, f"{axis}_dac_in")))
              for axis in self.axes),
        ]
        return m

