# amaranth: UnusedElaboratable=no
"""The board's gateware: the sigma-delta D/A against its model, the chipset at one cycle in
``clock_hz / 1 MHz`` against the chipset at its own clock, the UART bridge on the board's pins,
the pin map and the build plan."""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from k37.hdl.board.core import BoardCore
from k37.hdl.board.model.sigma_delta import SigmaDeltaModel
from k37.hdl.board.pins import ulx3s_pins
from k37.hdl.board.sigma_delta import SigmaDelta
from k37.hdl.board.top import BoardTop
from k37.hdl.bridge.protocol import OK, Op, encode, stuff
from k37.hdl.chipset.identity import chipset_identity
from k37.hdl.common.constants import CHIP_HZ
from k37.sim.fpga.export import pins as export_pins
from k37.sim.fpga.icarus import HOST_DRIVES
from tests.sim.fpga.chips import SEEDS
from tests.sim.fpga.cosim import amaranth_chipset, chipset_stimulus, core_port, drive_bus
from tests.testbench import simulate

needs_boards = pytest.mark.skipif(importlib.util.find_spec("amaranth_boards") is None,
                                  reason="amaranth-boards (the fpga extra) is not installed")


# --- sigma-delta D/A -----------------------------------------------------------------------

@settings(max_examples=20, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 0xFFFF), st.integers(1, 40)), min_size=1,
                max_size=12))
def test_sigma_delta_matches_its_model_cycle_by_cycle(runs):
    words = [word for word, n in runs for _ in range(n)]
    dut, model, seen = SigmaDelta(), SigmaDeltaModel(), []

    async def bench(ctx):
        for word in words:
            ctx.set(dut.word, word)
            seen.append((ctx.get(dut.out), model.step(word)))
            await ctx.tick()

    simulate(dut, bench)
    assert [got for got, _ in seen] == [want for _, want in seen]


@pytest.mark.parametrize("word", [0, 1, 0x4000, 0x8000, 0xC123, 0xFFFF])
def test_sigma_delta_mean_is_the_word_over_two_to_the_width(word):
    model = SigmaDeltaModel()
    cycles = 1 << 16
    ones = sum(model.step(word) for _ in range(cycles + 1))
    assert ones == word  # floor(cycles * word / 2**16), the first cycle's bit being 0


def test_sigma_delta_model_refuses_a_word_out_of_range():
    with pytest.raises(ValueError, match=r"word must be in 0\.\.65535, not 65536"):
        SigmaDeltaModel().step(1 << 16)


# --- the chipset under its clock enable -----------------------------------------------------

@pytest.mark.parametrize(("clock_hz", "match"), [
    (1_500_000, "multiple of 1000000"), (CHIP_HZ, "at least twice"), (0, "at least 1")])
def test_a_board_clock_that_is_no_multiple_of_the_chipset_clock_is_refused(clock_hz, match):
    with pytest.raises(ValueError, match=match):
        BoardCore(clock_hz=clock_hz)


def test_the_chipset_on_a_board_clock_matches_the_chipset_on_its_own_cycle_by_cycle():
    """A board clock 3x the chipset's: each chipset cycle's pins held for 3 board cycles, the
    chipset's outputs read in the tick cycle equal the chipset's own in that cycle."""
    ratio, cycles = 3, 500
    rows = chipset_stimulus(SEEDS[0], cycles)
    for row in rows[1:]:
        row["rst"] = 0   # the power-up state is the reset state; the board is not reset
    expect = amaranth_chipset(rows)
    dut = BoardCore(axes=2, clock_hz=ratio * CHIP_HZ)
    chip = dut.chipset
    outputs = [p.name for p in export_pins("chipset") if p.direction == "output"]
    seen, ticks = [], []

    async def bench(ctx):
        for row in rows:
            drive_bus(ctx, dut.bus, row)
            for axis in ("x", "y"):
                ctx.set(getattr(dut, f"{axis}_a"), row[f"{axis}_a"])
                ctx.set(getattr(dut, f"{axis}_b"), row[f"{axis}_b"])
            for _ in range(ratio):
                ticks.append(ctx.get(dut.tick))
                if ticks[-1]:
                    got = {name: ctx.get(core_port(chip, name)) for name in outputs}
                    got["r_data"] = ctx.get(dut.bus.r_data)
                    got["x_alarm"], got["irq"] = ctx.get(dut.x_alarm), ctx.get(dut.irq_alarm)
                    seen.append(got)
                await ctx.tick()

    simulate(dut, bench)
    assert ticks == [0] * (ratio - 1) + [1] + ([0] * (ratio - 1) + [1]) * (cycles - 1)
    moving, reads = set(), 0
    for t, (got, want) in enumerate(zip(seen, expect, strict=True)):
        if not want[HOST_DRIVES]:   # the chipset drives D: its byte is r_data
            assert got["r_data"] == want["d"], f"cycle {t}"
            reads += 1
        assert {k: got[k] for k in outputs} == {k: want[k] for k in outputs}, f"cycle {t}"
        assert (got["x_alarm"], got["irq"]) == (1 - want["x_alarm_n"], want["irq_alarm"])
        moving |= {k for k in outputs if want[k] != expect[0][k]}
    assert {"x_dac", "y_dac"} <= moving and reads > 20   # the stimulus exercises them


# --- the board's top: pins and bridge -------------------------------------------------------

