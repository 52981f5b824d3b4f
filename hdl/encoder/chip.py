"""Encoder interface gateware (``docs/chips/encoder.md``): receiver, glitch filter, quadrature
decoder.

The reference model is :mod:`k37.hdl.encoder.model`; this module is tested against it cycle by
cycle.
"""


from amaranth.hdl import Module, Mux, Signal, Value
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out, connect, flipped

from k37.hdl.bus.hostbus import HostBus, RegisterBank
from k37.hdl.encoder.map import ENCODER_MAP, Decode

__all__ = ["EncoderInterface"]

def _streak(m: Module, cond: Value, k: Value, name: str) -> Signal:
    """High in the sample that completes ``k`` consecutive samples with ``cond`` high.

    The count then starts afresh; it restarts whenever ``cond`` is low.
    """
    count = Signal(8, name=f"{name}_count")
    done = Signal(name=f"{name}_done")
    m.d.comb += done.eq(cond & (count + 1 >= k))
    m.d.sync += count.eq(Mux(cond & ~done, count + 1, 0))
    return done


class EncoderInterface(wiring.Component):
    """The encoder interface of one axis: A, /A, B, /B in, one-cycle +FB / -FB pulses out.

    Every input is sampled at each rising edge of the system clock (1 MHz). Per line, the
    differential receiver outputs A while A and /A are complementary and holds its last
    output while they are equal (no differential signal: the receiver's hysteresis); the
    glitch filter accepts the receiver's new level after K = FILTER consecutive equal
    samples. The decoder compares the accepted levels with the previous ones: one line
    changing is a step (A leading B, the sequence 00, 10, 11, 01 of (A, B), is CCW, normal,
    +FB; B leading A is -FB), both changing at once sets ``quad_error`` and counts nothing.
    The first sample after reset sets the accepted levels without counting.

    Timing, as a testbench sees it that sets inputs in cycle *t* (sampled at the rising edge
    that ends it), then does ``await ctx.tick()`` and ``ctx.get()``: a clean edge held for
    K samples from cycle *t* gives its ``fb_pos`` / ``fb_neg`` pulse in cycle *t* + K
    (latency K cycles; 3 us with the reset K = 3), one cycle long. A pair non-complementary
    in cycles *t* .. *t* + K - 1 shows ``line_fault`` from cycle *t* + K; a both-line
    change shows ``quad_error`` in the cycle its pulse would have had. Register writes whose
    last byte is on the bus in cycle *t* act on the samples of cycle *t* + 1 on.

    Members
    -------
    bus : In(HostBus(ENCODER_MAP.addr_width))
        Host interface (see :mod:`k37.hdl.bus.hostbus`); registers in :data:`ENCODER_MAP`.
    a, a_n, b, b_n : In(1)
        The encoder's lines A, /A, B, /B, sampled every cycle.
    fb_pos, fb_neg : Out(1)
        One-cycle +FB / -FB count pulses for the K3702 (never both at once).
    line_fault : Out(1)
        A line of A or B was broken (non-complementary for K samples); sticky until
        CMD.clear.
    quad_error : Out(1)
        Illegal transition seen (A and B changed in one sample); sticky until CMD.clear.
    """

    bus: In(HostBus(ENCODER_MAP.addr_width))
    a: In(1)
    a_n: In(1)
    b: In(1)
    b_n: In(1)
    fb_pos: Out(1)
    fb_neg: Out(1)
    line_fault: Out(1)
    quad_error: Out(1)

    def elaborate(self, platform) -> Module:
        m = Module()
        m.submodules.regs = regs = RegisterBank(ENCODER_MAP)
        connect(m, flipped(self.bus), regs.bus)
        k = regs.filter.w_data
        clear = regs.cmd.w_stb & regs.cmd.w_data[ENCODER_MAP["CMD"].field("clear").offset]

        started = Signal()
        m.d.sync += started.eq(1)

        flags: dict[str, Value] = {}
        change: dict[str, Value] = {}  # the filter accepts a new level in this sample
        new: dict[str, Value] = {}     # the accepted level after this sample
        for name, line, line_n in (("a", self.a, self.a_n), ("b", self.b, self.b_n)):
            # Values used several times are signals: computed once per evaluation by
            # compiled simulators, rather than once per use.
            complementary = line != line_n
            held = Signal(name=f"{name}_rx")
            received = Signal(name=f"{name}_received")
            m.d.comb += received.eq(Mux(complementary, line, held))
            m.d.sync += held.eq(received)

            fault = Signal(name=f"line_fault_{name}")
            broken = _streak(m, ~complementary, k, f"{name}_broken")
            m.d.sync += fault.eq((fault & ~clear) | broken)

            level = Signal(name=f"{name}_level")
            change[name] = _streak(m, started & (received != level), k, f"{name}_filter")
            new[name] = Signal(name=f"{name}_new")
            m.d.comb += new[name].eq(Mux(change[name] | ~started, received, level))
            m.d.sync += level.eq(new[name])
            flags |= {f"line_fault_{name}": fault, name: level}

        # Decoder. After a change of A, A != B means A leads (+); after a change of B,
        # A == B means A leads.
        up = Mux(change["a"], new["a"] != new["b"], new["a"] == new["b"])
        decode_field = ENCODER_MAP["MODE"].field("decode")
        decode = regs.mode.w_data[decode_field.offset:][:decode_field.width]
        count = Mux(decode == Decode.X4, change["a"] ^ change["b"],
                    change["a"] & ~change["b"] & ((decode == Decode.X2) | ~new["b"]))
        bad_config = Signal()
        m.d.sync += [
            self.fb_pos.eq(count & up),
            self.fb_neg.eq(count & ~up),
            self.quad_error.eq((self.quad_error & ~clear) | (change["a"] & change["b"])),
            bad_config.eq((bad_config & ~clear) | regs.filter.w_err | regs.mode.w_err),
        ]
        flags |= {"quad_error": self.quad_error, "bad_config": bad_config}
        m.d.comb += self.line_fault.eq(flags["line_fault_a"] | flags["line_fault_b"])

        for f in ENCODER_MAP["STATUS"].fields:
            m.d.comb += regs.status.r_data[f.offset].eq(flags[f.name])
        m.d.comb += [regs.filter.r_data.eq(regs.filter.w_data),
                     regs.mode.r_data.eq(regs.mode.w_data)]
        return m
