"""Servo amplifier, motor and encoder of one axis, as a simulation model.

The plant is written in Amaranth so that it runs inside the simulated design, identically on
every backend (Amaranth's simulator, CXXRTL, Verilator), with integer fixed-point arithmetic
and no per-cycle Python. It is not part of the synthesised chipset.

Fixed point: positions are counts (1 count = 1 LSB = one quadrature state) with
``FRAC_BITS`` fraction bits; velocities are counts per cycle with the same fraction.
"""



from amaranth.hdl import Module, Mux, Signal, Value, signed
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from k37.hdl.common.observation import FreeRunning, Observed, PlantState
from k37.sim.machine.plant_model import (
    ALPHA_BITS,
    COUNT_BITS,
    FF_BITS,
    FRAC_BITS,
    GAIN_BITS,
    KF_BITS,
    PERIOD_BITS,
    POSITION_BITS,
    PRODUCT_BITS,
    VC_BITS,
    VC_MAX,
    VMAX_BITS,
)

__all__ = ["ServoPlant"]

class ServoPlant(Observed, wiring.Component):
    """Servo amplifier + motor (first-order velocity lag) + incremental encoder.

    In every ``period``-th cycle from reset (every cycle with a period of 0 or 1), the velocity
    update: e = dac - dac_zero; vc = clamp(e * gain + ff, +-vmax) (vmax 0: 2^37 - 1), where
    the velocity feedforward ff is +kf for each command pulse com_pos since the last update
    (this cycle's included), -kf for each com_neg (an F/V converter's input: its mean is Kf
    times the command pulse rate, and the motor's own lag smooths it);
    v += round((vc - v) * alpha / 2^ALPHA_BITS), or v = vc when that step rounds to 0 (v = 0
    while stalled). Between updates v is held. Every cycle p += v; the encoder count is
    floor(p) and A/B are its Gray code (count 0: A=0 B=0, 1: 1 0, 2: 1 1, 3: 0 1), so
    positive motion has A leading B (CCW, normal). Every output follows registered state
    only: it shows the state after the cycle's update, one cycle after the ``dac`` (and the
    fault inputs) it follows.

    Members
    -------
    dac : In(16)
        D/A code from the K3702, offset binary, N bits right-aligned.
    dac_zero : In(16)
        The code of 0 V, 2^(N-1) for an N-bit converter (:func:`dac_zero`); given as a
        number rather than N, so that the model needs no shifter.
    gain, alpha, vmax, kf : In(GAIN_BITS), In(ALPHA_BITS), In(VMAX_BITS), In(KF_BITS)
        Fixed-point parameters, see :class:`PlantParams`.
    period : In(PERIOD_BITS)
        Cycles from one velocity update to the next (0 or 1: every cycle); alpha and kf are
        per update (:attr:`PlantParams.update_cycles`).
    com_pos, com_neg : In(1)
        The K3702's command pulses (for the feedforward), combinational into ``vc`` in an
        update cycle, summed until the next one otherwise. They are events, so they are 0 all
        through an idle skip, and a skip's native plant update (which adds only the sum
        before it) is exact.
    stall : In(1)
        Fault: the axis is blocked (velocity held at 0).
    glitch_a, glitch_b : In(1)
        Fault: invert A (or B) and its complement in this cycle (a noise spike).
    break_a : In(1)
        Fault: the /A line is broken (reads as A, not its complement).
    a, a_n, b, b_n : Out(1)
        Encoder lines.
    count : Out(signed(COUNT_BITS))
        The encoder count (floor of the position).
    velocity : Out(signed(VC_BITS + 1))
        Motor velocity, counts/cycle << FRAC_BITS.
    """

    dac: In(16)
    dac_zero: In(16)
    gain: In(GAIN_BITS)
    alpha: In(ALPHA_BITS)
    vmax: In(VMAX_BITS)
    kf: In(KF_BITS)
    period: In(PERIOD_BITS)
    com_pos: In(1)
    com_neg: In(1)
    stall: In(1)
    glitch_a: In(1)
    glitch_b: In(1)
    break_a: In(1)
    a: Out(1)
    a_n: Out(1)
    b: Out(1)
    b_n: Out(1)
    count: Out(signed(COUNT_BITS))
    velocity: Out(signed(VC_BITS + 1))

    @property
    def free_running(self) -> FreeRunning:
        """See :meth:`declare`."""
        return self.declare()

    @staticmethod
    def declare() -> FreeRunning:
        """While the chipset stands still, a compiled backend steps the plant natively, with
        this fixed-point format, up to its next count (:mod:`k37.hdl.common.observation`)."""
        return FreeRunning(plants=(PlantState("", VC_BITS, ALPHA_BITS, FRAC_BITS),))

    def elaborate(self, platform) -> Module:
        m = Module()
        # The update comes in the cycles where phase is 0; ff sums the feedforward since the
        # last one (this cycle's included).
        phase = Signal(PERIOD_BITS)
        update = Signal()
        m.d.comb += update.eq(phase == 0)
        m.d.sync += phase.eq(Mux(phase + 1 >= self.period, 0, phase + 1))
        ff = Signal(signed(FF_BITS))
        feedforward = Signal(signed(FF_BITS))
        m.d.comb += feedforward.eq(
            ff + Mux(self.com_pos == self.com_neg, 0, Mux(self.com_pos, self.kf, -self.kf)))
        m.d.sync += ff.eq(Mux(update, 0, feedforward))
        vc = self.velocity_command(m, feedforward)
        m.d.sync += self.velocity.eq(Mux(update, self.next_velocity(m, vc), self.velocity))
        # p += v_next is kept as before = p - v (so before += v): each register's next value
        # is then one expression, which compiled simulators evaluate only at the clock edge.
        before = Signal(signed(POSITION_BITS))
        m.d.sync += before.eq(before + self.velocity)
        position = Signal(signed(POSITION_BITS))
        m.d.comb += position.eq(self.encoder_position(m, before + self.velocity))
        # The encoder lines follow the position; a fault input acts one cycle later, as if
        # it were registered with the lines.
        glitch_a = Signal()
        glitch_b = Signal()
        break_a = Signal()
        m.d.sync += [glitch_a.eq(self.glitch_a), glitch_b.eq(self.glitch_b),
                     break_a.eq(self.break_a)]
        count = position[FRAC_BITS:].as_signed()
        a = count[0] ^ count[1] ^ glitch_a
        b = count[1] ^ glitch_b
        m.d.comb += [
            self.count.eq(count),
            self.a.eq(a),
            self.a_n.eq(Mux(break_a, a, ~a)),
            self.b.eq(b),
            self.b_n.eq(~b),
        ]
        return m

    def encoder_position(self, m: Module, motor: Value) -> Value:
        """The position the encoder reads, given the motor's (here the motor's own)."""
        del m
        return motor

    def velocity_command(self, m: Module, feedforward: Value) -> Signal:
        """vc: the drive's velocity command with ``feedforward``, clamped to the speed limit
        (combinational)."""
        err = Signal(signed(17))
        m.d.comb += err.eq(self.dac - self.dac_zero)
        # The D/A's part on its own: it follows the D/A word alone, which a move changes
        # every few dozen cycles, so a compiled simulator computes it only then.
        command = Signal(signed(len(err) + GAIN_BITS + 1), attrs={"keep": 1})
        m.d.comb += command.eq(err * self.gain)
        vc_raw = Signal(signed(len(err) + GAIN_BITS + 2))
        m.d.comb += vc_raw.eq(command + feedforward)
        vmax = Signal(VC_BITS)
        m.d.comb += vmax.eq(Mux((self.vmax == 0) | (self.vmax > VC_MAX), VC_MAX, self.vmax))
        vc = Signal(signed(VC_BITS + 1))
        m.d.comb += vc.eq(Mux(vc_raw > vmax, vmax, Mux(vc_raw < -vmax, -vmax, vc_raw)))
        return vc

    def next_velocity(self, m: Module, vc: Signal):
        """The velocity after this cycle: the first-order lag towards ``vc``."""
        # Every value fits in PRODUCT_BITS = 64 bits, so that compiled simulators compute it in
        # at most two machine words: |vc|, |v| < 2^VC_BITS and alpha < 2^ALPHA_BITS, so
        # |(vc - v) * alpha| < 2^62.
        delta = Signal(signed(PRODUCT_BITS))
        m.d.comb += delta.eq((vc - self.velocity) * self.alpha + (1 << (ALPHA_BITS - 1)))
        # An update that rounds to 0 lands on vc: the lag ends exactly, so an axis at rest
        # has velocity 0 (no creep from a residue the rounding can never remove).
        step = Signal(signed(PRODUCT_BITS - ALPHA_BITS))
        m.d.comb += step.eq(delta.shift_right(ALPHA_BITS))
        return Mux(self.stall, 0, Mux(step == 0, vc, self.velocity + step))
