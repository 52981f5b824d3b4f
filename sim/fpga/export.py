"""Verilog export of the chips: one self-contained file per block, with the chips' pin names.

Each exported file holds two layers:

* the **core**: Amaranth's own Verilog of the block (``amaranth.back.verilog.convert``),
  unchanged but for its registers' power-up values, moved from their declarations to
  ``initial`` statements (the same values at time 0), so the FPGA runs exactly the logic the
  project simulates and tests. Its module
  is ``<block>_core`` (submodules ``<block>_core.<name>``), so the files of several blocks can
  share one FPGA project;
* a thin **pin wrapper** ``<block>``, generated here, with the real chips' pin names: the
  8-bit host bus as ``d[7:0]`` (bidirectional), ``addr``, ``cs_n``, ``rd_n``, ``wr_n``
  (active low, as on the chips); every other signature port keeps its name (``x_pos`` is
  +X, ``alarm_n`` is ALARM, active low already in the core). Output ports a block declares
  in its ``probes`` (simulation observability, not chip pins) stay inside.

The header names the block's parameters, its register map(s) and version, and the clocking
and bus protocol; the port list gives each pin its datasheet name and meaning. Waivers for
Verilator's ``-Wall`` lint are written inline, each with its reason (:data:`CORE_WAIVERS`),
naming only rules that Debian's Verilator 5.006 knows as well as the newest.
:data:`k37.sim.fpga.blocks.BLOCKS` is the registry of exportable blocks; adding one (the chipset
top) is one line.
"""

from __future__ import annotations

import dataclasses
import enum
import inspect
import re
import textwrap
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any

from amaranth.back import verilog
from amaranth.hdl import Shape
from amaranth.lib import wiring

from k37.hdl.board.core import BoardCore
from k37.hdl.board.pins import BoardPin
from k37.hdl.bus.hostbus import HostBus
from k37.hdl.bus.wishbone import WishboneBus
from k37.hdl.chipset.map import SUB_WINDOWS
from k37.hdl.common.constants import CHIP_HZ
from k37.sim.files import atomic_open
from k37.sim.fpga.blocks import BLOCKS, Exportable, block

__all__ = ["CORE_WAIVERS", "Pin", "export_verilog", "pins", "verilog_text"]


# --- pins ----------------------------------------------------------------------------------

#: The datasheets' pin labels of the Verilog names that have one.
SPEC_LABELS = {
    "clk": "CP", "rst": "RESET", "d": "D7-D0", "cs_n": "/CS", "rd_n": "/RD", "wr_n": "/WR",
    "fp": "FP", "x_pos": "+X", "x_neg": "-X", "y_pos": "+Y", "y_neg": "-Y", "busy": "BUSY",
    "irq": "INT", "alarm_n": "ALARM", "com_pos": "+COM", "com_neg": "-COM", "fb_pos": "+FB",
    "fb_neg": "-FB", "a": "A", "a_n": "/A", "b": "B", "b_n": "/B",
}

#: Verilog and SystemVerilog keywords a pin name must not be.
_KEYWORDS = frozenset((
    "alias", "always", "and", "assign", "begin", "bit", "buf", "byte", "case", "class",
    "default", "do", "else", "end", "endmodule", "enum", "event", "final", "for", "force", "if",
    "initial", "inout", "input", "int", "integer", "logic", "module", "nand", "nor", "not", "or",
    "output", "parameter", "real", "reg", "shortint", "signed", "string", "supply0", "supply1",
    "table", "time", "tri", "type", "unsigned", "var", "void", "wait", "wand", "while", "wire",
    "wor", "xor",
))

_BUS_PINS = {  # suffix: (direction, datasheet label, meaning)
    "d": ("inout", "D7-D0", "Data bus, driven in the cycle after a read cycle"),
    "addr": ("input", "address", "Register byte address"),
    "cs_n": ("input", "/CS", "Chip select, active low"),
    "rd_n": ("input", "/RD", "Read strobe, active low"),
    "wr_n": ("input", "/WR", "Write strobe, active low"),
}


@dataclass(frozen=True)
class Pin:
    """One port of the exported wrapper."""

    name: str
    direction: str  # "input", "output" or "inout"
    width: int
    label: str
    doc: str


