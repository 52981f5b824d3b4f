"""The job's tool table: each tool's length (G43) and diameter (G41/G42), in mm."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

__all__ = ["Tool", "ToolTable", "tool_entry"]


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
