"""Documentation generated from the single sources of truth in code."""

from __future__ import annotations

from firmware_model.gcode_words import markdown as gcode_markdown
from hdl.chipset import CHIP_SELECTS, REG_BITS
from hdl.hostbus import RegisterMap, registers_markdown

__all__ = ["REGISTER_MAPS", "documents", "registers_document"]

#: Every distinct register map, in chip-select order.
REGISTER_MAPS: tuple[RegisterMap, ...] = tuple(
    {id(m): m for _, m in sorted(CHIP_SELECTS.values(), key=lambda v: v[0])}.values())


def _chip_selects() -> str:
    lines = ["## Chip selects", "",
             f"An 8085 I/O port address is `chip select << {REG_BITS} | register address`.", "",
             "| chip | chip select | ports | register map |", "|---|---|---|---|"]
    for chip, (cs, regmap) in CHIP_SELECTS.items():
        base = cs << REG_BITS
        lines.append(f"| {chip} | {cs} | {base:#04x}-{base + regmap.size - 1:#04x} | "
                     f"{regmap.chip} |")
    return "\n".join(lines) + "\n"


def registers_document() -> str:
    """The text of ``docs/registers.md``."""
    return registers_markdown(REGISTER_MAPS).replace(
        "\n## ", "\n" + _chip_selects() + "\n## ", 1)


def documents() -> dict[str, str]:
    """Every generated document under ``docs/``, by file name."""
    from sim.run.jobfile import job_keys_markdown
    from sim.run.report import schema_markdown

    return {"registers.md": registers_document(), "run-json.md": schema_markdown(),
            "job-keys.md": job_keys_markdown(), "gcode.md": gcode_markdown()}
