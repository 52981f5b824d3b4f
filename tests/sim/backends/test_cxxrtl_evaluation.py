# amaranth: UnusedElaboratable=no
"""How the compiled CXXRTL backend evaluates a design: the falling edge only where there is
falling-edge logic, commits split by edge, the rising edge by parts under dirty marks, the skip
decision's own evaluation, and the machine-word arithmetic of the generated C++ against
CXXRTL's own."""


import re
import subprocess

from k37.firmware_model.job import demo_job
from k37.hdl.chipset import map as chipset_map
from k37.sim.backends.cxxrtl import build, rise
from k37.sim.backends.cxxrtl.backend import CxxrtlBackend
from k37.sim.backends.cxxrtl.evals import edge_wires, fall_eval, skip_eval
from k37.sim.backends.cxxrtl.rise import rise_eval
from k37.sim.backends.factory import make_backend
from k37.sim.machine.system import System
from k37.sim.run import runner


def test_only_designs_with_falling_edge_logic_evaluate_the_falling_edge(backends, simple):
    assert backends[1].needs_falling_edge
    assert not simple[1].needs_falling_edge


def _edge_wires(backend: CxxrtlBackend):
    return edge_wires((backend.model.path.parent / "design.cc").read_text())


def test_commits_are_split_by_edge_and_waits_peek_where_the_code_allows(backends, simple,
                                                                       peeking):
    for zoo in (backends, simple, peeking):
        fall, rise, discard, _ = _edge_wires(zoo[1])
        assert set(discard) <= set(fall)
        assert set(fall) | set(rise) >= set(discard) and rise
    assert not _edge_wires(backends[1])[3]  # the bit chain needs several evaluations
    assert _edge_wires(simple[1])[3] and not _edge_wires(simple[1])[2]
    fall, rise, discard, peek = _edge_wires(peeking[1])
    assert peek and discard and not set(discard) & set(rise)


def test_the_simulated_machine_splits_its_commits_and_peeks():
    system = make_backend(System(), "cxxrtl")
    fall, rise, discard, peek = _edge_wires(system)
    assert peek and discard == fall and len(rise) > 5 * len(fall)
    cxx = (system.model.path.parent / "design.cc").read_text()
    pruned = fall_eval(cxx)  # the falling edge evaluates the K3702s and the outputs only
    assert pruned is not None and 0 < pruned[0].count(" = ") < cxx.count(" = ") / 3
    whole = cxx[cxx.index("bool p_top::eval("):cxx.index("void p_top::debug_eval(")]
    rising = rise_eval(cxx)  # the rising edge leaves out what only outputs and K3702s read
    assert rising is not None and 0 < rising.body.count(" = ") < 0.9 * whole.count(" = ")
    assert "if (posedge_p_clk)" in rising.body and "if (negedge_p_clk)" not in rising.body
    system.close()


