"""Documentation generated from the single sources of truth in code."""

from __future__ import annotations

from k37.firmware_model.gcode.words import markdown as gcode_markdown
from k37.hdl.board.map import BOARD_MAP, BOARD_SELECT, BOARD_WINDOW, board_port
from k37.hdl.bridge.protocol import markdown as bridge_markdown
from k37.hdl.bus.descriptions import Chip, c_header, svd
from k37.hdl.bus.registers import RegisterMap, registers_markdown
from k37.hdl.chipset.map import CHIP_SELECTS, REG_BITS, SUB_WINDOWS, chip_selects, port
from k37.hdl.feed.map.feed_rate import FEED_MAP, FEED_MAP_AXIS_FA

__all__ = ["REGISTER_MAPS", "chips", "documents", "registers_document"]

#: The three-axis chipset's chips (the two-axis chipset's are the first seven, with the
#: two-axis K3701), with the FEED chip's per-axis fa build.
_CHIPS = {**chip_selects(3), "FEED": (CHIP_SELECTS["FEED"][0], FEED_MAP_AXIS_FA)}
#: Every distinct register map, in chip-select order (the K3701's is the three-axis build's,
#: the FEED chip's the per-axis fa build's: each a superset of the plain one).
REGISTER_MAPS: tuple[RegisterMap, ...] = (*{
    id(m): m for _, m in sorted(_CHIPS.values(), key=lambda v: v[0])}.values(), BOARD_MAP)


def _chip_selects() -> str:
    lines = ["## Chip selects", "",
             f"An 8085 I/O port address is `chip select << {REG_BITS} | register address`. "
             f"The three-axis chipset (`machine.axes = 3`) adds the Z axis's chips on chip "
             f"select 7, which also decodes A4 (a chip's register window starts at its offset "
             f"in the select), and has the three-axis K3701 (the two-axis chip answers at "
             f"0x00-0x0e only). A chipset whose axes have addition clocks of their own "
             f"(`[machine.x] accel_fa_hz`, ...) has the FEED chip's per-axis fa build, with "
             f"FA_INC_X, FA_INC_Y or FA_INC_Z for each such axis (the plain chip answers at "
             f"{port('FEED', 'FEED'):#04x}-{port('FEED', 'FEED') + FEED_MAP.size - 1:#04x} "
             f"only).", "",
             "| chip | chip select | ports | register map | chipsets |", "|---|---|---|---|---|"]
    for chip, (cs, regmap) in _CHIPS.items():
        first = port(chip, regmap.registers[0].name)
        which = "both" if chip in CHIP_SELECTS else "three-axis"
        offset = f" (A4 = 1: offset {SUB_WINDOWS[chip]:#04x})" if chip in SUB_WINDOWS else ""
        lines.append(f"| {chip} | {cs}{offset} | {first:#04x}-{first + regmap.size - 1:#04x} "
                     f"| {regmap.chip} | {which} |")
    board = board_port(BOARD_MAP.registers[0].name)
    lines += [f"| BOARD | {BOARD_SELECT} (A4 = 1, A3 = 0: offset {BOARD_WINDOW:#04x}) "
              f"| {board:#04x}-{board + BOARD_MAP.size - 1:#04x} | BOARD | the FPGA board's "
              f"own, not the chipset's |"]
    return "\n".join(lines) + "\n"


def chips() -> list[Chip]:
    """The three-axis chipset's chips (:data:`_CHIPS`) and the FPGA board's registers, with
    the port of each one's address 0."""
    return [*(Chip(name, port(name, regmap.registers[0].name) - regmap.registers[0].addr,
                   regmap) for name, (_, regmap) in _CHIPS.items()),
            Chip("BOARD", board_port(BOARD_MAP.registers[0].name), BOARD_MAP)]


def registers_document() -> str:
    """The text of ``docs/registers.md``."""
    return registers_markdown(REGISTER_MAPS).replace(
        "\n## ", "\n" + _chip_selects() + "\n## ", 1)


def documents() -> dict[str, str]:
    """Every generated document under ``docs/``, by file name."""
    from k37.sim.run.jobfile import job_keys_markdown
    from k37.sim.run.report import schema_markdown

    return {"registers.md": registers_document(), "run-json.md": schema_markdown(),
            "job-keys.md": job_keys_markdown(), "gcode.md": gcode_markdown(),
            "bridge-protocol.md": bridge_markdown(), "k37_registers.h": c_header(chips()),
            "k37_registers.svd": svd(chips())}
