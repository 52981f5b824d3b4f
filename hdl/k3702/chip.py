"""KM3702 position controller gateware (``docs/chips/k3702.md``), one per axis.

The reference model is :mod:`k37.hdl.k3702.model`; this module is tested against it cycle by cycle.
"""

from amaranth.hdl import ClockDomain, ClockSignal, Const, Module, Mux, ResetSignal, Signal, signed
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out, connect, flipped

from k37.hdl.bus.hostbus import HostBus, RegisterBank
from k37.hdl.common.observation import Observed
from k37.hdl.k3702.map import COUNTER_WIDTH, K3702_MAP

__all__ = ["K3702"]

_DAC_BITS_INIT = K3702_MAP["DAC_BITS"].init


class K3702(Observed, wiring.Component):
    """The KM3702 position controller of one axis.

    All of the chip's own state (counters, flags, D/A word, interrupt) changes on the
    **falling** clock edge, in a local ``neg`` domain driven by the system clock; the host
    interface (:class:`~k37.hdl.bus.hostbus.RegisterBank`) works on the rising edge. Each falling
    edge samples the four count inputs, and the outputs are computed from the new counter
    value and the zone settings of that cycle, so they always agree with ``error``.

    Timing, as a testbench sees it that sets inputs in cycle *t*, then does
    ``await ctx.tick()`` and ``ctx.get()`` (cycle *t* + 1):

    * a count input high in cycle *t* is counted at the falling edge inside cycle *t*; the
      new ``command``, ``error``, ``dac`` and flags show in cycle *t* + 1 (an input held N
      cycles counts N times; inputs of one cycle are all counted, net effect);
    * a register write whose last byte is on the bus in cycle *t* acts at the falling edge
      of cycle *t* + 1 and shows in cycle *t* + 2; a counter load or clear replaces the
      counter's old value and the counts of that same cycle are added to the new value, so
      no count is ever dropped;
    * reading byte 0 of COMMAND or ERROR (or STATUS) in cycle *t* snapshots the value shown
      in cycle *t* + 1, so the three bytes always belong to one counter value;
    * a CORRECT write of *c* (K37's extension) whose byte is on the bus in cycle *t* adds
      *c* to ``command`` and ``error`` at the falling edge of *t* + 1, with that cycle's
      counts (it shows in *t* + 2), as *c* command pulses would;
    * the alarm interrupt rises together with ``alarm_n`` falling, when ``|error|`` enters
      the alarm zone, and holds until CMD.ack; a new interrupt needs a new entry.

    Counters wrap silently: 0x7FFFFF + 1 = 0x800000 and back. (In Amaranth's simulator the
    stretch before the first rising edge contains no falling edge: cycles count from the
    first rising edge.)

    Members
    -------
    bus : In(HostBus(K3702_MAP.addr_width))
        Host interface (see :mod:`k37.hdl.bus.hostbus` for its cycle timing); registers in
        :data:`K3702_MAP`.
    com_pos, com_neg : In(1)
        +COM / -COM command pulses (from the interpolator), level-sensitive, sampled at the
        falling edge of every cycle.
    fb_pos, fb_neg : In(1)
        +FB / -FB feedback pulses (from the encoder interface), likewise.
    command, error : Out(signed(24))
        The counters, changing at the falling edge (probes; the host reads them through the
        bus).
    dac : Out(16)
        The D/A word: ``error`` clamped to N bits (N = DAC_BITS, 8..16), offset binary
        (0 = -full scale, 2^(N-1) = 0 V, 2^N - 1 = +full scale), right-aligned.
    sat_pos, sat_neg : Out(1)
        +SAT / -SAT: ``dac`` is clamped high / low.
    in_position : Out(1)
        ``|error| <= W``.
    negative : Out(1)
        ``error < 0``.
    alarm_n : Out(1)
        ALARM, active low: ``|error| > A``.
    irq : Out(1)
        Alarm interrupt, held until the host acknowledges it (CMD.ack).
    """

    @property
    def probes(self) -> tuple[str, ...]:
        """Observation outputs, not pins of the chip (the Verilog export keeps them inside)."""
        return ("command", "error")

    bus: In(HostBus(K3702_MAP.addr_width))
    com_pos: In(1)
    com_neg: In(1)
    fb_pos: In(1)
    fb_neg: In(1)
    command: Out(signed(COUNTER_WIDTH))
    error: Out(signed(COUNTER_WIDTH))
    dac: Out(16, init=1 << (_DAC_BITS_INIT - 1))
    sat_pos: Out(1)
    sat_neg: Out(1)
    in_position: Out(1, init=1)
    negative: Out(1)
    alarm_n: Out(1, init=1)
    irq: Out(1)

    def elaborate(self, platform) -> Module:
        m = Module()
        # The paper's counters change on the falling edge (``docs/chips/k3702.md``). The domain must
        # be defined and driven here, or Amaranth would create a rising-edge one silently.
        m.domains.neg = ClockDomain("neg", clk_edge="neg", local=True)
        m.d.comb += [ClockSignal("neg").eq(ClockSignal("sync")),
                     ResetSignal("neg").eq(ResetSignal("sync"))]

        m.submodules.regs = regs = RegisterBank(K3702_MAP)
        connect(m, flipped(self.bus), regs.bus)

        cmd_reg = K3702_MAP["CMD"]

        def cmd(name: str):
            return regs.cmd.w_stb & regs.cmd.w_data[cmd_reg.field(name).offset]

        # Counters: a load or clear sets the base value, the cycle's counts are added to it;
        # the host's correction pulses (K37's CORRECT) count as command pulses.
        correct = Mux(regs.correct.w_stb, regs.correct.w_data.as_signed(), 0)
        com_delta = self.com_pos - self.com_neg + correct
        base_command = Mux(regs.command.w_stb, regs.command.w_data,
                           Mux(cmd("clear_command"), 0, self.command))
        base_error = Mux(regs.error.w_stb, regs.error.w_data,
                         Mux(cmd("clear_error"), 0, self.error))
        error = Signal(signed(COUNTER_WIDTH))  # the value after this falling edge
        m.d.comb += error.eq(base_error + com_delta - self.fb_pos + self.fb_neg)
        m.d.neg += [self.command.eq(base_command + com_delta), self.error.eq(error)]

        # Flags and D/A word of the new error value, under this cycle's settings.
        magnitude = Signal(COUNTER_WIDTH)  # |error|; 2^23 for -2^23
        half = Signal(17)  # 2^(N-1), the offset of 0 V
        alarm = Signal()
        sat_pos = Signal()
        sat_neg = Signal()
        m.d.comb += [
            magnitude.eq(Mux(error < 0, -error, error)),
            half.eq(Const(1 << 7, 17) << (regs.dac_bits.w_data - 8)[:4]),  # N is 8..16
            alarm.eq(magnitude > regs.alarm_zone.w_data),
            sat_pos.eq(error >= half),
            sat_neg.eq(error < -half),
        ]
        m.d.neg += [
            self.dac.eq(Mux(sat_pos, (half << 1) - 1, Mux(sat_neg, 0, error + half))),
            self.sat_pos.eq(sat_pos),
            self.sat_neg.eq(sat_neg),
            self.in_position.eq(magnitude <= regs.position_zone.w_data),
            self.negative.eq(error < 0),
            self.alarm_n.eq(~alarm),
            # Entering the alarm zone sets the interrupt; an acknowledge never hides an entry.
            self.irq.eq((self.irq & ~cmd("ack")) | (alarm & self.alarm_n)),
        ]
        bad_config = Signal()
        m.d.neg += bad_config.eq((bad_config & ~cmd("clear")) | regs.dac_bits.w_err)

        flags = {"in_position": self.in_position, "negative": self.negative,
                 "sat_pos": self.sat_pos, "sat_neg": self.sat_neg, "alarm": ~self.alarm_n,
                 "irq": self.irq, "bad_config": bad_config}
        for f in K3702_MAP["STATUS"].fields:
            m.d.comb += regs.status.r_data[f.offset].eq(flags[f.name])
        m.d.comb += [
            regs.command.r_data.eq(self.command),
            regs.error.r_data.eq(self.error),
            regs.position_zone.r_data.eq(regs.position_zone.w_data),
            regs.alarm_zone.r_data.eq(regs.alarm_zone.w_data),
            regs.dac_bits.r_data.eq(regs.dac_bits.w_data),
        ]
        return m
