"""The job's tool table: each tool's length (G43) and diameter (G41/G42), in mm."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from k37.firmware_model.gcode.block_words import BlockError
from k37.firmware_model.gcode.lex import Word

__all__ = ["Tool", "ToolTable", "table_tool", "tool_entry", "tool_number"]


@dataclass(frozen=True)
class Tool:
    """One tool of the table: its length (G43) and its diameter (G41/G42), mm."""

    length: float = 0.0
    diameter: float = 0.0


#: Tool number -> the tool, or a plain number: its length (its diameter zero).
ToolTable = Mapping[int, "float | Tool"]


def tool_entry(value: float | Tool) -> Tool:
    """A table's entry as a :class:`Tool` (a plain number is the tool's length)."""
    return value if isinstance(value, Tool) else Tool(length=float(value))


def tool_number(w: Word) -> int:
    """The tool number a word (H, D) gives."""
    if w.value < 0 or w.value != w.value.to_integral_value():
        raise BlockError(w.col, f"{w.text}: {w.letter} must be a non-negative integer")
    return int(w.value)


def table_tool(tools: Mapping[int, Tool], number: int | None, w: Word) -> Tool:
    """The tool ``number`` of the job's tool table ``tools`` (``w`` names it in an error); no
    table, no tool loaded or tool 0: a tool of length and diameter zero."""
    if not tools or number in (None, 0):
        return Tool()
    if number not in tools:
        raise BlockError(w.col, f"{w.text}: tool {number} is not in the job's tool table "
                                f"({sorted(tools)})")
    return tools[number]
