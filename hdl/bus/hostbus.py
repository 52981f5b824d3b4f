"""The chips' 8-bit host interface, implemented once in gateware.

Every chip of the set (K3701, K3702, the feed path) talks to the 8085 through the same
8-bit bus and the same register semantics, implemented here once:

* multi-byte registers are little-endian, byte 0 at the register's base address;
* a write **commits on its last byte** (the most significant one): the lower bytes wait in a
  shadow register, so the chip never sees half a new value;
* a read **snapshots on its first byte** (the least significant one): the whole value is
  latched and the higher bytes are read from the latch, so a counter that keeps running can
  never be read torn.

A :class:`RegisterBank` implements a chip's :class:`~k37.hdl.bus.registers.RegisterMap` (the data
the host, the firmware and the docs share, in :mod:`k37.hdl.bus.registers`).
"""

from __future__ import annotations

from dataclasses import dataclass

from amaranth.hdl import Cat, Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from k37.hdl.bus.registers import Access, Register, RegisterMap

__all__ = ["HostBus", "RegisterBank", "RegisterPort"]


class HostBus(wiring.Signature):
    """The host (initiator) side of the 8-bit chip bus, sampled on the rising system clock.

    Members
    -------
    addr : Out(addr_width)
        Byte address inside the chip; meaningful while ``w_stb`` or ``r_stb`` is high.
    w_stb : Out(1)
        Write strobe: the byte on ``w_data`` is taken at the clock edge that ends the cycle.
    w_data : Out(8)
        Write data.
    r_stb : Out(1)
        Read strobe: the byte addressed in cycle *t* appears on ``r_data`` in cycle *t* + 1
        and stays there until the next read.
    r_data : In(8)
        Read data, driven by the chip.
    """

    def __init__(self, addr_width: int):
        if not isinstance(addr_width, int) or addr_width < 1:
            raise TypeError(f"addr_width must be a positive integer, not {addr_width!r}")
        self.addr_width = addr_width
        super().__init__({
            "addr": Out(addr_width),
            "w_stb": Out(1),
            "w_data": Out(8),
            "r_stb": Out(1),
            "r_data": In(8),
        })

    def __eq__(self, other: object) -> bool:
        return isinstance(other, HostBus) and other.addr_width == self.addr_width

    def __hash__(self) -> int:
        return hash(("HostBus", self.addr_width))

    def __repr__(self) -> str:
        return f"HostBus({self.addr_width})"


class RegisterPort(wiring.Signature):
    """The chip-facing side of one register in a :class:`RegisterBank` (the bank's view).

    Members
    -------
    w_data : Out(width), writable registers only
        The last committed value; holds between writes.
    w_stb : Out(1), writable registers only
        High for the one cycle after the committing byte was written (when ``w_data`` first
        shows the new value).
    w_err : Out(1), registers with a ``valid`` range only
        High instead of ``w_stb`` when the committed value was outside the range; ``w_data``
        keeps its previous value.
    r_data : In(width), readable registers only
        The value the chip presents; sampled whole when the host reads byte 0.
    r_stb : Out(1), readable registers only
        High in the cycle in which the host reads byte 0 (the snapshot cycle).
    """

    def __init__(self, width: int, access: Access, checked: bool = False):
        self.width = width
        self.access = access
        self.checked = checked
        members: dict[str, wiring.Member] = {}
        if access.writable:
            members |= {"w_data": Out(width), "w_stb": Out(1)}
        if checked:
            members |= {"w_err": Out(1)}
        if access.readable:
            members |= {"r_data": In(width), "r_stb": Out(1)}
        super().__init__(members)

    def __eq__(self, other: object) -> bool:
        return (isinstance(other, RegisterPort) and other.width == self.width
                and other.access == self.access and other.checked == self.checked)

    def __hash__(self) -> int:
        return hash(("RegisterPort", self.width, self.access, self.checked))

    def __repr__(self) -> str:
        return f"RegisterPort({self.width}, {self.access}, checked={self.checked})"


def _port_name(reg: Register) -> str:
    return reg.name.lower()


