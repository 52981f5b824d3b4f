"""The FuseSoC core file that ``k37 export-verilog`` writes beside the Verilog."""

from __future__ import annotations

import shutil
import subprocess
import sys
from importlib import metadata

import pytest

from k37.sim.fpga.fusesoc import core_text


def test_the_core_lists_every_file_and_a_lint_target_per_block(tmp_path):
    text = core_text([tmp_path / "chipset.v", tmp_path / "k3702.v"])
    assert text.startswith("CAPI=2:\n")
    assert f"name: k37:chips:verilog:{metadata.version('k37')}\n" in text
    assert "      - chipset.v\n      - k3702.v\n" in text
    assert "  default:\n    filesets: [rtl]\n    toplevel: chipset\n" in text
    assert text.count("mode: lint-only") == 2 and "    toplevel: k3702\n" in text
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