@dataclass(frozen=True)
class _Bus:
    prefix: str   # pin name prefix ("" for the block's one bus)
    core: str     # the core's port prefix, e.g. "bus__"
    addr_width: int


def _members_doc(cls: type) -> dict[str, str]:
    """First sentence of each port's description in the class's NumPy "Members" section."""
    doc = inspect.cleandoc(cls.__doc__ or "")
    section = re.search(r"^Members\n-+\n(.*?)(?:^\S[^\n]*\n-+\n|\Z)", doc, re.M | re.S)
    docs: dict[str, str] = {}
    if section is None:
        return docs
    for names, text in re.findall(r"^(\S[^\n]*?) : [^\n]*\n((?:[ \t]+\S[^\n]*\n?)*)",
                                  section.group(1), re.M):
        text = " ".join(text.replace("``", "").split())
        sentence = re.split(r"(?<=[.;])\s", text, maxsplit=1)[0]
        for name in names.split(","):
            docs.setdefault(name.strip(), sentence.rstrip(".;"))
    return docs


def _walk(signature: wiring.Signature, component: Any, docs: dict[str, str],
          path: tuple[str, ...] = ()):
    """(path, member, value, doc) of each port; each HostBus the block is the target of is one
    (path, signature, None, ""), one it drives (a bridge's) its ports.

    ``docs`` are the port descriptions of ``signature``'s class; a nested signature's ports
    take theirs from its own class's "Members" section.
    """
    for name, member in signature.members.items():
        here = (*path, name)
        value = getattr(component, name)
        if member.is_signature and isinstance(member.signature, HostBus) \
                and member.flow == wiring.In:
            yield here, member.signature, None, ""
        elif member.is_signature:
            inner = member.signature
            unflipped = inner.flip() if isinstance(inner, wiring.FlippedSignature) else inner
            yield from _walk(inner, value, _members_doc(type(unflipped)), here)
        else:
            yield here, member, value, docs.get(name, "")


def _check_name(name: str, where: str) -> str:
    if not re.fullmatch(r"[a-z][a-z0-9_]*", name) or name in _KEYWORDS or "__" in name:
        raise ValueError(f"{where}: pin name {name!r} is not a plain lower-case Verilog "
                         f"identifier; rename the port")
    return name


def _board_pins(component: wiring.Component) -> dict[str, tuple[str, str]]:
    """A board top's pins (its ``pins``, :class:`k37.hdl.board.pins.BoardPin`): the board's
    label and the description of each, by signal."""
    return {pin.signal: (pin.label, pin.doc) for pin in getattr(component, "pins", ())
            if isinstance(pin, BoardPin)}


def _clock_text(component: wiring.Component) -> str:
    """What clk is: the chips' CP, or a board's clock with the chipset under a clock enable."""
    core = getattr(component, "core", None)
    if isinstance(core, BoardCore):
        return (f"the board's {core.clock_hz / 1e6:g} MHz clock; the chipset inside runs at "
                f"{CHIP_HZ / 1e6:g} MHz, one cycle of every {core.ratio}, by a clock enable")
    return "the paper's CP, 1 MHz"


def _plan(entry: Exportable, component: wiring.Component
          ) -> tuple[list[Pin], list[_Bus], dict[str, str], list[str]]:
    """The wrapper's pins, buses, core port -> pin connections and unconnected probes."""
    pins_: list[Pin] = []
    buses: list[_Bus] = []
    direct: dict[str, str] = {}
    probes: list[str] = []
    board = _board_pins(component)
    docs = _members_doc(type(component)) | {name: doc for name, (_, doc) in board.items()}
    for path, member, value, doc in _walk(component.signature, component, docs):
        core = "__".join(path)
        if value is None:  # a host bus
            stem = path[:-1] if path[-1] == "bus" else path
            prefix = "".join(f"{p}_" for p in stem)
            bus = _Bus(prefix, f"{core}__", member.addr_width)
            buses.append(bus)
            for suffix, (direction, label, doc) in _BUS_PINS.items():
                width = {"d": 8, "addr": bus.addr_width}.get(suffix, 1)
                name = _check_name(prefix + suffix, entry.name)
                pins_.append(Pin(name, direction, width, label, doc))
            continue
        if core in entry.probes:
            if member.flow != wiring.Out:
                raise ValueError(f"{entry.name}: probe {core} must be an output")
            probes.append(core)
            continue
        name = _check_name("_".join(path), entry.name)
        width = Shape.cast(value.shape()).width
        direction = "input" if member.flow == wiring.In else "output"
        label = board[name][0] if name in board else SPEC_LABELS.get(path[-1], "")
        pins_.append(Pin(name, direction, width, label, doc))
        direct[core] = name
    names = [p.name for p in pins_]
    if len(set(names)) != len(names) or {"clk", "rst"} & set(names):
        raise ValueError(f"{entry.name}: pin names collide: {sorted(names)}")
    missing = set(entry.probes) - set(probes)
    if missing:
        raise ValueError(f"{entry.name}: probes {sorted(missing)} are not output ports")
    return pins_, buses, direct, probes


