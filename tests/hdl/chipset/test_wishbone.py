"""The chipset behind its Wishbone classic target behaves as the chipset on its own host bus."""

from __future__ import annotations

from amaranth.hdl import Module
from hypothesis import given, settings
from hypothesis import strategies as st

from k37.hdl.bus.wishbone import WishboneBus, WishboneTarget
from k37.hdl.chipset.chip import Chipset
from k37.hdl.chipset.map import chip_selects, port
from k37.hdl.chipset.wishbone import WishboneChipset
from tests.testbench import simulate

#: Every register byte's address of the two-axis chipset, and whether it is writable.
BYTES = [(port(chip, reg.name, k), reg.access.writable)
         for chip, (_, regmap) in chip_selects(2).items() for reg in regmap
         for k in range(reg.nbytes)]

#: One bus operation: ("w", addr, data), ("r", addr, 0), ("unselected", addr, data) (a transfer
#: with sel low) or ("idle", 0, 0) (no cycle).
OPS = st.one_of(
    st.sampled_from([a for a, writable in BYTES if writable]).flatmap(
        lambda a: st.tuples(st.just("w"), st.just(a), st.integers(0, 255))),
    st.tuples(st.just("r"), st.sampled_from([a for a, _ in BYTES]) | st.integers(0, 255),
              st.just(0)),
    st.tuples(st.just("unselected"), st.integers(0, 255), st.integers(0, 255)),
    st.tuples(st.just("idle"), st.just(0), st.just(0)),
)


def _outputs(chipset: Chipset) -> list:
    """What the chipset shows outside its bus: interrupts, step pulses, the axes' ports."""
    axes = [getattr(getattr(chipset, axis), name) for axis in chipset.axes
            for name in ("dac", "alarm_n", "com_pos", "com_neg", "command", "error")]
    steps = [getattr(chipset, f"step_{axis}_{sign}") for axis in chipset.axes
             for sign in ("pos", "neg")]
    return [chipset.irq_interp, chipset.irq_alarm, chipset.fp, *steps, *axes]


def _run_side_by_side(ops: list[tuple[str, int, int]]) -> list[tuple[int, int]]:
    """Each op as a Wishbone transfer to a wrapped chipset and, in the same cycles, as the
    host-bus access it stands for to a chipset of its own; every output is compared in every
    cycle. Returns (wrapped, direct) read bytes."""
    direct, wrapped = Chipset(), WishboneChipset()
    m = Module()
    m.submodules.direct, m.submodules.wrapped = direct, wrapped
    wb, bus = wrapped.wb, direct.bus
    pairs = list(zip(_outputs(wrapped.chipset), _outputs(direct), strict=True))
    reads = []

    async def bench(ctx):
        async def tick():
            await ctx.tick()
            for a, b in pairs:
                assert ctx.get(a) == ctx.get(b), f"{a.name} after {ops}"

        for kind, addr, data in ops:
            if kind == "idle":
                await tick()
                continue
            ctx.set(wb.adr, addr)
            ctx.set(wb.dat_w, data)
            ctx.set(wb.we, kind != "r")
            ctx.set(wb.sel, kind != "unselected")
            ctx.set(wb.cyc, 1)
            ctx.set(wb.stb, 1)
            ctx.set(bus.addr, addr)
            ctx.set(bus.w_data, data)
            ctx.set(bus.w_stb, kind == "w")
            ctx.set(bus.r_stb, kind == "r")
            assert not ctx.get(wb.ack)
            await tick()
            ctx.set(bus.w_stb, 0)
            ctx.set(bus.r_stb, 0)
            assert ctx.get(wb.ack)       # the acknowledge, cyc and stb still high
            if kind == "r":
                reads.append((ctx.get(wb.dat_r), ctx.get(bus.r_data)))
            await tick()
            ctx.set(wb.cyc, 0)
            ctx.set(wb.stb, 0)
        await tick()

    simulate(m, bench, name="wishbone_side_by_side")
    return reads


def test_register_accesses_through_the_wrapper_match_the_chipset_on_its_own_bus():
    zone = port("K3702_X", "ALARM_ZONE")
    ops = [("w", zone, 0xC4), ("w", zone + 1, 0x09), ("w", zone + 2, 0),
           ("r", zone, 0), ("r", zone + 1, 0), ("r", zone + 2, 0),
           ("r", port("FEED", "FA_INC"), 0), ("unselected", zone, 0x55), ("r", zone, 0)]
    reads = _run_side_by_side(ops)
    assert [w for w, _ in reads] == [0xC4, 0x09, 0, 0x47, 0xC4]
    assert all(w == d for w, d in reads)


@settings(max_examples=12, deadline=None, derandomize=True)
@given(st.lists(OPS, min_size=1, max_size=40))
def test_random_register_access_sequences_read_the_same_through_the_wrapper(ops):
    for wrapped, direct in _run_side_by_side(ops):
        assert wrapped == direct


def test_a_transfer_held_over_its_acknowledge_is_made_once_and_dropped_strobes_get_no_ack():
    dut = WishboneTarget(8)
    seen = []

    async def bench(ctx):
        wb, bus = dut.wb, dut.bus
        ctx.set(bus.r_data, 0x5A)
        ctx.set(wb.adr, 0x21)
        ctx.set(wb.dat_w, 0x33)
        for we, sel, stb_cycles in ((1, 1, 6), (0, 1, 2), (1, 0, 2), (1, 1, 1)):
            ctx.set(wb.we, we)
            ctx.set(wb.sel, sel)
            ctx.set(wb.cyc, 1)
            for _ in range(stb_cycles):
                ctx.set(wb.stb, 1)
                seen.append((ctx.get(bus.w_stb), ctx.get(bus.r_stb), ctx.get(wb.ack),
                             ctx.get(wb.dat_r)))
                await ctx.tick()
            ctx.set(wb.stb, 0)
            ctx.set(wb.cyc, 0)
            seen.append((ctx.get(bus.w_stb), ctx.get(bus.r_stb), ctx.get(wb.ack), None))
            await ctx.tick()

    simulate(dut, bench)
    write, read, ack = (1, 0, 0, 0x5A), (0, 1, 0, 0x5A), (0, 0, 1, 0x5A)
    idle = (0, 0, 0, None)
    assert seen == [
        write, ack, write, ack, write, ack, idle,     # stb held: one write per two cycles
        read, ack, idle,
        (0, 0, 0, 0x5A), ack, idle,                   # sel low: acknowledged, no access
        write, idle,                                  # stb dropped after one cycle: no ack
    ]


def test_the_wishbone_bus_has_amaranth_soc_s_member_names_and_directions():
    members = {name: (m.flow.name, m.shape) for name, m in WishboneBus(9).members.items()}
    assert members == {"adr": ("Out", 9), "dat_w": ("Out", 8), "dat_r": ("In", 8),
                       "sel": ("Out", 1), "cyc": ("Out", 1), "stb": ("Out", 1),
                       "we": ("Out", 1), "ack": ("In", 1)}
