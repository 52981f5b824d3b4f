"""The C++ of a CXXRTL model: what K37 reads from the design's C++ and what it generates.

Yosys's ``write_cxxrtl`` writes one ``eval()`` that computes every value of the design and
one ``commit()`` of every register. :func:`design_main` wraps it in a translation unit with
what the harness (``harness.cc``; ``model.h`` declares it) asks of the design, generated from
that C++:
- commits per clock edge of only the registers that edge can change (:func:`edge_wires`);
- a rising edge that runs only the parts of the design whose inputs changed
  (:func:`rise_eval`), and a falling edge that runs only when what its registers read changed
  (:func:`fall_eval`);
- the evaluation of one output port (:func:`port_eval`) and of what a skip decision reads
  (:func:`skip_eval`), alone.
Anything the generators do not recognise falls back to CXXRTL's own ``eval()`` and
``commit()``.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import NamedTuple

__all__ = ["DESIGN_MAIN", "FALL", "PARTS", "SPLIT_COMMIT", "WHOLE_COMMIT", "RiseEval",
           "design_main", "edge_wires", "fall_eval", "port_eval", "rise_eval", "skip_eval"]

#: The design's translation unit: Yosys's C++ (its arithmetic in machine words: words.h) and
#: what the harness asks of the design.
DESIGN_MAIN = """#include "words.h"
#include "design.cc"
// `to` takes `now`, without branches (CXXRTL's commit compares first): whether it changed is
// `!= 0`. A wire's commit is k37_take(wire.curr, wire.next).
template<size_t Bits>
inline cxxrtl::chunk_t k37_take(cxxrtl::value<Bits> &to, const cxxrtl::value<Bits> &now) {{
	cxxrtl::chunk_t diff = 0;
	for (size_t i = 0; i < to.chunks; i++) {{
		diff |= to.data[i] ^ now.data[i];
		to.data[i] = now.data[i];
	}}
	return diff;
}}
namespace cxxrtl_design {{
// The design with an eval() for falling edges and one for rising edges that compute only what
// they need (fall_eval, rise_eval), and a skip's evaluation of what a skip decision reads,
// from the state (skip_eval).
struct k37_top : p_top {{
	// The parts of the design (rise_eval) whose support changed since they last ran, and those
	// that the last rising edge ran.
	uint64_t k37_dirty = ~uint64_t(0), k37_ran = ~uint64_t(0);
	bool k37_fall_ran = true;  // whether the last falling edge's evaluation ran
{members}	bool eval_fall(performer *performer = nullptr) {{{eval_fall}}}
	bool eval_peek(performer *performer = nullptr) {{{eval_peek}}}
	bool eval_port(const cxxrtl::chunk_t *curr) {{{eval_port}}}
	bool eval_rise(performer *performer = nullptr) {{{eval_rise}}}
	void eval_skip() {{{eval_skip}}}
}};
}}
cxxrtl::module *k37_make_top() {{ return new cxxrtl_design::k37_top; }}
bool k37_eval_fall(cxxrtl::module *module) {{
	return static_cast<cxxrtl_design::k37_top *>(module)->eval_fall();
}}
bool k37_eval_peek(cxxrtl::module *module) {{
	return static_cast<cxxrtl_design::k37_top *>(module)->eval_peek();
}}
bool k37_eval_port(cxxrtl::module *module, const cxxrtl::chunk_t *curr) {{
	return static_cast<cxxrtl_design::k37_top *>(module)->eval_port(curr);
}}
bool k37_eval_rise(cxxrtl::module *module) {{
	return static_cast<cxxrtl_design::k37_top *>(module)->eval_rise();
}}
uint64_t *k37_dirty(cxxrtl::module *module) {{
	return &static_cast<cxxrtl_design::k37_top *>(module)->k37_dirty;
}}
uint64_t k37_touches(cxxrtl::module *module, const cxxrtl::chunk_t *curr) {{{touches}}}
bool k37_has_eval_skip() {{ return {has_eval_skip}; }}
void k37_eval_skip(cxxrtl::module *module) {{
	static_cast<cxxrtl_design::k37_top *>(module)->eval_skip();
}}
bool k37_needs_falling_edge() {{ return {falling}; }}
bool k37_can_peek() {{ return {peek}; }}
unsigned k37_commit_fall(cxxrtl::module *module) {{{commit_fall}}}
unsigned k37_commit_rise(cxxrtl::module *module) {{{commit_rise}}}
void k37_discard_fall(cxxrtl::module *module) {{{discard_fall}}}
"""
#: A commit of only some wires of the design (``top`` is the design, ``wires`` its wires,
#: each adding its change to ``rest`` or, for the free-running state's, to ``free``). It
#: returns the harness's flags: 1 if any wire changed, 2 if any but the free-running ones.
TOP = "\tauto &top = *static_cast<cxxrtl_design::k37_top *>(module);\n"
SPLIT_COMMIT = """
""" + TOP + """	cxxrtl::chunk_t rest = 0, free = 0, c;
	const uint64_t ran = {ran};
	uint64_t marks = 0;
{wires}	top.k37_dirty |= marks;
	top.prev_p_clk = top.p_clk;
	return unsigned(rest != 0) << 1 | unsigned((rest | free) != 0);
