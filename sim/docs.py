"""Documentation generated from the single sources of truth in code."""

from __future__ import annotations

from hdl.hostbus import RegisterMap, registers_markdown
from hdl.k3701 import K3701_MAP

__all__ = ["REGISTER_MAPS", "registers_document"]

#: Every chip's register map, in bus order.
REGISTER_MAPS: tuple[RegisterMap, ...] = (K3701_MAP,)


def registers_document() -> str:
    """The text of ``docs/registers.md``."""
    return registers_markdown(REGISTER_MAPS)
