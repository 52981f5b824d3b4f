"""Waveforms: a third-party reader (pywellen, the library behind Surfer) opens the VCD, with
a scope per chip, and the GTKWave save file names signals that exist in it."""

from __future__ import annotations

import pytest
import pywellen

from firmware_model.job import demo_job
from sim.run.output import write_gtkw
from sim.run.runner import RunOptions, run_job

CHIP_SCOPES = ("k3701", "k3702_x", "k3702_y", "encoder_x", "encoder_y", "feed", "decel",
               "accel")


@pytest.mark.parametrize("backend", ["pysim", "cxxrtl"])
def test_vcd_opens_in_pywellen_with_a_scope_per_chip_and_gtkw_names_its_signals(tmp_path,
                                                                               backend):
    vcd, gtkw = tmp_path / "run.vcd", tmp_path / "run.gtkw"
    run_job(demo_job(), RunOptions(backend=backend, max_cycles=1500, vcd=vcd))
    wave = pywellen.Waveform(str(vcd))
    scopes = {str(s).removeprefix("Scope(").removesuffix(")") for s in wave.all_scopes()}
    for chip in CHIP_SCOPES:
        assert f"bench.top.chipset.{chip}" in scopes, sorted(scopes)
    names = {v.full_name for v in wave.all_vars()}
    written = write_gtkw(vcd, gtkw)
    assert len(written) >= 15
    listed = [line for line in gtkw.read_text().splitlines() if line.startswith("bench.")]
    assert listed == written
    assert set(listed) <= names
