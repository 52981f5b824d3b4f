"""What the co-simulations of the exported Verilog share: each chip's seeded random stimulus
and its run in Verilator and Icarus against the drivers of :mod:`tests.sim.fpga.chips`, and the
chipset top's stimulus and its run in Amaranth's simulator (which the board and netlist tests
compare against too)."""

from __future__ import annotations

import random
from collections.abc import Iterator

import pytest
from amaranth.hdl import ClockDomain, Module
from amaranth.sim import Simulator

from k37.hdl.bus.registers import RegisterMap
from k37.hdl.chipset.map import CHIP_SELECTS, REG_BITS
from k37.sim.backends.verilator.model import VerilatedModel
from k37.sim.fpga.blocks import block
from k37.sim.fpga.export import pins as export_pins
from k37.sim.fpga.icarus import HOST_DRIVES, find_iverilog
from tests.sim.fpga.chips import CHIPS, CYCLES, BusModel, Chip, Op, built, host_ops


def bus_pins(op: Op, rng: random.Random, regmap: RegisterMap) -> dict[str, int]:
    """The bus pins of one cycle: the host's operation, or an idle bus with random noise."""
    if op is not None:
        kind, addr, data = op
        return {"cs_n": 0, "rd_n": int(kind != "r"), "wr_n": int(kind != "w"), "addr": addr,
                "d": data if kind == "w" else rng.randrange(256)}
    idle = {"addr": rng.randrange(1 << regmap.addr_width), "d": rng.randrange(256)}
    if rng.random() < 0.1:  # selected, no strobe
        return idle | {"cs_n": 0, "rd_n": 1, "wr_n": 1}
    # Not selected: the strobes may be those of another chip.
    strobe = rng.choice(("rd_n", "wr_n", None, None))
    return idle | {"cs_n": 1, "rd_n": int(strobe != "rd_n"), "wr_n": int(strobe != "wr_n")}


