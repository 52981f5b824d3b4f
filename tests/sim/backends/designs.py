# amaranth: UnusedElaboratable=no
"""Small designs for the backends' tests: blocks that exercise what the compiled backend must
get right (a register bank on the host bus, a falling-edge domain, signed and wide ports, a
24-bit up/down counter, a phase accumulator, a sequencer, a bit chain), the :class:`Zoo` that
holds any of them as submodules, and a design with no clock (:class:`Combinational`)."""

from amaranth.hdl import Cat, ClockDomain, ClockSignal, Module, Signal, signed
from amaranth.lib import data, wiring
from amaranth.lib.wiring import In, Out, connect, flipped

from k37.hdl.bus.hostbus import HostBus, RegisterBank
from k37.hdl.bus.registers import Access, Register, RegisterMap

MAP = RegisterMap("ZOO", 1, (
    Register("VALUE", 0x0, 24, Access.RW, "a signed value; reads back", signed=True),
    Register("SCALE", 0x3, 16, Access.W, "a write-only value"),
    Register("COMMITS", 0x5, 8, Access.R, "number of committed writes"),
))


class RegisterFile(wiring.Component):
    """Registers of :data:`MAP` on the host bus, exposing their values.

    Members
    -------
    bus : In(HostBus)
        The host bus.
    value : Out(signed(24))
        VALUE as last written, from the cycle after its committing byte.
    scale : Out(16)
        SCALE as last written, likewise.
    """

    bus: In(HostBus(MAP.addr_width))
    value: Out(signed(24))
    scale: Out(16)

    def elaborate(self, platform):
        m = Module()
        m.submodules.regs = regs = RegisterBank(MAP)
        connect(m, flipped(self.bus), regs.bus)
        commits = Signal(8)
        with m.If(regs.value.w_stb | regs.scale.w_stb):
            m.d.sync += commits.eq(commits + 1)
        m.d.comb += [self.value.eq(regs.value.w_data), self.scale.eq(regs.scale.w_data),
                     regs.value.r_data.eq(regs.value.w_data), regs.commits.r_data.eq(commits)]
        return m


class NegCounter(wiring.Component):
    """Counts enabled rising edges, and enabled falling edges in a local negedge domain.

    Members
    -------
    en : In(1)
        Count enable, sampled on both edges.
    pos, neg : Out(8)
        Enabled rising and falling edges so far (registered).
    total : Out(9)
        ``pos + neg`` (combinational).
    """

    en: In(1)
    pos: Out(8)
    neg: Out(8)
    total: Out(9)

    def elaborate(self, platform):
        m = Module()
        m.domains.fall = ClockDomain(local=True, clk_edge="neg")
        m.d.comb += ClockSignal("fall").eq(ClockSignal())
        with m.If(self.en):
            m.d.sync += self.pos.eq(self.pos + 1)
            m.d.fall += self.neg.eq(self.neg + 1)
        m.d.comb += self.total.eq(self.pos + self.neg)
        return m


class SignedMath(wiring.Component):
    """Signed arithmetic and a port wider than 64 bits.

    Members
    -------
    a : In(signed(12))
    b : In(signed(5))
    prod : Out(signed(17))
        ``a * b`` (combinational).
    acc : Out(signed(20))
        Running sum of ``prod`` (registered, wraps).
    wide : In(72)
    wide_next : Out(72)
        ``wide + 1`` (registered, wraps).
    """

    a: In(signed(12))
    b: In(signed(5))
    prod: Out(signed(17))
    acc: Out(signed(20))
    wide: In(72)
    wide_next: Out(72)

    def elaborate(self, platform):
        m = Module()
        m.d.comb += self.prod.eq(self.a * self.b)
        m.d.sync += [self.acc.eq(self.acc + self.prod), self.wide_next.eq(self.wide + 1)]
        return m