class RegisterBank(wiring.Component):
    """The bus side of a chip: decodes :class:`HostBus` accesses into its registers.

    Writes: byte *k* < n-1 of an n-byte register goes to a shadow byte at the edge that ends
    the write cycle *t*; the last byte commits the whole value, visible on the register's
    ``w_data`` with ``w_stb`` high in cycle *t* + 1. Reads: ``r_data`` of cycle *t* + 1 holds
    the byte addressed in cycle *t*; reading byte 0 latches the register's whole ``r_data``
    (``r_stb`` high in cycle *t*), bytes 1.. come from that latch. A committed value outside
    the register's ``valid`` range is not taken: ``w_err`` pulses instead of ``w_stb``.
    Unmapped addresses and writes to read-only registers are ignored (the host driver refuses
    them first); reads of write-only registers and unmapped addresses return 0.

    Members
    -------
    bus : In(HostBus(regmap.addr_width))
        The host bus.
    <register name in lower case> : Out(RegisterPort(width, access))
        One port per register of the map.
    """

    def __init__(self, regmap: RegisterMap):
        self.regmap = regmap
        members: dict[str, wiring.Member] = {"bus": In(HostBus(regmap.addr_width))}
        for reg in regmap:
            members[_port_name(reg)] = Out(RegisterPort(reg.width, reg.access,
                                                        checked=reg.valid is not None))
        super().__init__(members)

    def elaborate(self, platform) -> Module:
        m = Module()
        bus = self.bus
        r_data = Signal(8)
        m.d.comb += bus.r_data.eq(r_data)

        shadows: dict[str, Signal] = {}
        latches: dict[str, Signal] = {}
        values: dict[str, Signal] = {}
        # Which register committed (1, 2, ...; 0: none) or was refused in the last cycle: one
        # register each instead of a strobe per register, cheaper to simulate.
        writable = [reg for reg in self.regmap if reg.access.writable]
        checked = [reg for reg in writable if reg.valid is not None]
        strobes = _Strobes(_code_register(m, "committed", len(writable)),
                           _code_register(m, "refused", len(checked)),
                           {reg.name: k + 1 for k, reg in enumerate(writable)},
                           {reg.name: k + 1 for k, reg in enumerate(checked)})
        for reg in self.regmap:
            name = _port_name(reg)
            port = getattr(self, name)
            if reg.access.writable:
                values[name] = Signal(reg.width, name=f"{name}_value",
                                      init=reg.init & ((1 << reg.width) - 1))
                m.d.comb += [port.w_data.eq(values[name]),
                             port.w_stb.eq(strobes.committed == strobes.commit_code[reg.name])]
                if reg.valid is not None:
                    m.d.comb += port.w_err.eq(strobes.refused == strobes.refuse_code[reg.name])
                if reg.nbytes > 1:
                    shadows[name] = Signal(reg.width - 8, name=f"{name}_shadow")
            if reg.access.readable and reg.nbytes > 1:
                latches[name] = Signal(reg.width - 8, name=f"{name}_latch")

        # Only a bus access changes anything: one test per register when the bus is idle.
        with m.If(bus.w_stb | bus.r_stb):
            with m.Switch(bus.addr):
                for reg in self.regmap:
                    name = _port_name(reg)
                    port = getattr(self, name)
                    for k in range(reg.nbytes):
                        with m.Case(reg.addr + k):
                            if reg.access.writable:
                                with m.If(bus.w_stb):
                                    if k < reg.nbytes - 1:
                                        m.d.sync += shadows[name].eq(
                                            _with_byte(shadows[name], k, bus.w_data))
                                    else:
                                        new = (Cat(shadows[name], bus.w_data) if name in shadows
                                               else bus.w_data)
                                        _commit(m, reg, strobes, values[name], new)
                            with m.If(bus.r_stb):
                                if not reg.access.readable:
                                    m.d.sync += r_data.eq(0)
                                elif k == 0:
                                    m.d.comb += port.r_stb.eq(1)
                                    m.d.sync += r_data.eq(port.r_data[:8])
                                    if name in latches:
                                        m.d.sync += latches[name].eq(port.r_data[8:])
                                else:
                                    m.d.sync += r_data.eq(latches[name].word_select(k - 1, 8))
                with m.Default():
                    with m.If(bus.r_stb):
                        m.d.sync += r_data.eq(0)
        return m


def _with_byte(word: Signal, k: int, byte: Signal):
    """``word`` with its byte ``k`` replaced by ``byte``.

    A whole-register assignment (rather than ``word_select(k, 8).eq``) keeps each shadow one
    multiplexer that compiled simulators evaluate only on a bus write.
    """
    return Cat(word[:8 * k], byte, word[8 * (k + 1):])


@dataclass(frozen=True)
class _Strobes:
    """A bank's write strobes: the code of the register committed or refused last cycle."""

    committed: Signal | None  # None if there is no such register
    refused: Signal | None
    commit_code: dict[str, int]
    refuse_code: dict[str, int]


def _code_register(m: Module, name: str, count: int) -> Signal | None:
    """A register holding 1..``count`` for one cycle after an event, else 0 (None if no
    events)."""
    if not count:
        return None
    code = Signal(range(count + 1), name=name)
    m.d.sync += code.eq(0)
    return code


def _commit(m: Module, reg: Register, strobes: _Strobes, value: Signal, new) -> None:
    """Take the completed value ``new`` of a writable register, unless it is out of range."""
    code = strobes.commit_code[reg.name]
    if reg.valid is None:
        m.d.sync += [value.eq(new), strobes.committed.eq(code)]
        return

    def ok():
        # A fresh expression per use: each register's logic then stands alone, and compiled
        # simulators evaluate the range check only on a write.
        word = new.as_signed() if reg.signed else new
        return (word >= reg.valid[0]) & (word <= reg.valid[1])

    m.d.sync += [value.eq(Mux(ok(), new, value)),
                 strobes.committed.eq(Mux(ok(), code, 0)),
                 strobes.refused.eq(Mux(ok(), 0, strobes.refuse_code[reg.name]))]
