# amaranth: UnusedElaboratable=no
"""The chipset in a small SoC: a Wishbone bus, an address decoder, an identity ROM and the chips.

The SoC's Wishbone bus (9-bit byte addresses, 8-bit data) is the CPU's port; here the
simulation's testbench is the CPU and runs what its firmware would: it reads the ROM's identity
of the chipset, reads registers back through the wrapper, and runs one K3701 linear block,
counting the step pulses the interpolator gives. Memory map::

    0x000-0x0ff  the chipset (k37.hdl.chipset.wishbone.WishboneChipset): chip select << 5 |
                 register address, as k37.hdl.chipset.map.port gives it
    0x100-0x105  identity ROM: protocol version, axes, map fingerprint (4 bytes, LSB first),
                 the bytes a board's bridge answers IDENT with

Run it (Amaranth's simulator, a few seconds)::

    python examples/soc/soc.py
"""

from __future__ import annotations

from amaranth.hdl import Array, Const, Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out, connect, flipped
from amaranth.sim import Simulator

from k37.hdl.bus.wishbone import WishboneBus
from k37.hdl.chipset.chip import AxisPins
from k37.hdl.chipset.identity import chipset_identity
from k37.hdl.chipset.map import chip_register, port
from k37.hdl.chipset.wishbone import WishboneChipset

#: The identity ROM's base address (the chipset takes the 256 bytes below it).
ROM_BASE = 0x100
#: The chipset's parameters: no accel/decel circuit, so a block's FP run at the feed rate at once.
CHIPSET = {"axes": 2, "accel": "none"}


class IdentityRom(wiring.Component):
    """A read-only Wishbone target holding ``data`` (reads past it give 0; writes are ignored).

    Acknowledges in the cycle after the request, as the chipset's target does.
    """

    def __init__(self, data: bytes, addr_width: int = 3):
        self.data = data
        super().__init__({"wb": In(WishboneBus(addr_width))})

    def elaborate(self, platform) -> Module:
        m = Module()
        size = 1 << len(self.wb.adr)
        rom = Array(Const(b, 8) for b in (self.data + bytes(size))[:size])
        ack = Signal()
        m.d.sync += ack.eq(self.wb.cyc & self.wb.stb & ~ack)
        m.d.sync += self.wb.dat_r.eq(rom[self.wb.adr])
        m.d.comb += self.wb.ack.eq(ack & self.wb.cyc & self.wb.stb)
        return m


class SoC(wiring.Component):
    """The CPU's bus decoded to the chipset (``adr[8]`` low) and the identity ROM (high).

    Members
    -------
    wb : In(WishboneBus(9))
        The CPU's bus.
    irq_interp, irq_alarm : Out(1)
        The chipset's interrupts, for the CPU's interrupt controller.
    x, y : Out(AxisPins())
        The axes' pins.
    """

    def __init__(self):
        self.chipset = WishboneChipset(**CHIPSET)
        self.rom = IdentityRom(chipset_identity(**CHIPSET).encode())
        super().__init__({"wb": In(WishboneBus(9)), "irq_interp": Out(1), "irq_alarm": Out(1),
                          "x": Out(AxisPins()), "y": Out(AxisPins())})

    def elaborate(self, platform) -> Module:
        m = Module()
        m.submodules.chipset = chipset = self.chipset
        m.submodules.rom = rom = self.rom
        wb, rom_selected = self.wb, self.wb.adr[8]
        for target, selected in ((chipset.wb, ~rom_selected), (rom.wb, rom_selected)):
            m.d.comb += [target.adr.eq(wb.adr), target.dat_w.eq(wb.dat_w),
                         target.sel.eq(wb.sel), target.we.eq(wb.we),
                         target.cyc.eq(wb.cyc & selected), target.stb.eq(wb.stb & selected)]
        m.d.comb += [wb.ack.eq(chipset.wb.ack | rom.wb.ack),
                     wb.dat_r.eq(Mux(rom_selected, rom.wb.dat_r, chipset.wb.dat_r)),
                     self.irq_interp.eq(chipset.irq_interp),
                     self.irq_alarm.eq(chipset.irq_alarm)]
        for axis in ("x", "y"):
            connect(m, flipped(getattr(self, axis)), getattr(chipset, axis))
        return m


