"""The chips' register maps as data: what the host, the firmware and the docs see of a chip.

A :class:`RegisterMap` is the single source of truth for a chip's registers: the gateware's
:class:`k37.hdl.bus.hostbus.RegisterBank`, the firmware model's constants and ``docs/registers.md``
all come from it. Register semantics (little-endian; a write commits on its last byte, a read
snapshots on its first) are the bank's: see :mod:`k37.hdl.bus.hostbus`. This module, and each chip's
``*_map`` module, imports nothing of Amaranth, so a host or a run that only talks to the chips
never loads the HDL.
"""

from __future__ import annotations

import enum
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

from k37.hdl.common.params import Limit

__all__ = ["Access", "Field", "Register", "RegisterMap", "registers_markdown"]


class Access(enum.Enum):
    """Who may do what with a register."""

    #: Read only; writes are refused by the host driver and ignored by the chip.
    R = "r"
    #: Write only; reads return 0.
    W = "w"
    #: Read and write; what a read returns is documented per register (it may differ from
    #: what was written, e.g. the K3701's X register reads back the remaining distance).
    RW = "rw"

    @property
    def readable(self) -> bool:
        return self is not Access.W

    @property
    def writable(self) -> bool:
        return self is not Access.R


@dataclass(frozen=True)
class Field:
    """A named bit field of a register."""

    name: str
    offset: int
    width: int = 1
    doc: str = ""

    @property
    def mask(self) -> int:
        return ((1 << self.width) - 1) << self.offset

    def encode(self, value: int) -> int:
        """Place ``value`` in this field's bits, refusing what does not fit."""
        if not 0 <= value < (1 << self.width):
            raise ValueError(f"field {self.name} is {self.width} bit(s) wide; {value} does not fit")
        return value << self.offset

    def decode(self, word: int) -> int:
        """Extract this field from a register value."""
        return (word >> self.offset) & ((1 << self.width) - 1)


@dataclass(frozen=True)
class Register:
    """One register of a chip.

    ``width`` is in bits (a multiple of 8). ``doc`` says what writing and reading mean;
    ``signed`` marks two's complement values. ``init`` is the value a writable register
    holds after reset; ``after_reset`` what a read-only one reads after reset, the machine at
    rest (its inputs idle, encoder lines still). ``valid`` (inclusive bounds) limits the
    values the chip accepts: the bank ignores a write outside them and pulses the port's
    ``w_err`` instead, and :meth:`to_bytes` refuses them.
    """

    name: str
    addr: int
    width: int
    access: Access
    doc: str
    fields: tuple[Field, ...] = ()
    signed: bool = False
    init: int = 0
    valid: tuple[int, int] | None = None
    after_reset: int | None = None

    def __post_init__(self) -> None:
        if self.width % 8 or not 8 <= self.width <= 32:
            raise ValueError(f"register {self.name}: width must be 8, 16, 24 or 32 bits, "
                             f"not {self.width}")
        used = 0
        for f in self.fields:
            if f.offset + f.width > self.width or used & f.mask:
                raise ValueError(f"register {self.name}: field {f.name} overlaps or overflows")
            used |= f.mask
        lo, hi = self.bounds
        if self.valid is not None and not self.full_range[0] <= lo <= hi <= self.full_range[1]:
            raise ValueError(f"register {self.name}: valid must be (low, high) inside the "
                             f"register's range, not {self.valid!r}")
        if not lo <= self.init <= hi:
            raise ValueError(f"register {self.name}: init must be in {lo}..{hi}, "
                             f"not {self.init!r}")

    @property
    def full_range(self) -> tuple[int, int]:
        """The lowest and highest value the register's width holds."""
        if self.signed:
            return -(1 << (self.width - 1)), (1 << (self.width - 1)) - 1
        return 0, (1 << self.width) - 1

    @property
    def bounds(self) -> tuple[int, int]:
        """The lowest and highest value the chip accepts (``valid``, else the full range)."""
        return self.full_range if self.valid is None else self.valid

    @property
    def limit(self) -> Limit:
        """The values the chip accepts (:attr:`bounds`), for checking a value to be written."""
        return Limit(*self.bounds, integer=True)

    @property
    def nbytes(self) -> int:
        return self.width // 8

    @property
    def reset(self) -> int | None:
        """The value after reset as raw bits (two's complement): :attr:`init` for a register
        the host writes, :attr:`after_reset` for a read-only one (None if not given)."""
        value = self.after_reset if self.access is Access.R else self.init
        return None if value is None else value & ((1 << self.width) - 1)

    def field(self, name: str) -> Field:
        for f in self.fields:
            if f.name == name:
                return f
        raise KeyError(f"register {self.name} has no field {name!r}")

    def encode(self, **values: int) -> int:
        """Build a register value from field values: ``CTRL.encode(circular=1, quadrant=2)``."""
        word = 0
        for name, value in values.items():
            word |= self.field(name).encode(value)
        return word

    def decode(self, word: int) -> dict[str, int]:
        """Each field's value in a register value (``encode``'s inverse)."""
        return {f.name: f.decode(word) for f in self.fields}

    def to_bytes(self, value: int) -> list[int]:
        """The bytes a host writes, in bus order (LSB first, the committing MSB last)."""
        lo, hi = self.bounds
        if not lo <= value <= hi:
            raise ValueError(f"register {self.name}: {value} is outside {lo}..{hi}")
        raw = value & ((1 << self.width) - 1)
        return [(raw >> (8 * i)) & 0xFF for i in range(self.nbytes)]

    def from_bytes(self, data: Sequence[int]) -> int:
        """The value of the bytes a host read, in bus order."""
        raw = sum(b << (8 * i) for i, b in enumerate(data))
        if self.signed and raw >> (self.width - 1):
            raw -= 1 << self.width
        return raw