_CLOCK_PINS = (Pin("clk", "input", 1, "CP", "System clock, rising edge"),
               Pin("rst", "input", 1, "RESET", "Synchronous reset, active high (as the 8085's "
                                                "RESET OUT)"))


def pins(name: str) -> list[Pin]:
    """The exported wrapper's pins of block ``name``, in port order (clock and reset first)."""
    entry = block(name)
    return [*_CLOCK_PINS, *_plan(entry, entry.component())[0]]


# --- the file ------------------------------------------------------------------------------

#: The Verilator ``-Wall`` rules waived for the core (Amaranth's unchanged Verilog), and why.
#: Only rules that Verilator 5.006 (Debian 12's) knows as well as the newest: WIDTH covers the
#: WIDTHEXPAND and WIDTHTRUNC of later versions.
CORE_WAIVERS = {
    "WIDTH": "Yosys's Verilog writer leaves operand sizing to Verilog's context-determined "
             "width rules, which give exactly its cells' semantics (results are truncated to "
             "the target's width as the cells define)",
    "CASEINCOMPLETE": "each process assigns its default first, then a case without a default "
                      "branch overrides it; unlisted values keep the default",
    "UNUSEDSIGNAL": "intermediate nets of which synthesis uses only some bits (an adder's "
                    "carry, a bus bit a submodule ignores); they are trimmed",
    "DECLFILENAME": "one file holds the wrapper and all its core modules (<block>_core...)",
    "CMPCONST": "the register bank's range check also compares with a bound equal to the "
                "register's full range (FILTER <= 255), which is constant; synthesis drops it",
    "UNSIGNED": "likewise for a lower bound of 0 (MODE >= 0)",
}
_PROBE_WAIVER = ("PINCONNECTEMPTY", "the core's probe outputs (simulation observability, not "
                                    "chip pins) are deliberately left unconnected")


def _core_verilog(entry: Exportable, component: wiring.Component) -> tuple[str, set[str]]:
    """Amaranth's Verilog of the block as module ``<name>_core``, and its clock/reset ports."""
    text = verilog.convert(component, name=f"{entry.name}_core", emit_src=False)
    header = re.search(rf"^module {entry.name}_core\((.*?)\);", text, re.M | re.S)
    assert header is not None, "Amaranth writes the top module first"
    ports = {p.strip() for p in header.group(1).split(",")}
    signature_ports = {"__".join(path) for path, _, _ in component.signature.flatten(component)}
    extra = ports - signature_ports
    if not extra <= {"clk", "rst"}:
        raise ValueError(f"{entry.name}: ports {sorted(extra - {'clk', 'rst'})} are not in "
                         f"the signature; only the sync domain's clk and rst may be added")
    # The wrapper is the top: drop the core's top attribute (an attribute, not logic).
    text = text.replace("(* top =  1  *)\n", "", 1)
    return _REG_INIT.sub(_initial_statement, text), extra


#: A register declared with its power-up value: indent, width, name, value.
_REG_INIT = re.compile(r"^( *)reg ((?:\[[^\]]*\] )?)(\S+) += ([^;]+);$", re.M)


