"""The rising edge's evaluation of a CXXRTL design that runs only the parts whose inputs
changed (:func:`rise_eval`), from the units :mod:`k37.sim.backends.cxxrtl.evals` reads."""

from __future__ import annotations

import re
from typing import NamedTuple

from k37.sim.backends.cxxrtl.evals import (
    CXX_NAME,
    HEAD_LINES,
    declared_members,
    eval_units,
    needed_units,
)

__all__ = ["FALL", "PARTS", "RiseEval", "rise_eval"]


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
        rf"({CXX_NAME});", cxx)}


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
    parsed = eval_units(cxx)
    if parsed is None:
        return None
    head, units = parsed
    kept = set(needed_units([(edge == "pos", defines, text) for edge, defines, text in units
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
    wires = set(declared_members(cxx, "wire"))
    readers = {name: mask for name, mask in needs.items() if name in wires}
    touches = {name: needs.get(name, 0) for name in declared_members(cxx, "input")}
    for name in wires:
        touches[f"{name}.curr"] = needs.get(name, 0) | owner.get(name, 0)
    # Each passed value is compared after its last definition, before any reader.
    widths = {name: width for width, name in
              re.findall(rf"^\t(?:/\*\w+\*/ )?value<(\d+)> ({CXX_NAME});$", cxx, re.M)}
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
    scratch = [line for line in head if line not in HEAD_LINES]
    renamed = {re.findall(CXX_NAME, line)[-1] for line in scratch}
    members = "".join(re.sub(rf"({CXX_NAME});\n$", r"k37_\1;\n", line) for line in scratch)
    members += "".join(f"\tvalue<{widths[name]}> k37_was_{name};\n" for name in sorted(passed))
    body = re.sub(rf"\b{CXX_NAME}\b", lambda m: f"k37_{m[0]}" if m[0] in renamed else m[0],
                  "".join(lines))
    body = ("".join(line for line in head if line in HEAD_LINES) +
            f"\tuint64_t dirty = k37_dirty;\n\tk37_dirty = dirty & {FALL:#x}u;\n" + body +
            "\tk37_ran = dirty;\n\treturn converged;\n")
    return RiseEval(body, members, owner, touches, readers)


def _targets_and_reads(units: list[tuple[str, set[str], str]]
                       ) -> tuple[list[set[str]], list[set[str]]]:
    """Per unit, the registers whose next values it writes and every name it reads."""
    targets = [set(re.findall(rf"\b({CXX_NAME})\.next = ", text)) for _, _, text in units]
    reads = [set(re.findall(rf"\b{CXX_NAME}\b", re.sub(rf"\b{CXX_NAME}\.next = ", "", text)))
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
    declared = set(re.findall(rf"\b(?:wire|value|memory)<\d+> ({CXX_NAME})\b", cxx))
    inputs = set(declared_members(cxx, "input"))
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