def test_a_rising_edge_runs_a_part_only_when_what_it_reads_changed():
    """The machine's rising edge (rise.rise_eval) runs each module's statements under a guard
    of its own, and the plants' position and velocity, which change at every cycle of a move,
    are read by the plants alone: an encoder reads its plant through the quadrature lines,
    compared after the plant's statements, and the K3701 not at all. What follows the inputs
    alone (the plants' fault sampling, their speed limit) has a part of its own, which a
    move does not run; so has a plant's velocity command, which follows the DAC."""
    system = make_backend(System(), "cxxrtl")
    cxx = (system.model.path.parent / "design.cc").read_text()
    system.close()
    rising = rise_eval(cxx)
    assert rising is not None

    plant, encoder = rising.owner["p_plant__x_2e_velocity"], rising.owner[
        "p_chipset_2e_encoder__x_2e_a__level"]
    k3701 = rising.owner["p_chipset_2e_k3701_2e_x__pos"]
    assert len(set(rising.owner.values())) > 10 and len({plant, encoder, k3701}) == 3
    for register in ("p_plant__x_2e_before", "p_plant__x_2e_velocity"):
        assert rising.readers[register] == plant
    blocks = [(int(guard, 16), block) for guard, block in re.findall(
        r"if \(dirty & (0x[0-9a-f]+)u\) \{\n(.*?)\n\t\}\n", rising.body, re.S)]
    passed = []  # (the part that computes a value, the value, the parts it marks)
    for guard, block in blocks:
        passed += [(guard, name, int(mask, 16)) for name, mask in re.findall(
            r"k37_take\(k37_was_(\w+), \w+\)\) dirty \|= (0x[0-9a-f]+)u", block)]
    lines = {name for source, name, marks in passed if source == plant and marks & encoder}
    assert lines == {f"p_chipset_2e_encoder__x_2e_{line}" for line in ("a", "a__n", "b", "b__n")}
    assert not any(marks & k3701 for source, _, marks in passed if source == plant)
    assert rising.body.count("if (dirty & ") >= len(set(rising.owner.values()))
    faults = {rising.owner[f"p_plant__{axis}_2e_{name}"]
              for axis in "xy" for name in ("glitch__a", "glitch__b", "break__a")}
    assert len(faults) == 1 and not faults & {plant, encoder, k3701}
    inputs = faults.pop()
    assert rising.touches["p_x____glitch__a"] & inputs and not rising.touches["p_x____vmax"] & plant
    assert not any(rising.readers[name] & inputs for name in rising.readers
                   if rising.owner.get(name) == plant)
    command = {guard for guard, block in blocks if "p_x____dac" in block}
    assert command and not command & {plant, encoder, k3701, inputs}


def test_only_statements_that_read_inputs_alone_count_as_input_driven():
    """rise._input_driven: a copy of an input, a register sampling it and what reads only
    that register follow the inputs; a statement that reads a memory (state, whatever its
    name) or a register with state of its own does not."""
    cxx = ("\t/*input*/ value<1> p_a;\n\twire<1> p_r;\n\twire<1> p_s;\n"
           "\tmemory<1> memory_p_m { 4u };\n")
    units = [("", {"i_x"}, "\ti_x = not_u<1>(p_a);\n"),
             ("pos", set(), "\tif (posedge_p_clk) {\n\t\tp_r.next = i_x;\n\t}\n"),
             ("", {"i_y"}, "\ti_y = memory_p_m[0];\n"),
             ("", {"i_z"}, "\ti_z = and_uu<1>(p_r.curr, p_a);\n"),
             ("pos", set(), "\tif (posedge_p_clk) {\n\t\tp_s.next = not_u<1>(p_s.curr);\n\t}\n"),
             ("", {"i_w"}, "\ti_w = or_uu<1>(p_s.curr, p_a);\n")]
    assert rise._input_driven(cxx, units, *rise._targets_and_reads(units)) == {0, 1, 3}


def test_a_skip_decision_evaluates_its_own_signals_alone_as_a_settle_would():
    """The machine's skip evaluation (evals.skip_eval) computes the free-running state's
    signals, quiet and every output from the state as a settle does: checked after each of
    8,000 cycles of the demo's circle in motion (feed pulses, steps, accel/decel, plants,
    encoders), bus reads and writes of a new feed word, and a new speed limit (the last two
    change values CXXRTL computes only in its debug outline), each left unsettled."""
    job = demo_job()
    backend = runner.build_backend(job, "cxxrtl")
    cxx = (backend.model.path.parent / "design.cc").read_text()
    pruned = skip_eval(cxx, backend._free.reads())
    assert pruned is not None and 0 < pruned.count(" = ") < cxx.count(" = ") / 10
    outputs = [name for name, port in backend.ports.items()
               if not port.is_input and port.width <= 64]
    paths = [*backend._free.reads(), *outputs]
    runner.run_job(job, runner.RunOptions(max_cycles=400_000), backend)
    fp = backend.get("fp_total")
    feed = chipset_map.chip_register("FEED", "FEED").to_bytes(0x1234)
    checked = []
    for k in range(8_000):
        if k % 1000 == 0:
            backend.bus_read(0)
        elif 4000 <= k < 4000 + len(feed):  # a new feed word: outlined values change
            backend.bus_write(chipset_map.port("FEED", "FEED", k - 4000), feed[k - 4000])
        elif k == 6000:
            backend.set("x__vmax", 12345)
        else:
            backend.step(1)
        checked.append(backend.check_eval_skip(paths))
    assert backend.get("fp_total") > fp + 50  # in motion all along
    backend.close()
    assert all(checked)


