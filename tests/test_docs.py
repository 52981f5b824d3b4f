"""Generated documentation stays in step with the code it is generated from."""

import re
from pathlib import Path

import pytest

from sim.cli import main
from sim.docs import REGISTER_MAPS, documents, registers_document

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.parametrize("name", sorted(documents()))
def test_generated_doc_is_up_to_date(name):
    assert (ROOT / "docs" / name).read_text() == documents()[name], (
        f"docs/{name} is stale: run `k37 docs`")


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
    """Every module and C++ harness of the three packages, as a path from the root."""
    return {str(p.relative_to(ROOT)) for package in ("hdl", "sim", "firmware_model")
            for pattern in ("*.py", "*.cc") for p in (ROOT / package).rglob(pattern)
            if p.name != "__init__.py"}


def test_the_readme_architecture_table_names_every_module():
    readme = (ROOT / "README.md").read_text()
    section = readme[readme.index("## Architecture"):]
    section = section[:section.index("\n## ", 1)]
    named = set(re.findall(r"`([\w/]+\.(?:py|cc))`", section))
    assert _source_files() - named == set(), "add these to the README's architecture table"
    missing = {name for name in named if not (ROOT / name).exists()}
    assert missing == set(), "the README names modules that do not exist"
