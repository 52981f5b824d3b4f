"""Generated documentation stays in step with the code it is generated from."""

from pathlib import Path

from sim.cli import main
from sim.docs import REGISTER_MAPS, registers_document

ROOT = Path(__file__).resolve().parent.parent


def test_docs_registers_md_is_generated_from_the_register_tables():
    doc = (ROOT / "docs" / "registers.md").read_text()
    assert doc == registers_document(), (
        "docs/registers.md is stale: run `k37 registers -o docs/registers.md`")


def test_every_register_of_every_chip_is_documented():
    doc = registers_document()
    for regmap in REGISTER_MAPS:
        for reg in regmap:
            assert f"| {reg.name} |" in doc


def test_k37_registers_writes_the_document(tmp_path):
    out = tmp_path / "registers.md"
    assert main(["registers", "-o", str(out)]) == 0
    assert out.read_text() == registers_document()