_WORD_CASES = [(y, a, b) for y in (1, 7, 32, 33, 64, 65, 127, 129)
               for a, b in ((1, 1), (5, 38), (32, 32), (33, 64), (64, 64), (65, 17), (128, 100),
                            (130, 3))]
_WORD_OPS = ("add_uu", "add_ss", "sub_uu", "sub_ss", "mul_uu", "mul_ss", "lt_uu", "gt_uu",
             "le_uu", "ge_uu", "lt_ss", "gt_ss", "le_ss", "ge_ss")


def test_machine_word_arithmetic_equals_cxxrtls_for_every_op_and_width(tmp_path):
    """words.h computes the design's arithmetic in machine words: each op equals CXXRTL's
    own on random operands and on the edge cases (0, all ones, the sign bit alone)."""
    checks = [f"CHECK(k37_{op}<{y}>(a, b), {op}<{y}>(a, b), {a}, {b}, \"{op}<{y}>({a}, {b})\");"
              for op in _WORD_OPS for y, a, b in _WORD_CASES]
    checks += [f"CHECK(k37_{op}<{y}>(a), {op}<{y}>(a), {a}, 1, \"{op}<{y}>({a})\");"
               for op in ("neg_u", "neg_s") for y, a, _ in _WORD_CASES]
    undefs = "".join(f"#undef {op}\n" for op in (*_WORD_OPS, "neg_u", "neg_s"))
    # one function a check: one main() of a thousand inlined loops took g++ three times as long
    functions = "\n".join(f"static void check_{k}() {{ {check} }}"
                          for k, check in enumerate(checks))
    calls = "".join(f"\tcheck_{k}();\n" for k in range(len(checks)))
    (tmp_path / "check.cc").write_text(f"""#include "words.h"
{undefs}#include <cstdio>
#include <random>
using namespace cxxrtl_yosys;
static std::mt19937_64 rng(37);
template<size_t N> value<N> operand(int k) {{
	value<N> v;
	for (size_t i = 0; i < v.chunks; i++)
		v.data[i] = k % 4 == 0 ? 0 : k % 4 == 1 ? ~chunk_t(0) : chunk_t(rng());
	if (k % 4 == 2) {{
		v = value<N>();
		v.data[(N - 1) / 32] = chunk_t(1) << ((N - 1) % 32);
	}}
	v.data[v.chunks - 1] &= v.msb_mask;
	return v;
}}
static int failures = 0;
#define CHECK(ours, theirs, A, B, what) \\
	for (int k = 0; k < 64; k++) {{ \\
		auto a = operand<A>(k); auto b = operand<B>(k / 4 + k); (void)b; \\
		if (ours != theirs) {{ std::printf("%s differs\\n", what); failures++; break; }} \\
	}}
{functions}
int main() {{
{calls}	std::printf("%d failures\\n", failures);
	return failures != 0;
}}
""")
    tools = build._toolchain(None)
    subprocess.run([tools.compiler, "-std=c++17", "-O1", f"-I{tools.include}",
                    f"-I{build.WORDS.parent}", "check.cc", "-o", "check"], cwd=tmp_path,
                   check=True)
    result = subprocess.run([str(tmp_path / "check")], capture_output=True, text=True)
    assert result.stdout.strip().endswith("0 failures"), result.stdout
    assert result.returncode == 0