def _initial_statement(match: re.Match) -> str:
    """A register's power-up value as an ``initial`` statement after its declaration (the
    same value at time 0; Verilator's PROCASSINIT, which later versions raise for an
    initialiser of a register a process assigns, then has nothing to say)."""
    indent, width, name, value = match.groups()
    end = " ;" if name.startswith("\\") else ";"  # an escaped name ends at a space
    return f"{indent}reg {width}{name}{end}\n{indent}initial {name} = {value};"


def _comment(text: str) -> list[str]:
    """``text`` as ``//`` comment lines of at most 100 columns (blank lines kept)."""
    lines: list[str] = []
    for paragraph in text.split("\n"):
        indent = re.match(r" *", paragraph).group()
        lines += [f"// {line}" for line in textwrap.wrap(paragraph, 97, subsequent_indent=indent)
                  ] or ["//"]
    return lines


def _literal(value: Any) -> str:
    """A parameter value as Python source (an enum member by its name; a tuple of records,
    such as a board's pins, by their first fields)."""
    if isinstance(value, enum.Enum):
        return f"{type(value).__name__}.{value.name}"
    if isinstance(value, tuple) and value and all(map(dataclasses.is_dataclass, value)):
        first = [getattr(v, dataclasses.fields(v)[0].name) for v in value]
        return f"{len(value)} {type(value[0]).__name__} ({', '.join(map(str, first))})"
    return repr(value)


def _header(entry: Exportable, buses: list[_Bus], probes: list[str]) -> list[str]:
    cls = entry._class()
    params = entry.parameters()
    text = [
        f"{entry.name}.v: {entry.title}.",
        f"Generated by `k37 export-verilog` (k37 {metadata.version('k37')}, Amaranth "
        f"{metadata.version('amaranth')}) from {cls.__module__}.{cls.__qualname__}. Do not "
        f"edit: change the Python source and export again.",
        "",
        "Parameters: " + (", ".join(f"{k} = {_literal(v)}" for k, v in params.items())
                          or "none") + ".",
    ]
    selects = entry.chip_selects()
    if selects:
        text += ["", "Chip selects (the high address bits; the register maps below give the "
                     "low ones): " + ", ".join(f"{chip}={cs}" for chip, (cs, _) in
                                               selects.items()) + "."]
        text += [f"{chip} answers from register address {window:#04x} of its select (A4)."
                 for chip, window in SUB_WINDOWS.items() if chip in selects]
    for rm in entry.register_maps():
        text += ["", f"Register map {rm.chip}, version {rm.version} ({rm.size} bytes; the "
                     f"fields are in docs/registers.md):"]
        text += [f"  {reg.addr:#04x}  {reg.name:<14} {reg.width:>2} bits  "
                 f"{reg.access.value:<2}{'  signed' if reg.signed else ''}" for reg in rm]
    text += [
        "",
        f"Module {entry.name} gives the chip's pins (datasheet names in the port comments; active "
        f"low where the chips are) to {entry.name}_core, Amaranth's unchanged Verilog of the "
        f"block, so every cycle matches the project's simulation and reference models. All "
        f"inputs are sampled at the rising edge of clk ({_clock_text(entry.component())}).",
    ]
    if buses:
        text += [
            "Host bus: one byte access per rising clk edge with /CS low and /RD or /WR low "
            "(never both); hold a strobe low for exactly one cycle per byte. The byte read in "
            "cycle t is driven on D in cycle t+1. Multi-byte registers are little-endian: "
            "the last (most significant) byte commits a write, reading byte 0 snapshots the "
            "whole register for the bytes after it.",
        ]
    if any(m.is_signature and isinstance(m.signature, WishboneBus)
           for m in entry.component().signature.members.values()):
        text += [
            "Wishbone bus (wb_*): a classic (B4) target, 8-bit data, one register byte per "
            "address (chip select << 5 | register address). A transfer requested in cycle t "
            "(cyc, stb and sel high) is the chip's bus access of cycle t; ack is high in "
            "t + 1 with a read's byte on dat_r. The register semantics above hold unchanged.",
        ]
    if probes:
        text += [f"Probe outputs of the core, not chip pins, left unconnected here: "
                 f"{', '.join(probes)}."]
    return _comment("\n".join(text))


