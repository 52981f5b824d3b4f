"""The register maps' Markdown page, C header and CMSIS-SVD file say the same: every chip's
every register at the same port, with the same width, access and reset value."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

import pytest

from k37.hdl.bus.descriptions import Chip, c_header, svd
from k37.hdl.bus.registers import Access, Register, RegisterMap
from k37.sim.docs import chips, registers_document

#: (chip, register) -> (port, bits, access, reset or None)
Table = dict[tuple[str, str], tuple[int, int, str, int | None]]


def _from_markdown(text: str) -> Table:
    selects = re.findall(r"^\| (\w+) \| [^|]+ \| (0x[0-9a-f]+)-0x[0-9a-f]+ \| (\w+) \|", text,
                         re.M)
    maps: dict[str, list[tuple[int, str, int, str, int | None]]] = {}
    for section in re.split(r"^## ", text, flags=re.M)[1:]:
        name = section.split()[0]
        rows = re.findall(r"^\| (0x[0-9a-f]+)(?:-0x[0-9a-f]+)? \| (\w+) \| (\d+)(?: signed)? "
                          r"\| (\w+) \| (0x[0-9a-f]+|-) \|", section, re.M)
        if rows:
            maps.setdefault(name, [(int(a, 16), reg, int(bits), access,
                                    None if reset == "-" else int(reset, 16))
                                   for a, reg, bits, access, reset in rows])
    table: Table = {}
    for chip, first, regmap in selects:
        registers = maps[regmap]
        base = int(first, 16) - registers[0][0]
        for addr, reg, bits, access, reset in registers:
            table[chip, reg] = (base + addr, bits, access, reset)
    return table


def _from_header(text: str) -> Table:
    defines = dict(re.findall(r"^#define K37_(\w+) (\S+)", text, re.M))
    table: Table = {}
    for chip in chips():
        for reg in chip.regmap:
            key = f"{chip.name}_{reg.name}"
            if f"{key}_PORT" not in defines:
                continue
            reset = defines.get(f"{key}_RESET")
            table[chip.name, reg.name] = (
                int(defines[f"{key}_PORT"].rstrip("u"), 16),
                8 * int(defines[f"{key}_BYTES"].rstrip("u")), defines[f"{key}_ACCESS"].strip('"'),
                None if reset is None else int(reset.rstrip("u"), 16))
    assert len(table) == sum(1 for d in defines if d.endswith("_PORT"))
    return table


def _from_svd(text: str) -> Table:
    access = {"read-only": "r", "write-only": "w", "read-write": "rw"}
    table: Table = {}
    for peripheral in ET.fromstring(text).iter("peripheral"):
        base = int(peripheral.findtext("baseAddress"), 16)
        for register in peripheral.iter("register"):
            reset = register.findtext("resetValue")
            table[peripheral.findtext("name"), register.findtext("name")] = (
                base + int(register.findtext("addressOffset"), 16),
                int(register.findtext("size")), access[register.findtext("access")],
                None if reset is None else int(reset, 16))
    return table


def test_the_markdown_the_c_header_and_the_svd_agree_on_every_register():
    markdown = _from_markdown(registers_document())
    assert len(markdown) == sum(len(chip.regmap.registers) for chip in chips())
    assert _from_header(c_header(chips())) == markdown
    assert _from_svd(svd(chips())) == markdown


def test_every_register_gives_its_reset_value():
    for (chip, name), (_, _, _, reset) in _from_markdown(registers_document()).items():
        assert reset is not None, (chip, name)



SMALL = RegisterMap("DEMO", 2, (
    Register("SPEED", 0, 16, Access.RW, "signed speed", signed=True, init=-2),
    Register("STATE", 2, 8, Access.R, "state"),
))


@pytest.mark.parametrize("render", [c_header, svd])
def test_a_signed_reset_value_is_given_as_its_raw_bits(render):
    text = render([Chip("DEMO_A", 0x40, SMALL)])
    assert re.search(r"0xFFFEu?\b", text)
    assert "DEMO_A" in text and "STATE" in text
