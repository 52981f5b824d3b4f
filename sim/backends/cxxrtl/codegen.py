"""The C++ of a CXXRTL model: the translation unit K37 generates around the design's C++.

Yosys's ``write_cxxrtl`` writes one ``eval()`` that computes every value of the design and
one ``commit()`` of every register. :func:`design_main` wraps it in a translation unit with
what the harness (``harness.cc``; ``model.h`` declares it) asks of the design, generated from
that C++ (:mod:`k37.sim.backends.cxxrtl.evals` reads it):
- commits per clock edge of only the registers that edge can change
  (:func:`~k37.sim.backends.cxxrtl.evals.edge_wires`);
- a rising edge that runs only the parts of the design whose inputs changed
  (:func:`~k37.sim.backends.cxxrtl.rise.rise_eval`), and a falling edge that runs only when what
  its registers read changed (:func:`~k37.sim.backends.cxxrtl.evals.fall_eval`);
- the evaluation of one output port (:func:`~k37.sim.backends.cxxrtl.evals.port_eval`) and of
  what a skip decision reads (:func:`~k37.sim.backends.cxxrtl.evals.skip_eval`), alone.
Anything the generators do not recognise falls back to CXXRTL's own ``eval()`` and
``commit()``.
"""

from __future__ import annotations

from collections.abc import Sequence

from k37.sim.backends.cxxrtl.evals import edge_wires, fall_eval, member_paths, port_eval, skip_eval
from k37.sim.backends.cxxrtl.rise import FALL, rise_eval

__all__ = ["DESIGN_MAIN", "SPLIT_COMMIT", "WHOLE_COMMIT", "design_main"]

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
    members = member_paths(cxx)
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
