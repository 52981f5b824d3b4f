"""The cocotb example (``examples/cocotb``) runs and passes on the exported chipset in Icarus.

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


@needs_icarus
@needs_cocotb
@pytest.mark.slow
def test_the_cocotb_example_passes_on_the_exported_chipset(tmp_path):
    from cocotb_tools.check_results import get_results
    from cocotb_tools.runner import get_runner

    (verilog,) = export_verilog(["chipset"], tmp_path)
    runner = get_runner("icarus")
    runner.build(sources=[verilog, EXAMPLE / "chipset_tb.v"], hdl_toplevel="chipset_tb",
                 build_dir=tmp_path / "sim_build", always=True, log_file=tmp_path / "build.log")
    root = str(ROOT)
    results = runner.test(hdl_toplevel="chipset_tb", test_module="chipset_bench",
                          test_dir=EXAMPLE, build_dir=tmp_path / "sim_build",
                          extra_env={"PYTHONPATH": os.pathsep.join(
                              [str(EXAMPLE), root, os.environ.get("PYTHONPATH", "")])},
                          results_xml=str(tmp_path / "results.xml"),
                          log_file=tmp_path / "test.log")
    tests, failed = get_results(results)
    log = (tmp_path / "test.log").read_text()
    assert (tests, failed) == (2, 0), log[-3000:]