def stimulus(chip: Chip, seed: int, cycles: int = CYCLES
             ) -> Iterator[tuple[dict[str, int], dict[str, int]]]:
    """``cycles`` random cycles of ``chip``: the pins driven in each (``rst`` included) and the
    outputs its reference model expects then (``d__en``/``d__out``: the byte it drives on D)."""
    rng = random.Random(seed)
    chip.reset()
    bus = BusModel(chip.regmap) if chip.regmap else None
    ops = host_ops(chip.regmap, chip.value, rng, chip.gap) if bus else None
    reset_at = rng.randrange(cycles // 4, 3 * cycles // 4)
    shown: int | None = None  # the byte the chip drives on D in this cycle
    for t in range(cycles):
        pins = chip.inputs(rng)
        op = next(ops) if ops and t != reset_at else None
        drive = pins | (bus_pins(op, rng, chip.regmap) if bus else {}) | {"rst": int(t == reset_at)}
        commit = bus.write(op[1], op[2]) if bus and op and op[0] == "w" else None
        expected, registers = chip.cycle(pins, commit)
        if bus:
            driving = shown is not None and drive["wr_n"]
            expected["d__en"] = 0xFF if driving else 0
            if driving:
                expected["d__out"] = shown
            shown = bus.read(op[1], registers) if op and op[0] == "r" else None
        yield drive, {name: int(value) for name, value in expected.items()}
        if t == reset_at:
            chip.reset()
            if bus:
                bus.reset()
            shown = None


def cosimulate(chip: Chip, seed: int, cycles: int = CYCLES) -> int:
    """Run ``cycles`` random cycles on the Verilated export and the model; returns checks done."""
    checks = 0
    with VerilatedModel(built(chip.name)) as dut:
        # A power-up reset first, as in Icarus: without it the time-0 falling edge counts
        # the first cycle's inputs in the falling-edge registers.
        dut.set("rst", 1)
        dut.step()
        dut.set("rst", 0)
        for t, (drive, expected) in enumerate(stimulus(chip, seed, cycles)):
            for name, value in drive.items():
                dut.set(name, value)
            got = {name: dut.get(name) for name in expected}
            assert got == expected, (f"{chip.name} seed {seed} cycle {t}: Verilog {got} != "
                                     f"model {expected}")
            checks += len(expected)
            dut.step()
    return checks


needs_icarus = pytest.mark.skipif(find_iverilog() is None,
                                  reason="Icarus Verilog is not installed (Debian: apt-get "
                                         "install iverilog); the exported Verilog is not checked "
                                         "in Icarus here")


def icarus_rows(chip: Chip, seed: int, cycles: int
                ) -> tuple[list[dict[str, int]], list[dict[str, int]]]:
    """The stimulus as Icarus's rows (the host drives D where the chip does not) and the
    outputs expected on the wrapper's pins, D being whoever drives it; first a power-up reset
    cycle, expecting nothing."""
    rows, expect = [{"rst": 1}], [{}]
    for drive, expected in stimulus(chip, seed, cycles):
        chip_drives = expected.pop("d__en", 0)
        shown = expected.pop("d__out", None)
        if chip.regmap:
            drive = drive | {HOST_DRIVES: int(not chip_drives)}
            expected["d"] = shown if chip_drives else drive["d"]
        rows.append(drive)
        expect.append(expected)
    return rows, expect


def chipset_stimulus(seed: int, cycles: int) -> list[dict[str, int]]:
    """Random pins of the chipset: bus traffic to every chip (blocks with small moves, started
    and acknowledged), turning encoders, one reset."""
    rng = random.Random(seed)
    traffic = []
    for select, regmap in CHIP_SELECTS.values():
        chip = next(c() for c in CHIPS.values() if c.regmap is regmap)
        traffic.append((select, host_ops(regmap, chip.value, rng, 10)))
    phase = {"x": 0, "y": 0}
    reset_at = rng.randrange(cycles // 4, 3 * cycles // 4)
    rows = []
    select, ops = traffic[0]
    for t in range(cycles):
        op = next(ops) if t != reset_at else None
        if op is None and rng.random() < 0.1:  # between operations: another chip's turn
            select, ops = rng.choice(traffic)
        pins = bus_pins(op, rng, CHIP_SELECTS["K3701"][1])
        pins["addr"] = select << REG_BITS | op[1] if op else rng.randrange(256)
        for axis in phase:
            phase[axis] = (phase[axis] + rng.choice((-1, 0, 0, 1))) % 4
            a, b = (0, 1, 1, 0)[phase[axis]], (0, 0, 1, 1)[phase[axis]]
            pins |= {f"{axis}_a": a, f"{axis}_a_n": 1 - a, f"{axis}_b": b, f"{axis}_b_n": 1 - b}
        rows.append(pins | {"rst": int(t in (0, reset_at))})
    return rows


def drive_bus(ctx, bus, row: dict[str, int]) -> bool:
    """Put a stimulus row's chip pins (``cs_n``, ``rd_n``, ``wr_n``, ``addr``, ``d``) on a
    chip-style host ``bus``: its strobes as the pins select, the written byte from ``d``;
    whether the row reads."""
    read = not (row["cs_n"] or row["rd_n"])
    ctx.set(bus.addr, row["addr"])
    ctx.set(bus.w_data, row["d"])
    ctx.set(bus.w_stb, not (row["cs_n"] or row["wr_n"]))
    ctx.set(bus.r_stb, read)
    return read


def amaranth_chipset(rows: list[dict[str, int]]) -> list[dict[str, int]]:
    """The chipset's wrapper pins per cycle as Amaranth's simulator computes them from the
    core (the same component the export converts), the wrapper's D logic written out."""
    dut = block("chipset").component()
    pins = [p for p in export_pins("chipset") if p.direction == "output"]
    seen: list[dict[str, int]] = []

    async def bench(ctx):
        d_oe = 0
        for row in rows:
            read = drive_bus(ctx, dut.bus, row)
            for axis in ("x", "y"):
                group = getattr(dut, axis)
                for line in ("a", "a_n", "b", "b_n"):
                    ctx.set(getattr(group, line), row[f"{axis}_{line}"])
            ctx.set(dut_rst, row["rst"])
            out = {p.name: ctx.get(core_port(dut, p.name)) for p in pins}
            chip_drives = d_oe and row["wr_n"]
            out["d"] = ctx.get(dut.bus.r_data) if chip_drives else row["d"]
            seen.append(out | {HOST_DRIVES: int(not chip_drives)})
            d_oe = int(not row["rst"] and read)
            await ctx.tick()

    top = Module()
    top.domains.sync = sync = ClockDomain("sync")
    top.submodules.dut = dut
    dut_rst = sync.rst
    sim = Simulator(top)
    sim.add_clock(1e-6)
    sim.add_testbench(bench)
    sim.run()
    return seen


def core_port(dut, pin: str):
    """The core signal behind a wrapper output pin (``x_dac`` -> ``dut.x.dac``)."""
    if "_" in pin and pin.split("_", 1)[0] in ("x", "y"):
        axis, name = pin.split("_", 1)
        return getattr(getattr(dut, axis), name)
    return getattr(dut, pin)