def test_every_pin_of_the_map_is_a_port_of_the_top_and_each_has_one_place():
    for axes in (2, 3):
        pins = ulx3s_pins(axes)
        top = BoardTop(pins, axes=axes)
        assert {p.signal for p in pins} - {"reset"} == set(top.signature.members)
        places = [p.connector_pin or p.resource for p in pins]
        shared = [p for p in places if places.count(p) > 1]
        assert shared == [("uart", 0), ("uart", 0)]   # rx and tx of the one UART


def test_a_top_missing_a_pin_is_refused():
    with pytest.raises(ValueError, match=r"missing \['z_dac'\]"):
        BoardTop(tuple(p for p in ulx3s_pins(3) if p.signal != "z_dac"), axes=3)
    with pytest.raises(ValueError, match="baud must divide 1000000"):
        BoardTop(ulx3s_pins(3), axes=3, baud=115_200)


@pytest.mark.slow
def test_the_host_identifies_the_chipset_through_the_boards_uart_pins():
    ratio = 4  # a 4 MHz board clock keeps the simulation short; 25 MHz differs only in ratio
    top = BoardTop(ulx3s_pins(2), axes=2, clock_hz=ratio * CHIP_HZ)
    bit = ratio * top.bridge.cycles_per_bit
    reply = []
    expected = stuff(bytes([OK, 0]) + chipset_identity(axes=2).encode())

    async def bench(ctx):
        ctx.set(top.uart_rx, 1)
        await ctx.tick().repeat(bit)
        for byte in encode(Op.IDENT):
            for level in [0, *((byte >> k) & 1 for k in range(8)), 1]:
                ctx.set(top.uart_rx, level)
                await ctx.tick().repeat(bit)
        for _ in range(len(expected)):
            waited = 0
            while ctx.get(top.uart_tx):
                await ctx.tick()
                waited += 1
                assert waited < 40 * bit, f"no reply byte after {bytes(reply)!r}"
            await ctx.tick().repeat(bit // 2)
            byte = 0
            for k in range(8):
                await ctx.tick().repeat(bit)
                byte |= ctx.get(top.uart_tx) << k
            await ctx.tick().repeat(bit)
            assert ctx.get(top.uart_tx) == 1, "stop bit"
            reply.append(byte)

    simulate(top, bench)
    assert bytes(reply) == expected


# --- the build plan -------------------------------------------------------------------------

@needs_boards
@pytest.mark.slow
def test_the_build_plan_places_every_pin_and_constrains_the_board_clock(tmp_path):
    from k37.sim.fpga.build import build

    report = build("ulx3s-25f", tmp_path, plan_only=True, progress=lambda _: None)
    name = report.name
    assert name == "k37_ulx3s_25f_3axis"
    for suffix in (".il", ".lpf", ".ys"):
        assert (tmp_path / f"{name}{suffix}").stat().st_size > 0
    assert (tmp_path / f"build_{name}.sh").exists()
    lpf = (tmp_path / f"{name}.lpf").read_text()
    assert 'FREQUENCY PORT "clk25_0__io" 25000000.0 HZ;' in lpf
    table = (tmp_path / "pins.md").read_text()
    rows = [line for line in table.splitlines() if line.startswith("| `")]
    assert len(rows) == len(ulx3s_pins(3))
    balls = [re.split(r"\s*\|\s*", row)[4] for row in rows]
    assert all(re.fullmatch(r"[A-Y]\d{1,2}", ball) for ball in balls)
    assert "z_dac" in table and "Build plan only" in (tmp_path / "report.md").read_text()


def test_the_two_and_three_axis_builds_of_a_board_have_distinct_names():
    from k37.sim.fpga.build import design_name

    names = {design_name(board, axes) for board in ("ulx3s-25f", "ulx3s-85f") for axes in (2, 3)}
    assert names == {"k37_ulx3s_25f_2axis", "k37_ulx3s_25f_3axis", "k37_ulx3s_85f_2axis",
                     "k37_ulx3s_85f_3axis"}


def _k37(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "k37.sim.cli", *args], capture_output=True,
                          text=True, env=env, check=False)


def test_build_refuses_an_unwritable_folder_and_names_the_missing_extra(tmp_path):
    blocked = tmp_path / "file"
    blocked.write_text("")
    done = _k37("build", "--board", "ulx3s-25f", "--out", str(blocked / "sub"))
    assert done.returncode == 2
    assert done.stderr.startswith("k37: error: --out") and "Traceback" not in done.stderr
    env = {**os.environ, "PATH": str(tmp_path)}   # no tool anywhere
    done = _k37("build", "--board", "ulx3s-25f", "--out", str(tmp_path / "b"), env=env)
    assert done.returncode == 2
    assert "needs the fpga extra (pip install -e '.[fpga]')" in done.stderr
    assert "Traceback" not in done.stderr


def test_synth_without_its_tools_says_so_in_one_line_and_exits_2(tmp_path):
    env = {**os.environ, "PATH": str(tmp_path)}   # no tool anywhere
    done = _k37("synth", "--block", "divider", env=env)
    assert done.returncode == 2
    assert done.stderr.startswith("k37: error: synthesis needs the fpga extra "
                                  "(pip install -e '.[fpga]'): yosys is not installed")
    assert len(done.stderr.splitlines()) == 1


@needs_boards
def test_every_board_k37_builds_has_its_platform_and_part():
    from k37.hdl.board.ulx3s import PLATFORMS
    from k37.sim.fpga.build import BOARDS

    assert {board: platform.device for board, platform in PLATFORMS.items()} == BOARDS
