"""The SoC example (examples/soc/): its CPU reads the identity and the registers through the
Wishbone wrapper and runs K3701 blocks."""

from __future__ import annotations

import runpy

from amaranth.sim import Simulator

from k37.hdl.chipset.identity import chipset_identity
from k37.hdl.feed.rates import FA_INCREMENT
from tests.paths import ROOT

SOC_PATH = ROOT / "examples" / "soc" / "soc.py"
soc_example = runpy.run_path(str(SOC_PATH))


def test_the_soc_s_cpu_reads_the_identity_and_registers_and_runs_k3701_blocks():
    soc = soc_example["SoC"]()
    write, read = soc_example["write"], soc_example["read"]
    got = {}

    async def firmware(ctx):
        got["identity"] = await soc_example["identity"](ctx, soc.wb)
        got["fa_inc"] = await read(ctx, soc.wb, "FEED", "FA_INC")
        await write(ctx, soc.wb, "K3702_Y", "POSITION_ZONE", 123_456)
        got["zone"] = await read(ctx, soc.wb, "K3702_Y", "POSITION_ZONE")
        got["blocks"] = [await soc_example["run_block"](ctx, soc, x, y)
                         for x, y in ((40, -25), (-7, 12))]
        got["status"] = await read(ctx, soc.wb, "K3701", "STATUS")
        got["remaining"] = await read(ctx, soc.wb, "K3701", "X")

    sim = Simulator(soc)
    sim.add_clock(1e-6)
    sim.add_testbench(firmware)
    sim.run()
    assert got["identity"] == chipset_identity(**soc_example["CHIPSET"]).encode()
    assert got["fa_inc"] == FA_INCREMENT
    assert got["zone"] == 123_456
    steps = [{k: v for k, v in block.items() if k != "cycles"} for block in got["blocks"]]
    assert steps == [
        {"step_x_pos": 40, "step_x_neg": 0, "step_y_pos": 0, "step_y_neg": 25},
        {"step_x_pos": 0, "step_x_neg": 7, "step_y_pos": 12, "step_y_neg": 0},
    ]
    assert got["status"] == 0 and got["remaining"] == 0   # not busy, no request, no error


def test_the_soc_example_runs_as_a_script(capsys):
    runpy.run_path(str(SOC_PATH), run_name="__main__")
    out = capsys.readouterr().out
    assert "2 axes" in out and "'step_x_pos': 40" in out
