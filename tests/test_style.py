"""The code base is ruff clean and its imports keep the architecture's contracts (both
configured in pyproject.toml)."""

import shutil
import subprocess
import sys
from pathlib import Path

from tests.paths import ROOT


def _tool(name: str) -> str:
    return shutil.which(name) or str(Path(sys.executable).parent / name)


def test_ruff_check_is_clean():
    result = subprocess.run([_tool("ruff"), "check", "."], cwd=ROOT, capture_output=True,
                            text=True, check=False)
    assert result.returncode == 0, result.stdout + result.stderr


def test_imports_have_no_cycle_and_keep_the_layers():
    # import-linter: no cycle between sibling packages or modules at any depth, sim's layers
    # from the command line down to the backends, gateware and firmware free of simulation.
    result = subprocess.run([_tool("lint-imports")], cwd=ROOT, capture_output=True, text=True,
                            check=False)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "0 broken" in result.stdout
