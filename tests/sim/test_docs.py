"""Generated documentation stays in step with the code it is generated from."""

import importlib.util
import re
import subprocess
import sys

import pytest

from k37.sim.cli import build_parser, main
from k37.sim.docs import REGISTER_MAPS, documents, registers_document
from tests.paths import ROOT

# The manual's generators (docs/_ext/k37_sphinx.py), which the site's build runs too.
_spec = importlib.util.spec_from_file_location("k37_sphinx", ROOT / "docs" / "_ext" /
                                               "k37_sphinx.py")
k37_sphinx = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(k37_sphinx)


@pytest.mark.parametrize("name", sorted(documents()))
def test_generated_doc_is_up_to_date(name):
    assert (ROOT / "docs" / name).read_text() == documents()[name], (
        f"docs/{name} is stale: run `k37 docs -o docs`")


def test_every_register_of_every_chip_is_documented():
    doc = registers_document()
    for regmap in REGISTER_MAPS:
        for reg in regmap:
            assert f"| {reg.name} |" in doc
    for chip in ("K3701", "K3702_X", "K3702_Y", "ENCODER_X", "ENCODER_Y", "FEED", "DECEL"):
        assert f"| {chip} |" in doc


def test_k37_docs_writes_every_document(tmp_path):
    assert main(["docs", "-o", str(tmp_path)]) == 0
    for name, text in documents().items():
        assert (tmp_path / name).read_text() == text


def _source_files() -> set[str]:
    """Every module and C++ source of the three packages, as a path from the root."""
    return {str(p.relative_to(ROOT)) for package in ("hdl", "sim", "firmware_model")
            for pattern in ("*.py", "*.cc", "*.h") for p in (ROOT / package).rglob(pattern)
            if p.name != "__init__.py"}


def test_the_architecture_page_names_every_package_and_module():
    page = k37_sphinx.architecture()
    packages = {"k37." + str(p.parent.relative_to(ROOT)).replace("/", ".")
                for name in ("hdl", "sim", "firmware_model")
                for p in (ROOT / name).rglob("__init__.py")}
    named = set(re.findall(r"\*\*`([\w.]+)`\*\*: \S", page))
    assert packages - named == set(), "these packages have no docstring on the architecture page"
    assert _source_files() - set(re.findall(r"`([\w/]+\.(?:py|cc|h))`", page)) == set()


def test_the_cli_reference_names_every_command_and_option():
    page = k37_sphinx.cli_reference()
    parser = build_parser()
    commands = next(a for a in parser._actions if a.dest == "command").choices
    for name, sub in commands.items():
        assert f"**`k37 {name}`**" in page
        for action in sub._actions:
            for option in set(action.option_strings) - {"-h", "--help"}:
                assert f"`{option}`" in page, (name, option)


@pytest.mark.slow
def test_every_page_of_the_site_is_reachable_from_the_index(tmp_path):
    """The site builds with warnings as errors (an unreachable page is a warning)."""
    pytest.importorskip("sphinx")
    pytest.importorskip("myst_parser")
    result = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
         "-d", str(tmp_path / "doctrees"), str(ROOT / "docs"), str(tmp_path / "html")],
        capture_output=True, text=True, cwd=ROOT, check=False)
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "html" / "chips" / "k3701.html").exists()


def test_the_site_s_python_examples_run(capsys):
    for page in ("guide/api.md",):
        for code in re.findall(r"```python\n(.*?)```", (ROOT / "docs" / page).read_text(), re.S):
            exec(compile(code, page, "exec"), {})
    assert capsys.readouterr().out.startswith("ok ")
