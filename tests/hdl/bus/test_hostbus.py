"""The shared host interface: atomic multi-byte writes, snapshot reads, the register table."""

import pytest
from amaranth.hdl import Module
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out, connect, flipped

from k37.hdl.bus.hostbus import HostBus, RegisterBank
from k37.hdl.bus.registers import Access, Field, Register, RegisterMap
from tests.testbench import bus_read, bus_write, read_reg, simulate, write_reg

MAP = RegisterMap("TEST", 1, (
    Register("VALUE", 0x0, 24, Access.RW, "24-bit value; reads back a running counter",
             signed=True),
    Register("CTRL", 0x3, 8, Access.W, "control",
             fields=(Field("go", 0), Field("mode", 1, 2))),
    Register("STATUS", 0x4, 8, Access.R, "status"),
))


class Counted(wiring.Component):
    """A running counter readable through VALUE; VALUE writes reload it."""

    bus: In(HostBus(MAP.addr_width))
    count: Out(24)
    loads: Out(8)

    def elaborate(self, platform):
        m = Module()
        m.submodules.regs = regs = RegisterBank(MAP)
        connect(m, flipped(self.bus), regs.bus)
        m.d.sync += self.count.eq(self.count + 1)
        with m.If(regs.value.w_stb):
            m.d.sync += [self.count.eq(regs.value.w_data), self.loads.eq(self.loads + 1)]
        m.d.comb += [regs.value.r_data.eq(self.count), regs.status.r_data.eq(0xA5)]
        return m


def test_multi_byte_write_takes_effect_on_its_last_byte():
    dut = Counted()

    async def bench(ctx):
        reg = MAP["VALUE"]
        for k, byte in enumerate(reg.to_bytes(0x123456)):
            await bus_write(ctx, dut.bus, reg.addr + k, byte)
            if k < reg.nbytes - 1:
                assert ctx.get(dut.loads) == 0
        # The bank shows the value (w_stb) in the cycle after the committing write; the
        # counter takes it at the end of that cycle.
        assert ctx.get(dut.loads) == 0
        await ctx.tick()
        assert ctx.get(dut.loads) == 1
        assert ctx.get(dut.count) == 0x123456

    simulate(dut, bench)


def test_counter_read_byte_by_byte_is_never_torn():
    dut = Counted()
    reg = MAP["VALUE"]

    async def bench(ctx):
        # Park the counter just below a byte-carry chain, then read it while it crosses.
        for start in (0x00FFFD, 0x7FFFFE, -3):
            await write_reg(ctx, dut.bus, reg, start)
            snapshot_cycle_value = ctx.get(dut.count)
            value = await read_reg(ctx, dut.bus, reg)
            raw = value & 0xFFFFFF
            # The snapshot is the counter's value in the cycle byte 0 was read.
            assert raw == snapshot_cycle_value & 0xFFFFFF

    simulate(dut, bench)


def test_unmapped_and_write_only_reads_return_zero():
    dut = Counted()

    async def bench(ctx):
        assert await bus_read(ctx, dut.bus, MAP["CTRL"].addr) == 0
        assert await bus_read(ctx, dut.bus, 0x7) == 0
        assert await bus_read(ctx, dut.bus, MAP["STATUS"].addr) == 0xA5

    simulate(dut, bench)


def test_register_value_out_of_range_is_refused_by_name():
    with pytest.raises(ValueError, match="register VALUE: 8388608 is outside"):
        MAP["VALUE"].to_bytes(1 << 23)
    with pytest.raises(ValueError, match="field mode is 2 bit"):
        MAP["CTRL"].encode(mode=4)


def test_overlapping_registers_are_refused():
    with pytest.raises(ValueError, match="B overlaps A at 0x1"):
        RegisterMap("BAD", 1, (Register("A", 0, 16, Access.R, ""),
                               Register("B", 1, 8, Access.R, "")))


def test_markdown_lists_every_register_and_field():
    text = MAP.markdown()
    for name in ("VALUE", "CTRL", "STATUS", "go", "mode"):
        assert name in text
    assert "0x00-0x02" in text


def test_signed_round_trip():
    reg = MAP["VALUE"]
    for v in (-(1 << 23), -1, 0, 1, (1 << 23) - 1):
        assert reg.from_bytes(reg.to_bytes(v)) == v


def test_hostbus_signature_is_value_compared():
    assert HostBus(4) == HostBus(4)
    assert HostBus(4) != HostBus(5)
    with pytest.raises(TypeError, match="positive integer"):
        HostBus(0)


CHECKED = RegisterMap("CHECKED", 1, (
    Register("N", 0x0, 8, Access.RW, "a width 8..16", init=12, valid=(8, 16)),
))


class Checked(wiring.Component):
    """Exposes the N register's port."""

    bus: In(HostBus(CHECKED.addr_width))
    value: Out(8)
    rejected: Out(8)

    def elaborate(self, platform):
        m = Module()
        m.submodules.regs = regs = RegisterBank(CHECKED)
        connect(m, flipped(self.bus), regs.bus)
        m.d.comb += [self.value.eq(regs.n.w_data), regs.n.r_data.eq(regs.n.w_data)]
        with m.If(regs.n.w_err):
            m.d.sync += self.rejected.eq(self.rejected + 1)
        return m


def test_register_holds_its_reset_value_and_ignores_writes_outside_its_valid_range():
    dut = Checked()
    reg = CHECKED["N"]

    async def bench(ctx):
        assert ctx.get(dut.value) == 12
        await bus_write(ctx, dut.bus, reg.addr, 17)   # out of range: ignored, w_err
        await ctx.tick()
        assert ctx.get(dut.value) == 12
        assert ctx.get(dut.rejected) == 1
        await write_reg(ctx, dut.bus, reg, 16)
        await ctx.tick()
        assert ctx.get(dut.value) == 16
        assert ctx.get(dut.rejected) == 1
        assert await read_reg(ctx, dut.bus, reg) == 16

    simulate(dut, bench)
    with pytest.raises(ValueError, match=r"register N: 7 is outside 8\.\.16"):
        reg.to_bytes(7)
    with pytest.raises(ValueError, match=r"init must be in 8\.\.16"):
        Register("M", 0, 8, Access.RW, "", init=0, valid=(8, 16))
