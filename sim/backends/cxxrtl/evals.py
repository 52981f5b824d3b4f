"""What K37 reads from the C++ that Yosys's ``write_cxxrtl`` writes of a design, and the partial
evaluations it makes of it (:mod:`k37.sim.backends.cxxrtl.codegen` puts them together).

CXXRTL's ``eval()`` is read as units (:func:`eval_units`): its local declarations, its edge
blocks and its one-line assignments, in dependency order. From them: a falling edge's
evaluation (:func:`fall_eval`), one output port's (:func:`port_eval`), what a skip decision
reads (:func:`skip_eval`), and which registers each clock edge commits (:func:`edge_wires`).
Each gives None for C++ it does not recognise; CXXRTL's own ``eval()`` then serves.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

__all__ = ["CXX_NAME", "HEAD_LINES", "declared_members", "edge_wires", "eval_units",
           "fall_eval", "member_paths", "needed_units", "port_eval", "skip_eval"]

#: A C++ name as CXXRTL writes them.
CXX_NAME = r"[A-Za-z_]\w*"


def declared_members(cxx: str, kind: str) -> list[str]:
    """The members of a kind the design declares, in order: ``"wire"`` (registers),
    ``"input"`` or ``"output"`` (ports computed by ``eval()``, not registers)."""
    pattern = (rf"^\t(?:/\*\w+\*/ )?wire<\d+> ({CXX_NAME});$" if kind == "wire" else
               rf"^\t/\*{kind}\*/ value<\d+> ({CXX_NAME});$")
    return re.findall(pattern, cxx, re.M)


def eval_units(cxx: str) -> tuple[list[str], list[tuple[str, set[str], str]]] | None:
    """``eval()``'s head and units (:func:`_units`), if it computes every value in one pass
    (:func:`_one_pass`); else None."""
    body = _body(cxx, "eval(performer *performer)")
    return None if body is None or not _one_pass(body) else _units(body)


HEAD_LINES = ("\tbool converged = true;\n", "\tbool posedge_p_clk = this->posedge_p_clk();\n",
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
        elif re.fullmatch(rf"\tvalue<\d+> {CXX_NAME};\n", line) or line in HEAD_LINES:
            head.append(line)
        elif line == "\treturn converged;\n":
            pass
        else:
            match = re.match(rf"\t({CXX_NAME})(?:\.slice<[\d,]+>\(\))? = ", line)
            if match is None or "performer" in line:
                return None
            units.append(("", {match[1]}, line))
    return None if block is not None else (head, units)


def _one_pass(body: str) -> bool:
    """Whether an ``eval()`` body writes no combinational wire's next value (a commit would
    count its changes) and never needs a second evaluation (no feedback)."""
    return not re.search(r"^\t\w+\.next = ", body, re.M) and "converged = false" not in body


def needed_units(units: list[tuple[bool, set[str], str]],
                 roots: set[str]) -> tuple[list[str], set[str]]:
    """The units that compute ``roots`` (and the kept edge blocks), transitively, in order
    (statements are in dependency order), and every name they read."""
    needed, kept = set(roots), []
    for always, defines, text in reversed(units):
        if always or defines & needed:
            kept.append(text)
            needed |= set(re.findall(rf"\b{CXX_NAME}\b", text))
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
    ports = set(declared_members(cxx, "output")) if outputs else set()
    kept, reads = needed_units([(edge == "neg" or bool(defines & ports), defines, text)
                           for edge, defines, text in units if edge != "pos"], set())
    return "".join(head) + "".join(kept) + "\treturn converged;\n", reads


def port_eval(cxx: str) -> str | None:
    """The body of ``bool eval_port(const chunk_t *curr)``: it computes the output port whose
    value is at ``curr`` from the state, with the statements of ``eval()`` it depends on
    (transitively) and nothing else, and returns true; false for any other value. A wait that
    peeks at one port needs no other (``k37_eval_port``). None where :func:`skip_eval` is."""
    parsed = eval_units(cxx)
    if parsed is None:
        return None
    head, units = parsed
    comb = [(False, defines, text) for edge, defines, text in units if not edge]
    local = {re.findall(CXX_NAME, line)[-1]: line for line in head if line not in HEAD_LINES}
    cases = []
    for port in declared_members(cxx, "output"):
        kept, names = needed_units(comb, {port})
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
    parsed, debug = eval_units(cxx), None if debug_body is None else _units(debug_body)
    if parsed is None or debug is None:
        return None
    members = member_paths(cxx)
    roots = set(declared_members(cxx, "output"))
    for path in paths:
        if path not in members:
            raise ValueError(f"the free-running state's signal {path!r} is not in the "
                             f"compiled model")
        roots.add(members[path])
    head, units = parsed
    units = [(False, defines, text) for edge, defines, text in units if not edge]
    debug_head, debug_units = debug
    outlined, outline_reads = needed_units(debug_units, roots)
    # The outline's own values (its locals, and the outlined members it assigns) are computed
    # in its block; the members it reads otherwise are eval()'s, computed before it. Each
    # part is a block of its own, so that eval()'s locals never shadow the outline's members.
    in_outline = {re.findall(CXX_NAME, line)[-1] for line in debug_head}
    in_outline |= {name for _, defines, _ in debug_units for name in defines}
    kept, _ = needed_units(units, (roots | outline_reads) - in_outline)
    blocks = (head + kept, debug_head + outlined)
    return "".join("\t{\n" + "".join("\t" + line for line in block) + "\t}\n"
                   for block in blocks if block)


def member_paths(cxx: str) -> dict[str, str]:
    """The C++ member behind each debug item of the design, by probe path (an alias's or an
    outline's is the member it reads)."""
    found = re.findall(rf'^\t\titems->add\(path, "([^"]*)", "[^"]*", (?:debug_alias\(\), |'
                       rf'debug_eval_outline, )?({CXX_NAME})[,)]', cxx, re.M)
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
    wires, declared = [], set(declared_members(cxx, "wire"))
    for line in commit.group(1).splitlines():
        line = line.strip()
        if line in ("bool changed = false;", "prev_p_clk = p_clk;"):
            continue
        match = re.fullmatch(rf"if \(({CXX_NAME})\.commit\(observer\)\) changed = true;",
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
            written[edge or "comb"].update(re.findall(rf"\b({CXX_NAME})\.next\b", line))
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
            match = re.fullmatch(rf"\t({CXX_NAME}) = ({CXX_NAME});", line)
            if match and match[2] in copies and match[1] not in copies:
                copies.add(match[1])
                grew = True
    for line in lines:
        names = set(re.findall(rf"\b{CXX_NAME}\b", line.split("//")[0])) & copies
        if not names:
            continue
        copy = re.fullmatch(rf"\t({CXX_NAME}) = ({CXX_NAME});", line)
        if copy and copy[2] in copies:
            continue
        if re.fullmatch(rf"\tvalue<1> {CXX_NAME};", line):
            continue
        return True
    return False
