"""The cocotb example (``examples/cocotb``) runs and passes on the exported Verilog in Icarus.

Skips, saying so, where cocotb or Icarus Verilog is not installed.
"""

from __future__ import annotations

import importlib.util
import os

import pytest

from k37.sim.fpga.export import export_verilog
from tests.paths import ROOT
from tests.sim.fpga.cosim import needs_icarus

EXAMPLE = ROOT / "examples" / "cocotb"

needs_cocotb = pytest.mark.skipif(importlib.util.find_spec("cocotb") is None,
                                  reason="cocotb is not installed (pip install cocotb)")


#: The benches and how many tests each has.
BENCHES = {"chipset": 4, "k3701": 2}


@needs_icarus
@needs_cocotb
@pytest.mark.slow
@pytest.mark.parametrize(("top", "tests"), BENCHES.items())
def test_the_cocotb_example_passes_on_the_exported_verilog(tmp_path, top, tests):
    from cocotb_tools.check_results import get_results
    from cocotb_tools.runner import get_runner

    (verilog,) = export_verilog([top], tmp_path)
    runner = get_runner("icarus")
    runner.build(sources=[verilog, EXAMPLE / f"{top}_tb.v"], hdl_toplevel=f"{top}_tb",
                 build_dir=tmp_path / "sim_build", always=True, log_file=tmp_path / "build.log")
    root = str(ROOT)
    results = runner.test(hdl_toplevel=f"{top}_tb", test_module=f"{top}_bench",
                          test_dir=EXAMPLE, build_dir=tmp_path / "sim_build",
                          extra_env={"PYTHONPATH": os.pathsep.join(
                              [str(EXAMPLE), root, os.environ.get("PYTHONPATH", "")])},
                          results_xml=str(tmp_path / "results.xml"),
                          log_file=tmp_path / "test.log")
    log = (tmp_path / "test.log").read_text()
    assert get_results(results) == (tests, 0), log[-3000:]


def test_every_bench_of_the_example_is_run():
    assert {p.stem.removesuffix("_bench") for p in EXAMPLE.glob("*_bench.py")} == set(BENCHES)
    assert {p.stem.removesuffix("_tb") for p in EXAMPLE.glob("*_tb.v")} == set(BENCHES)