def _wrapper(entry: Exportable, pins_: list[Pin], buses: list[_Bus], direct: dict[str, str],
             probes: list[str], clocks: set[str]) -> list[str]:
    decls = []
    for i, p in enumerate(pins_):
        width = f"[{p.width - 1}:0]" if p.width > 1 else ""
        comma = "," if i < len(pins_) - 1 else ""
        decl = f"    {p.direction:<6} wire {width:<6} {p.name}{comma}"
        label = f"{p.label}: " if p.label else ""
        text = textwrap.wrap(f"{label}{p.doc}", 100 - 39) or [""]
        decls += [f"{decl if k == 0 else '':<36}// {t}".rstrip() for k, t in enumerate(text)]
    out = [f"module {entry.name} (", *decls, ");"]
    conns = [f".{c}({c})" for c in ("clk", "rst") if c in clocks]
    for bus in buses:
        p, c = bus.prefix, bus.core
        out += [
            f"    // Host bus{' ' + p.rstrip('_') if p else ''}: the active-low strobes become "
            f"the core's strobes; D is",
            "    // driven in the cycle after a read cycle, when the core shows the byte.",
            f"    wire [7:0] {p}r_data;",
            f"    reg        {p}d_oe;",
            f"    initial {p}d_oe = 1'b0;",
            f"    always @(posedge clk) {p}d_oe <= ~rst & ~{p}cs_n & ~{p}rd_n;",
            f"    assign {p}d = ({p}d_oe & {p}wr_n) ? {p}r_data : 8'bzzzzzzzz;",
        ]
        conns += [f".{c}addr({p}addr)", f".{c}w_stb(~{p}cs_n & ~{p}wr_n)",
                  f".{c}w_data({p}d)", f".{c}r_stb(~{p}cs_n & ~{p}rd_n)",
                  f".{c}r_data({p}r_data)"]
    conns += [f".{core}({pin})" for core, pin in direct.items()]
    conns += [f".{core}()" for core in probes]
    if probes:
        out.append(f"    /* verilator lint_off {_PROBE_WAIVER[0]} */  // {_PROBE_WAIVER[1]}")
    out += [f"    {entry.name}_core core (", ",\n".join(f"        {c}" for c in conns), "    );"]
    if probes:
        out.append(f"    /* verilator lint_on {_PROBE_WAIVER[0]} */")
    out.append("endmodule")
    return out


def verilog_text(name: str) -> str:
    """The complete exported Verilog file of block ``name``."""
    entry = block(name)
    component = entry.component()
    pins_, buses, direct, probes = _plan(entry, component)
    core, clocks = _core_verilog(entry, component)
    if buses and "clk" not in clocks:
        raise ValueError(f"{entry.name}: a block with a host bus needs the sync clock domain")
    pins_ = [p for p in _CLOCK_PINS if p.name in clocks] + pins_
    waivers = [f"/* verilator lint_off {rule} */  // {why}" for rule, why in CORE_WAIVERS.items()]
    lines = [
        *_header(entry, buses, probes),
        "",
        *_wrapper(entry, pins_, buses, direct, probes, clocks),
        "",
        f"// ---- {entry.name}_core: Amaranth's Verilog of the block, unchanged but for its "
        f"top attribute and its registers' power-up values, set by initial statements ----",
        "// Lint waivers for this machine-written part, each with its reason:",
        *waivers,
        core.rstrip("\n"),
        *(f"/* verilator lint_on {rule} */" for rule in CORE_WAIVERS),
        "",
    ]
    return "\n".join(lines)


def export_verilog(blocks: list[str] | None, out_dir: Path) -> list[Path]:
    """Write ``<block>.v`` for each named block (None or ``["all"]``: every block) to ``out_dir``.

    Returns the paths written, in registry order for ``all`` and in the given order otherwise.
    Unknown names raise ``ValueError`` before anything is written; each file is written whole
    or not at all (``OSError``).
    """
    names = [b.name for b in BLOCKS] if not blocks or blocks == ["all"] else list(blocks)
    for name in names:
        block(name)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for name in dict.fromkeys(names):
        path = out_dir / f"{name}.v"
        text = verilog_text(name)
        with atomic_open(path, "w") as f:
            f.write(text)
        paths.append(path)
    return paths
