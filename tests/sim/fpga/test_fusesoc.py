"""The FuseSoC core file that ``k37 export-verilog`` writes beside the Verilog."""

from __future__ import annotations

import shutil
import subprocess
import sys
from importlib import metadata

import pytest

from k37.sim.fpga.export import export_verilog
from k37.sim.fpga.fusesoc import core_text, write_core
from k37.sim.fpga.icarus import find_iverilog
from k37.sim.fpga.testbench import TESTBENCH

needs_icarus = pytest.mark.skipif(find_iverilog() is None,
                                  reason="Icarus Verilog is not installed (apt install iverilog)")


def test_the_core_lists_every_file_and_a_lint_target_per_block(tmp_path):
    text = core_text([tmp_path / "chipset.v", tmp_path / "k3702.v"])
    assert text.startswith("CAPI=2:\n")
    assert f"name: k37:chips:verilog:{metadata.version('k37')}\n" in text
    assert "      - chipset.v\n      - k3702.v\n" in text
    assert "  default:\n    filesets: [rtl]\n    toplevel: chipset\n" in text
    assert text.count("mode: lint-only") == 2 and "    toplevel: k3702\n" in text
    assert text.count("    description: ") == 2 and "sim:" not in text  # no K3701: no sim
    with pytest.raises(ValueError, match="at least one exported file"):
        core_text([])


@pytest.mark.skipif(shutil.which("fusesoc") is None,
                    reason="FuseSoC is not installed (pip install fusesoc)")
def test_fusesoc_reads_the_core_that_export_verilog_writes(tmp_path):
    done = subprocess.run([sys.executable, "-m", "k37.sim.cli", "export-verilog", "--block",
                           "divider", "--block", "k3702", "-o", str(tmp_path)],
                          capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[-1] == f"k37 export-verilog: wrote {tmp_path / 'k37.core'}"
    name = f"k37:chips:verilog:{metadata.version('k37')}"
    shown = subprocess.run(["fusesoc", "--cores-root", str(tmp_path), "core", "show", name],
                           capture_output=True, text=True, check=False, cwd=tmp_path)
    assert shown.returncode == 0, shown.stderr
    assert "lint_divider" in shown.stdout and "lint_k3702" in shown.stdout
    assert "default" in shown.stdout


def test_a_core_with_the_k3701_has_a_sim_target_and_every_target_says_what_it_needs(tmp_path):
    text = core_text([tmp_path / "k3701.v", tmp_path / "k3702.v"])
    sim = text[text.index("  sim:\n"):text.index("  lint_k3701:\n")]
    assert "default_tool: icarus" in sim and "filesets: [rtl, tb]" in sim
    assert "toplevel: k37_tb" in sim and "Needs iverilog on PATH" in sim
    assert f"  tb:\n    file_type: verilogSource\n    files:\n      - {TESTBENCH}\n" in text
    assert text.count("needs verilator on PATH: Debian 12's 5.006 or newer") == 2


@pytest.fixture(scope="module")
def exported_k3701(tmp_path_factory):
    out = tmp_path_factory.mktemp("core")
    paths = export_verilog(["k3701"], out)
    assert [p.name for p in write_core(paths, out)] == [TESTBENCH, "k37.core"]
    return out


def _icarus(folder, testbench: str) -> subprocess.CompletedProcess:
    """The sim target's run without FuseSoC: iverilog as the core's options, then vvp."""
    iverilog, vvp = find_iverilog()
    (folder / "tb_under_test.v").write_text(testbench)
    built = subprocess.run([iverilog, "-g2012", "-s", "k37_tb", "-o", str(folder / "tb.vvp"),
                            str(folder / "k3701.v"), str(folder / "tb_under_test.v")],
                           capture_output=True, text=True, check=False)
    assert built.returncode == 0, built.stderr
    return subprocess.run([vvp, "-n", str(folder / "tb.vvp")], capture_output=True, text=True,
                          check=False)


@needs_icarus
def test_the_sim_target_s_testbench_passes_in_icarus(exported_k3701):
    if shutil.which("fusesoc") is not None:
        done = subprocess.run(["fusesoc", "--cores-root", str(exported_k3701), "run",
                               "--target", "sim", f"k37:chips:verilog:{metadata.version('k37')}"],
                              capture_output=True, text=True, check=False, cwd=exported_k3701)
    else:
        done = _icarus(exported_k3701, (exported_k3701 / TESTBENCH).read_text())
    assert done.returncode == 0, done.stdout + done.stderr
    assert "PASS: linear block (40, -25)" in done.stdout and "FAIL" not in done.stdout


@needs_icarus
def test_the_testbench_fails_with_a_non_zero_exit_on_a_mismatch(exported_k3701):
    testbench = (exported_k3701 / TESTBENCH).read_text()
    wrong = testbench.replace('check("x_pos step pulses", n_x_pos, 40)',
                              'check("x_pos step pulses", n_x_pos, 41)')
    assert wrong != testbench
    done = _icarus(exported_k3701, wrong)
    assert done.returncode != 0
    assert "FAIL x_pos step pulses: 40, expected 41" in done.stdout