# --- the CPU's side: what its firmware does, as testbench coroutines ------------------------

async def transfer(ctx, wb, addr: int, data: int | None = None) -> int:
    """One Wishbone classic transfer: a write of ``data`` or a read; returns the byte read."""
    ctx.set(wb.adr, addr)
    ctx.set(wb.dat_w, data or 0)
    ctx.set(wb.we, data is not None)
    ctx.set(wb.sel, 1)
    ctx.set(wb.cyc, 1)
    ctx.set(wb.stb, 1)
    for _ in range(16):
        await ctx.tick()
        if ctx.get(wb.ack):
            value = ctx.get(wb.dat_r)
            await ctx.tick()     # the acknowledge ends the transfer at this edge
            ctx.set(wb.cyc, 0)
            ctx.set(wb.stb, 0)
            return value
    raise TimeoutError(f"no acknowledge from {addr:#05x}")


async def write(ctx, wb, chip: str, register: str, value: int) -> None:
    """Write a whole register of ``chip``, LSB first (the last byte commits it)."""
    reg = chip_register(chip, register)
    for k, byte in enumerate(reg.to_bytes(value)):
        await transfer(ctx, wb, port(chip, register, k), byte)


async def read(ctx, wb, chip: str, register: str) -> int:
    """Read a whole register of ``chip``, LSB first (the first byte snapshots it)."""
    reg = chip_register(chip, register)
    return reg.from_bytes([await transfer(ctx, wb, port(chip, register, k))
                           for k in range(reg.nbytes)])


async def identity(ctx, wb) -> bytes:
    """The identity ROM's bytes."""
    return bytes([await transfer(ctx, wb, ROM_BASE + k) for k in range(6)])


async def run_block(ctx, soc: SoC, x: int, y: int, timeout: int = 20_000) -> dict[str, int]:
    """Run one linear K3701 block to (``x``, ``y``) at the full feed rate, until its data
    request; returns the step pulses counted on each of the K3701's outputs and the cycles."""
    wb = soc.wb
    await write(ctx, wb, "K3701", "X", x)
    await write(ctx, wb, "K3701", "Y", y)
    await write(ctx, wb, "K3701", "CTRL", 0)
    await write(ctx, wb, "K3701", "CMD", 1)                 # start
    await write(ctx, wb, "FEED", "RM_INC", (1 << 24) - 1)   # input clock: every cycle
    await write(ctx, wb, "FEED", "FEED", 1 << 13)           # an FP every 32 cycles
    # One FP per step of the longer axis: the gate closes after the block's last FP.
    await write(ctx, wb, "DECEL", "BUDGET", max(abs(x), abs(y)))
    outputs = {f"step_{a}_{s}": getattr(soc.chipset.chipset, f"step_{a}_{s}")
               for a in ("x", "y") for s in ("pos", "neg")}
    steps = dict.fromkeys(outputs, 0)
    for cycle in range(timeout):
        await ctx.tick()
        for name, signal in outputs.items():
            steps[name] += ctx.get(signal)
        if ctx.get(soc.irq_interp):
            await write(ctx, wb, "K3701", "CMD", 2)        # acknowledge the data request
            return {**steps, "cycles": cycle + 1}
    raise TimeoutError(f"the block did not end in {timeout} cycles")


def main() -> None:
    soc = SoC()

    async def firmware(ctx):
        ident = await identity(ctx, soc.wb)
        print(f"identity: version {ident[0]}, {ident[1]} axes, map fingerprint "
              f"{int.from_bytes(ident[2:], 'little'):#010x}")
        print(f"FEED.FA_INC after reset: {await read(ctx, soc.wb, 'FEED', 'FA_INC'):#x}")
        await write(ctx, soc.wb, "K3702_X", "ALARM_ZONE", 2500)
        print(f"K3702_X.ALARM_ZONE written and read back: "
              f"{await read(ctx, soc.wb, 'K3702_X', 'ALARM_ZONE')}")
        result = await run_block(ctx, soc, 40, -25)
        print(f"block (40, -25): {result}")
        print(f"K3701 STATUS after it: {await read(ctx, soc.wb, 'K3701', 'STATUS'):#04x}")

    sim = Simulator(soc)
    sim.add_clock(1e-6)
    sim.add_testbench(firmware)
    sim.run()


if __name__ == "__main__":
    main()