class UpDown24(wiring.Component):
    """A 24-bit up/down counter with a load, wrapping both ways.

    Members
    -------
    up, down : In(1)
        Count by +1 / -1 (both: no change), from the next cycle.
    load : In(1)
        Load ``load_value`` instead (has priority).
    load_value : In(24)
    count : Out(24)
        The count (registered).
    zero : Out(1)
        ``count == 0`` (combinational).
    """

    up: In(1)
    down: In(1)
    load: In(1)
    load_value: In(24, init=0x123456)
    count: Out(24)
    zero: Out(1)

    def elaborate(self, platform):
        m = Module()
        with m.If(self.load):
            m.d.sync += self.count.eq(self.load_value)
        with m.Elif(self.up & ~self.down):
            m.d.sync += self.count.eq(self.count + 1)
        with m.Elif(self.down & ~self.up):
            m.d.sync += self.count.eq(self.count - 1)
        m.d.comb += self.zero.eq(self.count == 0)
        return m


class PhaseAccumulator(wiring.Component):
    """A divider: a 16-bit phase grows by ``inc`` each cycle; its carry is the output pulse.

    Members
    -------
    inc : In(16)
        Phase increment: ``pulse`` averages ``inc / 2**16`` per cycle.
    pulse : Out(1)
        High for the cycle after each carry.
    """

    inc: In(16)
    pulse: Out(1)

    def elaborate(self, platform):
        m = Module()
        phase = Signal(16)
        m.d.sync += Cat(phase, self.pulse).eq(phase + self.inc)
        return m


class Sequencer(wiring.Component):
    """An FSM with a structured port: runs ``cfg.length`` + 1 busy cycles per start.

    Members
    -------
    cfg : In(StructLayout(length=4, again=1))
        Busy length, and whether to restart at once after the done cycle.
    start : In(1)
        Starts a run from idle (sampled on the rising edge).
    busy : Out(1)
        High while running (from the cycle after ``start``).
    done : Out(1)
        High for one cycle after a run.
    """

    cfg: In(data.StructLayout({"length": 4, "again": 1}))
    start: In(1)
    busy: Out(1)
    done: Out(1)

    def elaborate(self, platform):
        m = Module()
        left = Signal(4)
        with m.FSM():
            with m.State("Idle"):
                with m.If(self.start):
                    m.d.sync += left.eq(self.cfg.length)
                    m.next = "Run"
            with m.State("Run"):
                m.d.comb += self.busy.eq(1)
                m.d.sync += left.eq(left - 1)
                with m.If(left == 0):
                    m.next = "Done"
            with m.State("Done"):
                m.d.comb += self.done.eq(1)
                m.next = "Idle"
                with m.If(self.cfg.again):
                    m.d.sync += left.eq(self.cfg.length)
                    m.next = "Run"
        return m


class BitChain(wiring.Component):
    """Bits of one signal computed from each other: no loop for Amaranth, but a feedback wire
    for CXXRTL, which then needs several delta cycles per edge.

    Members
    -------
    x : In(1)
    en : In(1)
        Update the register from the chain.
    y : Out(4)
        The chain XOR the register it feeds.
    """

    x: In(1)
    en: In(1)
    y: Out(4)

    def elaborate(self, platform):
        m = Module()
        chain, state = Signal(4), Signal(4)
        m.d.comb += [chain[0].eq(self.x ^ state[3]), chain[1].eq(chain[0] ^ state[0]),
                     chain[2].eq(chain[1]), chain[3].eq(chain[2] & state[1]),
                     self.y.eq(state ^ chain)]
        with m.If(self.en):
            m.d.sync += state.eq(Cat(chain[3], state[:3]) + chain)
        return m


BLOCKS = {"bank": RegisterFile, "negc": NegCounter, "math": SignedMath, "updown": UpDown24,
          "phase": PhaseAccumulator, "seq": Sequencer, "chain": BitChain}


class Zoo(wiring.Component):
    """Test blocks as submodules, their ports forwarded as ``<block>__<port>``."""

    def __init__(self, blocks: tuple[str, ...] = tuple(BLOCKS)):
        self._blocks = {name: BLOCKS[name]() for name in blocks}
        super().__init__({name: Out(block.signature) for name, block in self._blocks.items()})

    def elaborate(self, platform):
        m = Module()
        for name, block in self._blocks.items():
            m.submodules[name] = block
            connect(m, flipped(getattr(self, name)), block)
        return m


class Combinational(wiring.Component):
    """No clock at all."""

    a: In(4)
    b: Out(4)

    def elaborate(self, platform):
        m = Module()
        m.d.comb += self.b.eq(self.a + 1)
        return m
