"""The code base is ruff clean and its imports keep the architecture's contracts (both
configured in pyproject.toml)."""

import re
import shutil
import subprocess
import sys
import tomllib
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


AMARANTH_FREE = "Register maps and reference models import without Amaranth"


def _covered(module: str, patterns: list[str]) -> bool:
    """Whether ``module`` is one of import-linter's ``patterns`` (``*`` one dotted component,
    ``**`` one or more) or inside one (a forbidden contract checks a package's descendants)."""
    for pattern in patterns:
        parts = [r"[^.]+" if p == "*" else r"[^.]+(\.[^.]+)*" if p == "**" else re.escape(p)
                 for p in pattern.split(".")]
        if re.fullmatch(r"\.".join(parts) + r"(\..+)?", module):
            return True
    return False


def test_every_module_of_hdl_without_amaranth_is_in_the_amaranth_free_contract():
    # A new reference model or register map needs no edit of the contract: its name puts it
    # under the globs, and one that does not is found here.
    contracts = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]
    (contract,) = [c for c in contracts["contracts"] if c["name"] == AMARANTH_FREE]
    patterns = contract["source_modules"]
    uses_amaranth = re.compile(r"^\s*(from|import)\s+amaranth\b", re.MULTILINE)
    missed = []
    for path in sorted((ROOT / "hdl").rglob("*.py")):
        if path.name == "__init__.py" or uses_amaranth.search(path.read_text()):
            continue  # a package also holds gateware unless a glob names it
        module = ".".join(("k37", *path.relative_to(ROOT).with_suffix("").parts))
        if not _covered(module, patterns):
            missed.append(module)
    assert missed == []
    assert _covered("k37.hdl.feed.model.divider", patterns)
    assert not _covered("k37.hdl.feed.divider", patterns)