@dataclass(frozen=True)
class RegisterMap:
    """A chip's registers: names, addresses, widths, fields and meaning, in one table."""

    chip: str
    version: int
    registers: tuple[Register, ...]
    doc: str = ""
    _by_name: dict[str, Register] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        by_name: dict[str, Register] = {}
        taken: dict[int, str] = {}
        for reg in self.registers:
            if reg.name in by_name:
                raise ValueError(f"{self.chip}: register {reg.name} is defined twice")
            by_name[reg.name] = reg
            for a in range(reg.addr, reg.addr + reg.nbytes):
                if a in taken:
                    raise ValueError(f"{self.chip}: {reg.name} overlaps {taken[a]} at {a:#x}")
                taken[a] = reg.name
        object.__setattr__(self, "_by_name", by_name)

    def __getitem__(self, name: str) -> Register:
        try:
            return self._by_name[name]
        except KeyError:
            raise KeyError(f"{self.chip} has no register {name!r}") from None

    def __iter__(self):
        return iter(self.registers)

    @property
    def size(self) -> int:
        """Number of byte addresses the map spans."""
        return max(r.addr + r.nbytes for r in self.registers)

    @property
    def addr_width(self) -> int:
        return max(1, (self.size - 1).bit_length())

    def at(self, addr: int) -> tuple[Register, int] | None:
        """The register and byte index at a byte address, or None where nothing is mapped."""
        for reg in self.registers:
            if reg.addr <= addr < reg.addr + reg.nbytes:
                return reg, addr - reg.addr
        return None

    def markdown(self) -> str:
        """The map as a Markdown section (the generator of ``docs/registers.md``)."""
        lines = [f"## {self.chip} (register map version {self.version})", ""]
        if self.doc:
            lines += [self.doc, ""]
        lines += ["| addr | name | bits | access | reset | meaning |",
                  "|---|---|---|---|---|---|"]
        for reg in self.registers:
            addrs = (f"{reg.addr:#04x}" if reg.nbytes == 1
                     else f"{reg.addr:#04x}-{reg.addr + reg.nbytes - 1:#04x}")
            kind = f"{reg.width}{' signed' if reg.signed else ''}"
            doc = reg.doc
            if reg.valid is not None:
                doc += f" Valid {reg.valid[0]}..{reg.valid[1]}; other values are ignored."
            reset = "-" if reg.reset is None else f"{reg.reset:#0{2 + 2 * reg.nbytes}x}"
            lines.append(f"| {addrs} | {reg.name} | {kind} | {reg.access.value} | {reset} "
                         f"| {_cell(doc)} |")
        for reg in self.registers:
            if reg.fields:
                lines += ["", f"### {self.chip} {reg.name} fields", "",
                          "| bits | field | meaning |", "|---|---|---|"]
                for f in reg.fields:
                    bits = (str(f.offset) if f.width == 1
                            else f"{f.offset + f.width - 1}:{f.offset}")
                    lines.append(f"| {bits} | {f.name} | {_cell(f.doc)} |")
        return "\n".join(lines) + "\n"


def _cell(text: str) -> str:
    """``text`` as a Markdown table cell: its bars (``|ERROR|``) escaped."""
    return text.replace("|", "\\|")


def registers_markdown(maps: Iterable[RegisterMap]) -> str:
    """All chips' register maps as one Markdown document."""
    parts = ["# K37 register maps", "",
             "Generated by `k37 docs` from the register tables in `hdl/` "
             "(do not edit by hand).", "",
             "Multi-byte registers are little-endian. A write takes effect when its last "
             "(most significant) byte is written; reading byte 0 (the least significant) "
             "snapshots the whole register, so read it first. The reset column gives each "
             "register's value after reset (raw bits): what a writable register holds, what a "
             "read-only one reads with the machine at rest (inputs idle, encoder lines still). "
             "The same maps are in `k37_registers.h` (C) and "
             "`k37_registers.svd` (CMSIS-SVD) beside this page.", ""]
    parts += [rm.markdown() for rm in maps]
    return "\n".join(parts)