"""
#: CXXRTL's own commit, in those flags (every change counts as a change of the rest).
WHOLE_COMMIT = " return module->commit() ? 3 : 0; "


def design_main(cxx: str, falling: str, free: Sequence[str] = (),
                reads: Sequence[str] = ()) -> str:
    """The design's translation unit for Yosys's C++ ``cxx`` (see :func:`edge_wires`).

    Its commits return whether any state changed and whether any but the registers ``free``
    (probe paths) did: one cycle that changes only those proves the rest at a fixed point, at
    no extra cost per cycle. Its ``eval_skip`` computes the signals ``reads`` (probe paths:
    what the harness reads to decide a skip) alone (:func:`skip_eval`). Its edges run only
    the parts of the design whose inputs changed (:func:`rise_eval`; the falling edge is the
    part :data:`FALL`), and a peek computes the one port it reads (:func:`port_eval`). Raises
    ValueError if one of ``free`` or ``reads`` is not in the model.
    """
    split = edge_wires(cxx)
    peeked = fall_eval(cxx) if split is not None else None
    eval_peek = " return eval(performer); " if peeked is None else f"\n{peeked[0]}\t"
    rising = rise_eval(cxx) if split is not None else None
    eval_rise = " return eval(performer); " if rising is None else f"\n{rising.body}\t"
    falling_only = fall_eval(cxx, outputs=False) if rising is not None else None
    readers, touches_of = ({}, {}) if rising is None else (rising.readers, rising.touches)
    eval_fall, fall_ran = eval_peek, ""
    if falling_only is not None:
        # The falling edge runs only if what its negedge registers read changed (the FALL
        # part, marked as the rising edge's parts are); the outputs' statements only in a peek.
        fall_ran = f"\tk37_dirty &= ~{FALL:#x}u;\n\tk37_fall_ran = true;\n"
        eval_fall = (f"\n\tk37_fall_ran = false;\n\tif (!(k37_dirty & {FALL:#x}u)) return true;\n"
                     f"{fall_ran}{falling_only[0]}\t")
        readers, touches_of = dict(readers), dict(touches_of)
        for name in falling_only[1]:
            readers[name] = readers.get(name, 0) | FALL
            for member in (name, f"{name}.curr"):
                if member in touches_of:
                    touches_of[member] |= FALL
    touches = "" if rising is None else "\n" + TOP + "".join(
        f"\tif (curr == top.{member}.data) "
        f"return {mask:#x}u;\n" for member, mask in sorted(touches_of.items()))
    touches += " return ~uint64_t(0); "
    ports = port_eval(cxx) if falling_only is not None else None
    eval_port = " return false; " if ports is None else f"\n{ports}\t"
    if split is None:
        return DESIGN_MAIN.format(falling=falling, peek="false", eval_fall=eval_fall,
                                  eval_peek=eval_peek, eval_rise=eval_rise,
                                  commit_fall=WHOLE_COMMIT, commit_rise=WHOLE_COMMIT,
                                  discard_fall="", eval_skip="", has_eval_skip="false",
                                  touches=touches, members="", eval_port=eval_port)
    members = _members(cxx)
    missing = [path for path in free if path not in members]
    if missing:
        raise ValueError(f"free-running registers {', '.join(missing)} are not in the "
                         f"compiled model")
    free_wires = {members[path] for path in free}
    skip = skip_eval(cxx, reads) if reads else None
    has_eval_skip = "false" if skip is None else "true"
    eval_skip = "" if skip is None else f"\n{skip}\t"

    def commit(names: list[str], owner: dict[str, int], ran: str) -> str:
        """Commit wires ``names``, marking their readers where they changed; those of a part
        in ``owner`` only if the part ran (``ran``: the mask of those that did), else their
        next values are unchanged."""
        parts: dict[int, list[str]] = {}
        for name in names:
            parts.setdefault(owner.get(name, 0), []).append(name)
        text = []
        for part, wires in sorted(parts.items()):
            text.append(f"\tif (ran & {part:#x}u) {{\n" if part else "\t{\n")
            for name in wires:
                flag = "free" if name in free_wires else "rest"
                text.append(f"\t\tc = k37_take(top.{name}.curr, top.{name}.next);\n"
                            f"\t\t{flag} |= c;\n")
                if readers.get(name):
                    text.append(f"\t\tmarks |= c ? {readers[name]:#x}u : 0;\n")
            text.append("\t}\n")
        return SPLIT_COMMIT.format(wires="".join(text), ran=ran)

    fall, rise, discard, peek = split
    # Undoing a falling edge leaves its next values to compute again.
    resets = "".join(f"\ttop.{name}.next = top.{name}.curr;\n" for name in discard)
    resets += f"\ttop.k37_dirty |= {FALL:#x}u;\n" if resets and fall_ran else ""
    return DESIGN_MAIN.format(
        falling=falling, peek="true" if peek else "false", eval_fall=eval_fall,
        eval_peek=fall_ran + eval_peek, eval_port=eval_port,
        eval_rise=eval_rise, eval_skip=eval_skip, has_eval_skip=has_eval_skip,
        commit_fall=commit(fall, dict.fromkeys(discard, FALL) if fall_ran else {},
                           f"top.k37_fall_ran ? {FALL:#x}u : 0"),
        commit_rise=commit(rise, {} if rising is None else rising.owner, "top.k37_ran"),
        touches=touches,
        members="" if rising is None else rising.members,
        discard_fall=f"\n{TOP}{resets}" if resets else "")


_CXX_NAME = r"[A-Za-z_]\w*"


def _declared(cxx: str, kind: str) -> list[str]:
    """The members of a kind the design declares, in order: ``"wire"`` (registers),
    ``"input"`` or ``"output"`` (ports computed by ``eval()``, not registers)."""
    pattern = (rf"^\t(?:/\*\w+\*/ )?wire<\d+> ({_CXX_NAME});$" if kind == "wire" else
               rf"^\t/\*{kind}\*/ value<\d+> ({_CXX_NAME});$")
    return re.findall(pattern, cxx, re.M)


def _eval_units(cxx: str) -> tuple[list[str], list[tuple[str, set[str], str]]] | None:
    """``eval()``'s head and units (:func:`_units`), if it computes every value in one pass
    (:func:`_one_pass`); else None."""
    body = _body(cxx, "eval(performer *performer)")
    return None if body is None or not _one_pass(body) else _units(body)


_HEAD_LINES = ("\tbool converged = true;\n", "\tbool posedge_p_clk = this->posedge_p_clk();\n",
               "\tbool negedge_p_clk = this->negedge_p_clk();\n")


def _body(cxx: str, function: str) -> str | None:
    """The body of the member function ``function`` of ``p_top`` (``eval(performer
    *performer)``, ``debug_eval()``), or None."""
    body = re.search(rf"^\w+ p_top::{re.escape(function)} \{{\n(.*?)^\}}$", cxx, re.M | re.S)
    return None if body is None else body.group(1)


def _units(body: str) -> tuple[list[str], list[tuple[str, set[str], str]]] | None:
    """A CXXRTL function body as its head (local declarations) and its units in order: edge
    blocks (``if (posedge_p_clk) {...}``: ("pos", no names, the text), likewise "neg") and
    one-line assignments (("", {the name assigned}, the line)). None if the body holds
    anything else."""
    head, units, block = [], [], None
    for line in body.splitlines(keepends=True):
        if block is not None:
            block.append(line)
            if line == "\t}\n":
                units.append((block[0][5:8], set(), "".join(block)))
                block = None
            elif not line.startswith("\t\t"):
                return None
        elif re.fullmatch(r"\tif \((pos|neg)edge_p_clk\) \{\n", line):
            block = [line]
        elif line.startswith("\t//"):
            continue
        elif re.fullmatch(rf"\tvalue<\d+> {_CXX_NAME};\n", line) or line in _HEAD_LINES:
            head.append(line)
        elif line == "\treturn converged;\n":
            pass
        else:
            match = re.match(rf"\t({_CXX_NAME})(?:\.slice<[\d,]+>\(\))? = ", line)
            if match is None or "performer" in line:
                return None
            units.append(("", {match[1]}, line))
    return None if block is not None else (head, units)


def _one_pass(body: str) -> bool:
    """Whether an ``eval()`` body writes no combinational wire's next value (a commit would
    count its changes) and never needs a second evaluation (no feedback)."""
    return not re.search(r"^\t\w+\.next = ", body, re.M) and "converged = false" not in body


def _needed(units: list[tuple[bool, set[str], str]], roots: set[str]) -> tuple[list[str], set[str]]:
    """The units that compute ``roots`` (and the kept edge blocks), transitively, in order
    (statements are in dependency order), and every name they read."""
    needed, kept = set(roots), []
    for always, defines, text in reversed(units):
        if always or defines & needed:
            kept.append(text)
            needed |= set(re.findall(rf"\b{_CXX_NAME}\b", text))
    return kept[::-1], needed


def fall_eval(cxx: str, outputs: bool = True) -> tuple[str, set[str]] | None:
    """The body of an ``eval()`` for falling edges of ``clk`` only, from CXXRTL's C++, and the
    names it reads.

    CXXRTL's ``eval()`` computes every combinational value, although a falling edge needs only
    those that the negedge registers' next values (and, with ``outputs``, the output ports)
    depend on: the body keeps the negedge blocks, the statements that compute an output port,
    and those they read, transitively (statements are in dependency order). Other
    combinational values keep what the last full ``eval()`` left, so the harness treats them
    as stale. None if the body holds anything but declarations, assignments and edge blocks
    (then eval() serves).
    """
    body = _body(cxx, "eval(performer *performer)")
    parsed = None if body is None else _units(body)
    if parsed is None:
        return None
    head, units = parsed
    ports = set(_declared(cxx, "output")) if outputs else set()
    kept, reads = _needed([(edge == "neg" or bool(defines & ports), defines, text)
                           for edge, defines, text in units if edge != "pos"], set())
    return "".join(head) + "".join(kept) + "\treturn converged;\n", reads


class RiseEval(NamedTuple):
    """An ``eval()`` for rising edges that evaluates only the parts of the design whose inputs
    changed (:func:`rise_eval`)."""

    #: The function's body: it reads ``k37_dirty``, clears it and leaves in ``k37_ran`` the
    #: parts that ran.
    body: str
    #: Declarations of the members it keeps between calls: ``eval()``'s locals (renamed
    #: ``k37_<name>``) and the last value of each combinational value one part passes another.
    members: str
    #: The part (its bit) that computes each posedge register's next value.
    owner: dict[str, int]
    #: The parts (a mask) that read each wire or input, or own it (must run after a harness
    #: writes it), by the member that holds its current value (``p_a.curr``, ``p_input``).
    touches: dict[str, int]
    #: The parts that read each wire.
    readers: dict[str, int]


#: Most parts :func:`rise_eval` tells apart (bits of one 64-bit mask, less the falling
#: edge's: :data:`FALL`).
PARTS = 63
#: The part that stands for the falling edge's statements (:func:`design_main`).
FALL = 1 << 63


def _hdl_paths(cxx: str) -> dict[str, list[str]]:
    """The design hierarchy's path of each member or local that CXXRTL names (its
    ``\\hdlname``)."""
    return {m[2]: m[1].split() for m in re.finditer(
        rf"// \\hdlname: ([^\n]*)\n(?:\t//[^\n]*\n)*\t(?:/\*\w+\*/ )?(?:wire|value)<\d+> "
        rf"({_CXX_NAME});", cxx)}


def _module(name: str, paths: dict[str, list[str]]) -> tuple[str, ...]:
    """The module of the hierarchy that a C++ name of CXXRTL's belongs to: from its
    ``\\hdlname``, else from the name itself (CXXRTL writes ``_`` as ``__`` and any other
    character but a letter or a digit as two hex digits between ``_``:
    ``i_flatten_5c_plant__x_2e__24_19`` is cell ``flatten\\plant_x.$19`` of module
    ``plant_x``)."""
    if name in paths:
        return tuple(paths[name][:-1])
    text = re.sub(r"_(?:([0-9a-f]{2})_|_)", lambda m: chr(int(m[1], 16)) if m[1] else "_",
                  name[2:])
    return tuple(text.removeprefix("flatten\\").replace("\\", "").split(".")[:-1])


def rise_eval(cxx: str) -> RiseEval | None:
    """An ``eval()`` for rising edges of ``clk`` only, from CXXRTL's C++, that evaluates only
    the parts of the design whose inputs changed since they last ran.

    The statements that the posedge registers' next values read, transitively (as
    :func:`fall_eval`: not those that only the output ports, the negedge registers or nothing
    read), are split into parts: those of one module of the hierarchy (coarser modules if there
    are more than :data:`PARTS`), those that follow the inputs alone (:func:`_input_driven`),
    and per module those of its values that read none of its part's. Each runs under
    ``if (dirty & part)``. Every value a statement computes is kept between calls (``eval()``'s
    locals become members), so a statement whose inputs are unchanged since it last ran still
    holds its value, and a part whose registers, inputs and values read from other parts are
    unchanged computes the next values it computed then, which its registers still hold (a
    commit copies next to current and leaves next as it is): it need not run. So a part runs if
    the commits marked it (the readers of each wire that changed, :func:`design_main`), the
    harness did (the readers of what it writes), or a part before it in this evaluation changed
    a combinational value it reads (each such value is compared with its last value after the
    part that computes it). The harness treats the combinational values as stale after an edge
    anyway. None where :func:`fall_eval` is, or where ``eval()`` writes a combinational wire's
    next value (a commit counts its changes) or needs more than one evaluation: then eval()
    serves, whole."""
    parsed = _eval_units(cxx)
    if parsed is None:
        return None
    head, units = parsed
    kept = set(_needed([(edge == "pos", defines, text) for edge, defines, text in units
                        if edge != "neg"], set())[0])
    units = [unit for unit in units if unit[0] != "neg" and unit[2] in kept]
    targets, reads = _targets_and_reads(units)
    driven = _input_driven(cxx, units, targets, reads)
    paths = _hdl_paths(cxx)
    registers = {name: _module(name, paths) for i, target in enumerate(targets)
                 if i not in driven for name in target}
    depth = max(map(len, registers.values()), default=0)
    while len({module[:depth] for module in registers.values()}) > PARTS - bool(driven):
        depth -= 1
    parts = sorted({module[:depth] for module in registers.values()})
    owner = {name: 1 << parts.index(module[:depth]) for name, module in registers.items()}
    # The statements that read the inputs alone have a part of their own, after the modules'.
    inputs_part = 1 << len(parts)
    owner.update(dict.fromkeys((name for i in driven for name in targets[i]), inputs_part))
    # A statement belongs to the part of its registers; a combinational one to the part whose
    # values it reads if one part's only, the inputs' part aside (so that a value passes to
    # another part where it is narrowest: the encoder's quadrature lines, not the plant's
    # position), else to its module's part (that of the nearest module above it with
    # registers, for one without) if it reads a value of that part, else to a part set aside
    # for such values of the module (while bits last): a plant's velocity command follows the
    # DAC and the commands, and its position's part need not compute it at every cycle.
    # Which part a statement is in matters for speed only: the readers of what it reads follow.
    part_of: dict[str, int] = {}
    masks = []
    aside: dict[int, int] = {}  # a module's part: the part of its values that read no state of it
    for i, ((edge, defines, _), target, read) in enumerate(zip(units, targets, reads,
                                                                 strict=True)):
        if i in driven:
            mask = inputs_part
        elif edge == "pos":
            mask = owner[min(target)]
        else:
            sources = {part_of.get(name, owner.get(name)) for name in read} - {None}
            if len(sources - {inputs_part}) == 1:
                sources -= {inputs_part}
            module = _module(min(defines), paths)
            above = [k for k in range(len(module), -1, -1) if module[:k] in parts]
            home = 1 << parts.index(module[:above[0]]) if above else 1
            if len(sources) == 1:
                mask = sources.pop()
            elif home in sources or (home not in aside and len(parts) + len(aside) >= PARTS - 1):
                mask = home
            else:
                mask = aside.setdefault(home, inputs_part << (len(aside) + 1))
        masks.append(mask)
        part_of.update(dict.fromkeys(defines, mask))
    needs: dict[str, int] = {}
    for read, mask in zip(reads, masks, strict=True):
        for name in read:
            needs[name] = needs.get(name, 0) | mask
    passed = {name: needs[name] & ~mask for name, mask in part_of.items()
              if needs.get(name, 0) & ~mask}
    wires = set(_declared(cxx, "wire"))
    readers = {name: mask for name, mask in needs.items() if name in wires}
    touches = {name: needs.get(name, 0) for name in _declared(cxx, "input")}
    for name in wires:
        touches[f"{name}.curr"] = needs.get(name, 0) | owner.get(name, 0)
    # Each passed value is compared after its last definition, before any reader.
    widths = {name: width for width, name in
              re.findall(rf"^\t(?:/\*\w+\*/ )?value<(\d+)> ({_CXX_NAME});$", cxx, re.M)}
    last = {name: i for i, (_, defines, _) in enumerate(units) for name in defines}
    after: dict[int, list[str]] = {}
    for name in sorted(passed):
        after.setdefault(last[name], []).append(name)
    statements = []  # (defines, reads, text, part), each compare after its value's definition
    for i, ((_, defines, text), read, mask) in enumerate(zip(units, reads, masks, strict=True)):
        statements.append((defines, read, text, mask))
        statements += [({name}, {name}, f"\tif (k37_take(k37_was_{name}, {name})) dirty |= "
                        f"{passed[name]:#x}u;\n", mask) for name in after.get(i, ())]
    order = _grouped([(defines, read) for defines, read, _, _ in statements],
                     [mask for *_, mask in statements])
    lines, run = [], 0
    for _, _, text, mask in (statements[i] for i in order):
        if mask != run:
            lines.append(("\t}\n" if run else "") + f"\tif (dirty & {mask:#x}u) {{\n")
            run = mask
        lines.append(text)
    lines.append("\t}\n" if run else "")
    # eval()'s locals become members, renamed so as not to hide the design's outlined members
    # of the same names.
    scratch = [line for line in head if line not in _HEAD_LINES]
    renamed = {re.findall(_CXX_NAME, line)[-1] for line in scratch}
    members = "".join(re.sub(rf"({_CXX_NAME});\n$", r"k37_\1;\n", line) for line in scratch)
    members += "".join(f"\tvalue<{widths[name]}> k37_was_{name};\n" for name in sorted(passed))
    body = re.sub(rf"\b{_CXX_NAME}\b", lambda m: f"k37_{m[0]}" if m[0] in renamed else m[0],
                  "".join(lines))
    body = ("".join(line for line in head if line in _HEAD_LINES) +
            f"\tuint64_t dirty = k37_dirty;\n\tk37_dirty = dirty & {FALL:#x}u;\n" + body +
            "\tk37_ran = dirty;\n\treturn converged;\n")
    return RiseEval(body, members, owner, touches, readers)


def _targets_and_reads(units: list[tuple[str, set[str], str]]
                       ) -> tuple[list[set[str]], list[set[str]]]:
    """Per unit, the registers whose next values it writes and every name it reads."""
    targets = [set(re.findall(rf"\b({_CXX_NAME})\.next = ", text)) for _, _, text in units]
    reads = [set(re.findall(rf"\b{_CXX_NAME}\b", re.sub(rf"\b{_CXX_NAME}\.next = ", "", text)))
             for _, _, text in units]
    return targets, reads


def _input_driven(cxx: str, units: list[tuple[str, set[str], str]], targets: list[set[str]],
                  reads: list[set[str]]) -> set[int]:
    """The units (by index) whose values follow the input ports alone: every value of the
    design that they read is an input or a value of such a unit (a register whose next value
    reads no state: a fault input's sampling register, a bus register bank's write strobe; a
    combinational copy or limit of a parameter). Kept in a part of their own, they run when an
    input changes, not whenever a register of their module does. A value is a name the C++
    declares as a wire, a value or a memory (a member or a local), or one named as CXXRTL names
    them (``p_``, ``i_``, ``memory_``)."""
    declared = set(re.findall(rf"\b(?:wire|value|memory)<\d+> ({_CXX_NAME})\b", cxx))
    inputs = set(_declared(cxx, "input"))
    driven: set[int] = set()
    for i, ((_, defines, _), target, read) in enumerate(zip(units, targets, reads, strict=True)):
        values = {name for name in read if name in declared or
                  re.match(r"(?:p|i|memory)_", name)}
        if values - defines <= inputs:
            driven.add(i)
            inputs |= defines | target
    return driven


def _grouped(units: list[tuple[set[str], set[str]]], masks: list[int]) -> list[int]:
    """An order of statements (each: the names it defines, those it reads) that keeps their
    dependencies and runs statements of one mask together, so that few guards test them: a
    statement comes after every earlier one that defines a name it reads or defines, or reads
    a name it defines; among those ready, one of the current mask comes first."""
    last: dict[str, int] = {}    # the latest definition of each name so far
    readers: dict[str, list[int]] = {}  # the reads of each name since its latest definition
    after: list[set[int]] = []
    for i, (defines, reads) in enumerate(units):
        deps = {last[name] for name in reads | defines if name in last}
        for name in defines:
            deps.update(readers.pop(name, ()))
        after.append(deps)
        for name in reads:
            readers.setdefault(name, []).append(i)
        for name in defines:
            last[name] = i
    waiting = [len(deps) for deps in after]
    unblocks: list[list[int]] = [[] for _ in units]
    for i, deps in enumerate(after):
        for j in deps:
            unblocks[j].append(i)
    ready = {i for i, n in enumerate(waiting) if n == 0}
    order, mask = [], None
    while ready:
        same = [i for i in ready if masks[i] == mask]
        i = min(same or ready)
        mask = masks[i]
        ready.remove(i)
        order.append(i)
        for j in unblocks[i]:
            waiting[j] -= 1
            if waiting[j] == 0:
                ready.add(j)
    return order


def port_eval(cxx: str) -> str | None:
    """The body of ``bool eval_port(const chunk_t *curr)``: it computes the output port whose
    value is at ``curr`` from the state, with the statements of ``eval()`` it depends on
    (transitively) and nothing else, and returns true; false for any other value. A wait that
    peeks at one port needs no other (``k37_eval_port``). None where :func:`skip_eval` is."""
    parsed = _eval_units(cxx)
    if parsed is None:
        return None
    head, units = parsed
    comb = [(False, defines, text) for edge, defines, text in units if not edge]
    local = {re.findall(_CXX_NAME, line)[-1]: line for line in head if line not in _HEAD_LINES}
    cases = []
    for port in _declared(cxx, "output"):
        kept, names = _needed(comb, {port})
        lines = [local[name] for name in sorted(names & local.keys())] + kept
        cases.append(f"\tif (curr == {port}.data) {{\n" + "".join(f"\t{line}" for line in lines)
                     + "\t\treturn true;\n\t}\n")
    return "".join(cases) + "\treturn false;\n"


def skip_eval(cxx: str, paths: Sequence[str]) -> str | None:
    """The body of a function that computes the combinational values of the signals
    ``paths`` (probe paths: what a skip decision reads) and of the output ports (what a wait
    watches) from the state, and nothing else.

    A settle evaluates the whole design to read a handful of signals; this evaluates only the
    statements of ``eval()`` those signals depend on, transitively, and for a signal that
    CXXRTL computes only in its debug outline, the statements of ``debug_eval()`` it depends on
    (which read members that ``eval()`` computes: those are computed first). Registers and
    inputs are read as they are. Edge blocks are left out: the harness calls it between
    edges. None if a body is not shaped as expected, or ``eval()`` writes a combinational
    wire's next value (then a value may need a second evaluation: the harness settles).
    """
    debug_body = _body(cxx, "debug_eval()")
    parsed, debug = _eval_units(cxx), None if debug_body is None else _units(debug_body)
    if parsed is None or debug is None:
        return None
    members = _members(cxx)
    roots = set(_declared(cxx, "output"))
    for path in paths:
        if path not in members:
            raise ValueError(f"the free-running state's signal {path!r} is not in the "
                             f"compiled model")
        roots.add(members[path])
    head, units = parsed
    units = [(False, defines, text) for edge, defines, text in units if not edge]
    debug_head, debug_units = debug
    outlined, outline_reads = _needed(debug_units, roots)
    # The outline's own values (its locals, and the outlined members it assigns) are computed
    # in its block; the members it reads otherwise are eval()'s, computed before it. Each
    # part is a block of its own, so that eval()'s locals never shadow the outline's members.
    in_outline = {re.findall(_CXX_NAME, line)[-1] for line in debug_head}
    in_outline |= {name for _, defines, _ in debug_units for name in defines}
    kept, _ = _needed(units, (roots | outline_reads) - in_outline)
    blocks = (head + kept, debug_head + outlined)
    return "".join("\t{\n" + "".join("\t" + line for line in block) + "\t}\n"
                   for block in blocks if block)


def _members(cxx: str) -> dict[str, str]:
    """The C++ member behind each debug item of the design, by probe path (an alias's or an
    outline's is the member it reads)."""
    found = re.findall(rf'^\t\titems->add\(path, "([^"]*)", "[^"]*", (?:debug_alias\(\), |'
                       rf'debug_eval_outline, )?({_CXX_NAME})[,)]', cxx, re.M)
    return {name.replace(" ", "."): member for name, member in found}


def edge_wires(cxx: str) -> tuple[list[str], list[str], list[str], bool] | None:
    """Which wires each edge of ``clk`` can change, from CXXRTL's C++ of a design.

    CXXRTL's ``commit()`` compares every wire (register) of the design with its next value,
    although a falling edge of ``clk`` only writes the negedge domain's registers and a rising
    edge only the posedge ones. Returns the wires to commit after a falling edge, after a
    rising edge, the wires a falling edge's ``eval()`` writes (to discard them), and whether
    the falling edge's ``eval()`` computes every combinational value as a settle with ``clk``
    high would (no feedback, no memory, ``clk`` is not used as data), so that the harness may
    read the outputs there. Wires written outside the edge blocks, or never written, are in
    both commits. None if the C++ is not shaped as expected (one flat module, one clock): the
    harness then commits everything.
    """
    if len(re.findall(r"^struct p_\w+ : public module \{$", cxx, re.M)) != 1:
        return None
    if "memory<" in cxx or re.search(r"\b(?:pos|neg)edge_p_(?!clk\b)\w+\(\)", cxx):
        return None
    commit = re.search(r"^\tbool commit\(ObserverT &observer\) \{\n(.*?)\n\t\treturn changed;\n"
                       r"\t\}$", cxx, re.M | re.S)
    body = re.search(r"^bool p_top::eval\(performer \*performer\) \{\n(.*?)^\}$", cxx,
                     re.M | re.S)
    if commit is None or body is None:
        return None
    wires, declared = [], set(_declared(cxx, "wire"))
    for line in commit.group(1).splitlines():
        line = line.strip()
        if line in ("bool changed = false;", "prev_p_clk = p_clk;"):
            continue
        match = re.fullmatch(rf"if \(({_CXX_NAME})\.commit\(observer\)\) changed = true;",
                             line)
        if match is None or match[1] not in declared:
            return None
        wires.append(match[1])
    written: dict[str, set[str]] = {"pos": set(), "neg": set(), "comb": set()}
    edge = None
    for line in body.group(1).splitlines():
        start = re.fullmatch(r"\tif \((pos|neg)edge_p_clk\) \{", line)
        if edge is None and start:
            edge = start[1]
        elif edge is not None and line == "\t}":
            edge = None
        else:
            written[edge or "comb"].update(re.findall(rf"\b({_CXX_NAME})\.next\b", line))
    fall = [w for w in wires if not (w in written["pos"] and w not in written["neg"] and
                                     w not in written["comb"])]
    rise = [w for w in wires if not (w in written["neg"] and w not in written["pos"] and
                                     w not in written["comb"])]
    discard = [w for w in wires if w in written["neg"]]
    peek = (not written["comb"] and "converged = false" not in body.group(1) and
            not _clock_as_data(body.group(1)))
    return fall, rise, discard, peek


def _clock_as_data(body: str) -> bool:
    """Whether an ``eval()`` body reads ``p_clk`` other than through the edge detectors.

    Yosys copies the clock into each submodule's ``clk`` (``p_sub_2e_clk = p_clk;``); such
    copies, declared and never read but by further copies, are not data.
    """
    copies = {"p_clk"}
    lines = body.splitlines()
    grew = True
    while grew:
        grew = False
        for line in lines:
            match = re.fullmatch(rf"\t({_CXX_NAME}) = ({_CXX_NAME});", line)
            if match and match[2] in copies and match[1] not in copies:
                copies.add(match[1])
                grew = True
    for line in lines:
        names = set(re.findall(rf"\b{_CXX_NAME}\b", line.split("//")[0])) & copies
        if not names:
            continue
        copy = re.fullmatch(rf"\t({_CXX_NAME}) = ({_CXX_NAME});", line)
        if copy and copy[2] in copies:
            continue
        if re.fullmatch(rf"\tvalue<1> {_CXX_NAME};", line):
            continue
        return True
    return False


