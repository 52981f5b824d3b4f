"""Register-level reference model of :class:`k37.hdl.bus.hostbus.RegisterBank`: what a chip sees.

The chips' reference models use it to reproduce the bank's timing exactly: a register whose
committing (last) byte the host writes in cycle *t* shows its new value, with ``w_stb``, in
cycle *t* + 1; a value outside the register's ``valid`` range is not taken and ``w_err``
pulses in cycle *t* + 1 instead.
"""

from __future__ import annotations

from k37.hdl.bus.registers import Register, RegisterMap

__all__ = ["RegisterBankModel"]


class RegisterBankModel:
    """The chip-facing side of a :class:`~k37.hdl.bus.hostbus.RegisterBank`, one cycle at a time.

    Call :meth:`write` for the host's committing write of the current cycle (if any), read
    :attr:`values`, :meth:`w_stb` and :meth:`w_err` for what the chip sees in the current
    cycle, then :meth:`clock` for the rising edge that ends it.
    """

    def __init__(self, regmap: RegisterMap):
        self.regmap = regmap
        #: The ``w_data`` of every writable register in the current cycle.
        self.values: dict[str, int] = {r.name: r.init for r in regmap if r.access.writable}
        self._stb: str | None = None
        self._err: str | None = None
        self._bus: tuple[Register, int] | None = None

    def write(self, name: str, value: int) -> None:
        """Let the host write the committing byte of register ``name`` in the current cycle.

        ``value`` may lie outside the register's ``valid`` range (the bank then ignores it),
        but it must fit the register's width.
        """
        reg = self.regmap[name]
        if not reg.access.writable:
            raise ValueError(f"register {name} is read-only")
        if self._bus is not None:
            raise ValueError(f"the bus already carries a write of {self._bus[0].name} "
                             f"in this cycle")
        lo, hi = reg.full_range
        if not lo <= value <= hi:
            raise ValueError(f"register {name}: {value} does not fit {reg.width} bits")
        self._bus = (reg, value)

    def w_stb(self, name: str) -> bool:
        """Whether register ``name`` took a new value that the chip sees in this cycle."""
        return self._stb == name

    def w_err(self, name: str) -> bool:
        """Whether the host wrote register ``name`` out of range (ignored) one cycle ago."""
        return self._err == name

    def clock(self) -> None:
        """The rising edge that ends the current cycle."""
        self._stb = self._err = None
        if self._bus is not None:
            reg, value = self._bus
            lo, hi = reg.bounds
            if lo <= value <= hi:
                self.values[reg.name] = value
                self._stb = reg.name
            else:
                self._err = reg.name
            self._bus = None
