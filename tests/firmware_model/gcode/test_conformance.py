"""Conformance of the built-in G-code front end with LinuxCNC's interpreter, ``rs274``.

Every program of ``tests/gcode_corpus`` (small programs written in the styles of LinuxCNC's
examples, grbl and UGS test files, Fusion 360 and CamBam posts, and RS-274/NGC programs of
parameters, expressions, subroutines, loops and polar coordinates) and LinuxCNC's own example
programs read from the installed package (:data:`LINUXCNC_EXAMPLES`) are parsed by the
built-in front end (on a three-axis machine) and by ``rs274`` (``--frontend linuxcnc``); the
motion end points of K37's plan (where the K3701 really stops) must equal ``rs274``'s
canonical end points within 1 LSB on every axis (in G20 programs, 1 LSB plus ``rs274``'s
rounding of its output to 0.0001 in). Where ``rs274`` is not installed the comparison is
skipped, saying so. Slow tests do the same on random programs (moves, I/J and R arcs,
drilling, mode changes; work offsets; inverse time, M70-M73 and bolt circles; cutter
radius compensation).
``python -m tests.firmware_model.gcode.test_conformance`` prints the corpus table.
"""

from __future__ import annotations

import random
import re
import shutil
import sys
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from k37.firmware_model.gcode.canon import RS274, parse_linuxcnc
from k37.firmware_model.gcode.parser import GcodeError, parse
from k37.firmware_model.gcode.tool_table import Tool
from k37.firmware_model.motion.program import Arc, Program
from tests.paths import ROOT

CORPUS = ROOT / "tests" / "gcode_corpus"
FILES = sorted(p for p in CORPUS.iterdir() if p.is_file())
#: LinuxCNC's example programs (Debian's linuxcnc-uspace installs them in one of these).
LINUXCNC_NCFILES = next((p for p in (Path("/usr/share/linuxcnc/ncfiles"),
                                     Path("/usr/share/doc/linuxcnc/examples/nc_files"))
                         if p.is_dir()), Path("/usr/share/linuxcnc/ncfiles"))
_SET = "is the interpreter's: setting it (offsets, tool data) is unsupported"
#: Every example program ``rs274`` accepts, and what the built-in front end does with it:
#: None, it runs it as ``rs274`` does; else the unsupported feature its error names.
LINUXCNC_EXAMPLES: dict[str, str | None] = {
    # programs that move
    "3D_Chips.ngc": None, "3dtest.ngc": None, "arcspiral.ngc": None, "cds.ngc": None,
    "flowsnake.ngc": None, "plasmatest.ngc": None, "skeleton.ngc": None, "spiral.ngc": None,
    "tort.ngc": None, "hole-circle.ngc": None, "polar.ngc": None, "toplevel.ngc": None,
    # subroutine and remap files: parameters, messages and calls, no motion
    "factorial.ngc": None, "g20sub.ngc": None, "g881.ngc": None, "g881min.ngc": None,
    "g882.ngc": None, "m250.ngc": None, "m61demo.ngc": None, "m6demo.ngc": None,
    "m6remap.ngc": None, "m75.ngc": None, "m76.ngc": None, "retval.ngc": None,
    "roparams.ngc": None, "testm6fail.ngc": None, "touchoff.ngc": None,
    "m70m72-demo.ngc": None, "m73-demo.ngc": None,
    # cutter radius compensation with the tool table's diameters, in G17 and G18
    "comp-g1.ngc": None, "comp311.ngc": None, "comp.ngc": None, "lathecomp.ngc": None,
    "comp311_2.ngc": None, "gmoccapy_2_tools_with_cutter_radius_compensation.ngc": None,
    "useful-subroutines.ngc": None,
    # refused, naming what K37 does not have
    "b-index.ngc": "unsupported word B0 (K37's axes are X, Y and Z)",
    "daisy.ngc": "unsupported word A0 (K37's axes are X, Y and Z)",
    "gridprobe.ngc": "probing is unsupported", "smartprobe.ngc": f"#5070 {_SET}",
    "offsets.ngc": f"#5599 {_SET}",
    "lathe_g70_71_demo.ngc": "G71.1 is unsupported", "lathe_g7x_face_boring.ngc":
    "G72 is unsupported", "lathe_g7x_quadrants.ngc": "G70 is unsupported",
    "lathe_pawn.ngc": "G8 is unsupported", "threading.ngc": "G33 is unsupported",
}
#: The example programs not compared, and why: ``rs274`` refuses them (with the tool table
#: :data:`TOOLS`, an INI file's settings absent), or its output has a command K37's reader
#: of it does not take.
LINUXCNC_NOT_COMPARED: dict[str, str] = {
    "cone.ngc": "Bad character 'w' used", "increment.ngc": "File ended with no percent sign",
    "probe-hole.ngc": "File ended with no percent sign",
    "nestedcall.ngc": "Unexpected character after O-word",
    "tool-length-probe.ngc": "Start point too close to probe point",
    "x-trim.ngc": "seeking o-word: o<touchoff>",
    "systems.ngc": "NURBS_FEED: canonical command NURBS_FEED is unsupported",
}
#: The example programs both front ends refuse at the same line: (the line, rs274's message,
#: the built-in front end's).
LINUXCNC_BOTH_REFUSE: dict[str, tuple[int, str, str]] = {
    "g76.ngc": (26, "Length of cutter compensation entry move is not greater than the tool "
                    "radius", "entry move is not longer than the cutter's radius"),
    "lathe-g76.ngc": (26, "Length of cutter compensation entry move is not greater than the "
                          "tool radius", "entry move is not longer than the cutter's radius"),
    "mmount.ngc": (89, "Tool radius not less than arc radius with comp",
                   "is not more than the cutter's: cutter radius compensation cannot follow it "
                   "inside"),
}
#: rs274 writes coordinates with four decimals: in G20, up to 0.00005 in from the value.
RS274_INCH_ROUNDING_LSB = 0.00005 * 25.4 / 0.001
HAVE_RS274 = shutil.which(RS274) is not None
NEEDS_RS274 = pytest.mark.skipif(not HAVE_RS274, reason="LinuxCNC's rs274 is not installed "
                                 "(Debian: apt-get install linuxcnc-uspace): no comparison")
#: The tool table both front ends get (mm; lengths in whole hundredths of an inch, diameters in
#: whole sixteenths, as rs274 reads them).
TOOLS = {1: Tool(12.7, 3.175), 2: Tool(25.4, 6.35), 3: Tool(5.08, 1.5875), 4: Tool(7.62, 12.7),
         5: 3.81, 7: 2.54, 9: 6.35, 10: 10.16}


def programmed_ends(program: Program, *, targets: bool = False) -> list[tuple[int, ...]]:
    """The machine position after each programmed move (an arc's correction line counted
    with its arc), consecutive repeats (zero-length moves) merged; ``targets``: the
    programmed end points instead (rs274's canonical ones, for a program read from them)."""
    start = (0,) * program.axes
    points: list[tuple[tuple[int, ...], tuple[int, ...]]] = [(start, start)]  # (target, end)
    for move in program.moves:
        target = move.end
        if isinstance(move, Arc):
            target = tuple(s + d for s, d in zip(move.start, (move.xe, move.ye, move.ze),
                                                 strict=False))
        if getattr(move, "correction", False):
            points[-1] = points[-1][0], move.end
        elif points[-1][0] != target:  # repeats merge by their targets
            points.append((target, move.end))
    return [target if targets else end for target, end in points[1:]]


def largest_difference(a: list[tuple[int, ...]], b: list[tuple[int, ...]]) -> int | None:
    """The largest per-axis difference between two lists of end points (None: they differ in
    length)."""
    if len(a) != len(b):
        return None
    return max((abs(p - q) for ea, eb in zip(a, b, strict=True)
                for p, q in zip(ea, eb, strict=True)), default=0)


def corpus_row(path: Path) -> tuple[str, str, int | None]:
    """(file, outcome, largest end-point difference to rs274 in LSB)."""
    text = path.read_text()
    try:
        ours = parse(text, source=path.name, axes=3, tools=TOOLS)
        outcome = "ok"
    except GcodeError as e:
        return path.name, f"clear error ({e.message})", None
    if not HAVE_RS274:
        return path.name, outcome, None
    try:
        theirs = parse_linuxcnc(text, source=path.name, axes=3, tools=TOOLS)
    except GcodeError as e:
        return path.name, f"{outcome}; rs274 front end: {e}", None
    return path.name, outcome, largest_difference(programmed_ends(ours),
                                                  programmed_ends(theirs, targets=True))


def tolerance_lsb(text: str) -> int:
    """1 LSB; in a program that uses G20, plus rs274's rounding of its inch output."""
    inch = re.search(r"g\s*0*20(?![.0-9])", text, re.IGNORECASE) is not None
    return 1 + int(RS274_INCH_ROUNDING_LSB) if inch else 1


@pytest.mark.parametrize("path", FILES, ids=[p.name for p in FILES])
def test_the_builtin_front_end_runs_the_corpus_as_published(path):
    assert parse(path.read_text(), source=path.name, axes=3, tools=TOOLS).moves


@pytest.mark.parametrize(("program", "z"), [
    ("G43 H1\nG0 X1", 5000),                 # without a tool change Z keeps still
    ("T1 M6\nG43 H1\nG0 X1", 5000),          # the change, then the offset: the same
    ("T1 M6 G43 H1\nG0 X1", 17700),          # the offset on the change's line: Z moves
    ("G43 H1\nT1 M6\nG0 X1", 17700),         # ... or set before the change
    ("G43 H1\nT1 M6\nG49\nG0 X1", 17700),     # ... then cancelled: Z keeps still there
])
def test_after_a_tool_change_the_position_is_reread_as_rs274_does(program, z):
    # rs274's ends for each (K37's ends are compared with rs274's where it is installed)
    ends = programmed_ends(parse(f"G21 G90\nG0 Z5\n{program}\nM2", axes=3, tools=TOOLS))
    assert ends[-1] == (1000, 0, z)


@NEEDS_RS274
@pytest.mark.parametrize("path", FILES, ids=[p.name for p in FILES])
def test_every_end_point_equals_rs274s_within_one_lsb(path):
    text = path.read_text()
    theirs = programmed_ends(parse_linuxcnc(text, source=path.name, axes=3, tools=TOOLS),
                             targets=True)
    ours = programmed_ends(parse(text, source=path.name, axes=3, tools=TOOLS))
    assert largest_difference(ours, theirs) is not None, (ours, theirs)
    assert largest_difference(ours, theirs) <= tolerance_lsb(text)


@pytest.mark.parametrize("name", LINUXCNC_EXAMPLES)
def test_linuxcncs_examples_run_as_rs274_runs_them_or_name_what_is_unsupported(name):
    path = LINUXCNC_NCFILES / name
    if not path.is_file():
        pytest.skip(f"{path} is not installed (Debian: apt-get install linuxcnc-uspace)")
    text = path.read_text(errors="replace")
    refused = LINUXCNC_EXAMPLES[name]
    if refused is not None:
        with pytest.raises(GcodeError) as info:
            parse(text, source=name, axes=3, tools=TOOLS)
        assert refused in info.value.message
        return
    ours = programmed_ends(parse(text, source=name, axes=3, tools=TOOLS))
    if not HAVE_RS274:
        return
    theirs = programmed_ends(parse_linuxcnc(text, source=name, axes=3, tools=TOOLS),
                             targets=True)
    assert largest_difference(ours, theirs) is not None, (len(ours), len(theirs))
    assert largest_difference(ours, theirs) <= tolerance_lsb(text)


@NEEDS_RS274
@pytest.mark.parametrize("name", LINUXCNC_NOT_COMPARED)
def test_the_examples_not_compared_are_those_rs274_or_its_reader_refuses(name):
    path = LINUXCNC_NCFILES / name
    if not path.is_file():
        pytest.skip(f"{path} is not installed (Debian: apt-get install linuxcnc-uspace)")
    with pytest.raises(GcodeError, match=re.escape(LINUXCNC_NOT_COMPARED[name])):
        parse_linuxcnc(path.read_text(errors="replace"), source=name, axes=3, tools=TOOLS)


@NEEDS_RS274
@pytest.mark.parametrize("name", LINUXCNC_BOTH_REFUSE)
def test_the_examples_rs274_refuses_are_refused_at_the_same_line(name):
    path = LINUXCNC_NCFILES / name
    if not path.is_file():
        pytest.skip(f"{path} is not installed (Debian: apt-get install linuxcnc-uspace)")
    line, theirs, ours = LINUXCNC_BOTH_REFUSE[name]
    text = path.read_text(errors="replace")
    with pytest.raises(GcodeError) as info:
        parse_linuxcnc(text, source=name, axes=3, tools=TOOLS)
    assert info.value.errors[0][0] == line and theirs in info.value.message
    with pytest.raises(GcodeError) as info:
        parse(text, source=name, axes=3, tools=TOOLS)
    assert info.value.errors[0][0] == line and ours in info.value.errors[0][2]


def test_every_installed_example_is_classified():
    if not LINUXCNC_NCFILES.is_dir():
        pytest.skip(f"{LINUXCNC_NCFILES} is not installed (Debian: apt-get install "
                    f"linuxcnc-uspace)")
    installed = {p.name for p in LINUXCNC_NCFILES.glob("*.ngc")}
    assert installed == (LINUXCNC_EXAMPLES.keys() | LINUXCNC_NOT_COMPARED.keys()
                         | LINUXCNC_BOTH_REFUSE.keys())


def assert_ends_as_rs274s(text: str, theirs: list[tuple[int, ...]], tolerance: int) -> None:
    """The built-in front end's end points of ``text`` are ``theirs`` (``rs274``'s) within
    ``tolerance`` LSB on every axis."""
    ours = programmed_ends(parse(text, axes=3, tools=TOOLS))
    difference = largest_difference(ours, theirs)
    assert difference is not None and difference <= tolerance, (text, ours, theirs)


def random_program(rng: random.Random) -> str:
    """A random program of moves, arcs (I/J and R), drilling and mode changes."""
    inch = rng.random() < 0.5
    scale = 0.05 if inch else 1.0
    lines = [f"{'G20' if inch else 'G21'} F50"]

    def num() -> str:
        return f"{rng.uniform(-20, 20) * scale:.{rng.choice([0, 1, 2, 3])}f}"

    for _ in range(rng.randint(3, 12)):
        k = rng.random()
        if k < 0.1:
            lines.append(rng.choice(["G90", "G91", "G92 X0 Y0", "G92.1", "G98", "G99", "G17",
                                     "G18", "G19", "G90.1", "G91.1", "G54", "G55", "G59.1",
                                     f"G10 L2 P{rng.randint(0, 2)} X{num()} Z{num()}",
                                     f"G10 L20 P{rng.choice([0, 2, 7])} Y{num()}",
                                     f"G52 X{num()} Y{num()}"]))
        elif k < 0.4:
            z = f" Z{num()}" if rng.random() < 0.3 else ""
            lines.append(f"G{rng.choice('01')} X{num()} Y{num()}{z}")
        elif k < 0.6:
            lines.append(f"G{rng.choice('23')} X{num()} Y{num()} R{num()}")
        elif k < 0.8:
            lines.append(f"G{rng.choice('23')} I{num()} J{num()}")
        elif k < 0.9:
            lines += [f"G17 G81 X{num()} Y{num()} Z{num()} R{num()}", "G80"]
        elif k < 0.95:
            lines.append(rng.choice(["T1 M6 G43 H1", "G43 H2", "T2 M6", "G49", "M6"]))
        else:
            lines.append(f"G28 X{num()}")
    return "\n".join([*lines, "M2"])


@pytest.mark.slow
@NEEDS_RS274
@settings(max_examples=150, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**32))
def test_random_programs_run_as_rs274_runs_them(seed):
    text = random_program(random.Random(seed))
    try:
        theirs = programmed_ends(parse_linuxcnc(text, axes=3, tools=TOOLS), targets=True)
    except GcodeError:
        return  # rs274 refuses it (an R arc too short for its chord...): so do we, or more
    assert_ends_as_rs274s(text, theirs, 1)


def random_offsets_program(rng: random.Random) -> str:
    """A random program of moves between work offsets: G10 L2/L20, G52, G92, G54-G59.3."""
    def num() -> str:
        return f"{rng.uniform(-20, 20):.{rng.choice([0, 1, 3])}f}"

    lines = [f"{rng.choice(['G20', 'G21'])} G90"]
    for _ in range(rng.randint(4, 14)):
        axes = " ".join(f"{a}{num()}" for a in rng.sample("XYZ", rng.randint(1, 3)))
        lines.append(rng.choice([
            f"G10 L2 P{rng.randint(0, 9)} {axes}", f"G10 L20 P{rng.randint(0, 9)} {axes}",
            f"G52 {axes}", f"G92 {axes}", "G92.1", rng.choice(["G54", "G55", "G59", "G59.3"]),
            f"G0 {axes}", f"G1 {axes} F100", rng.choice(["G90", "G91"])]))
    return "\n".join([*lines, "M2"])


@pytest.mark.slow
@NEEDS_RS274
@settings(max_examples=60, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**32))
def test_random_work_offsets_move_as_rs274_moves(seed):
    text = random_offsets_program(random.Random(seed))
    theirs = programmed_ends(parse_linuxcnc(text, axes=3, tools=TOOLS), targets=True)
    assert_ends_as_rs274s(text, theirs, tolerance_lsb(text))


def random_language_program(rng: random.Random) -> str:
    """A random program of inverse-time moves (G93), modal state saved and restored (M70-M73,
    in the main program and a subroutine) and bolt circles (polar canned cycles with L)."""
    def num(low: float = -20, high: float = 20) -> str:
        return f"{rng.uniform(low, high):.{rng.choice([0, 1, 3])}f}"

    lines = ["o<steps> sub", "M73", f"{rng.choice(['G20', 'G21'])} G91 G94 F{num(5, 50)}",
             f"G1 X{num(0.2, 1)} Y{num(-1, -0.2)}", "o<steps> endsub",
             f"{rng.choice(['G20', 'G21'])} G90 G17 F300", "G0 X0 Y0 Z5", "M70"]
    for _ in range(rng.randint(4, 12)):
        lines.append(rng.choice([
            f"G93 G1 X{num()} Y{num()} F{num(0.5, 20)}",
            f"G93 G2 X{num()} Y{num()} R{num(25, 40)} F{num(0.5, 20)}",
            f"G93 G3 X{num()} Y{num()} Z{num(0, 5)} R{num(25, 40)} F{num(0.5, 20)}",
            f"G94 G1 X{num()} Y{num()} F{num(50, 500)}",
            "M70", "M72", "M71\nM70", "o<steps> call", rng.choice(["G20", "G21", "G90", "G91"]),
            f"G94 G90 G0 X{num(5, 20)} Y{num(5, 20)}\nG91 G81 R{num(-3, -1)} Z{num(-4, -1)} "
            f"^{num(10, 120)} L{rng.randint(1, 6)} F100\nG80\nG90 G0 Z5",
            f"G94 G90 G0 X{num(5, 20)} Y0\nG91 G81 @{num(1, 5)} R{num(-3, -1)} Z{num(-4, -1)} "
            f"L{rng.randint(1, 4)} F100\nG80\nG90 G0 Z5"]))
    return "\n".join([*lines, "M2"])


@pytest.mark.slow
@NEEDS_RS274
@settings(max_examples=60, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**32))
def test_random_inverse_time_modal_state_and_bolt_circles_run_as_rs274_runs_them(seed):
    text = random_language_program(random.Random(seed))
    try:
        theirs = programmed_ends(parse_linuxcnc(text, axes=3, tools=TOOLS), targets=True)
    except GcodeError:
        return  # rs274 refuses it (an M72 with nothing saved, an R arc too short...)
    assert_ends_as_rs274s(text, theirs, tolerance_lsb(text))


def random_comp_program(rng: random.Random) -> str:
    """A random path of lines, arcs, helices and Z moves under G41.1/G42.1 D or G41/G42 (a
    diameter of :data:`TOOLS`), with its entry (a line or an arc) and exit, in G17 or (its
    X, Y, Z as Z, X, Y) G18."""
    def num(low: float = -30, high: float = 30) -> str:
        return f"{rng.uniform(low, high):.{rng.choice([0, 1, 3])}f}"

    comp = rng.choice([f"{rng.choice(['G41.1', 'G42.1'])} D"
                       f"{rng.choice(['0.5', '1', '2', '3.175'])}",
                       f"{rng.choice(['G41', 'G42'])} D{rng.choice('13')}",
                       f"T{rng.choice('13')} M6\n{rng.choice(['G41', 'G42'])}"])
    entry = rng.choice([f"G1 X{num()} Y{num()} Z0",
                         f"G{rng.choice('23')} X{num()} Y{num()} Z0 R{num(15, 40)}"])
    lines = [f"{rng.choice(['G20', 'G21'])} G90 G17 F100", f"G0 X{num()} Y{num()} Z1", comp,
             entry]
    for _ in range(rng.randint(2, 8)):
        lines.append(rng.choice([
            f"G1 X{num()} Y{num()}", f"G{rng.choice('23')} X{num()} Y{num()} R{num(15, 40)}",
            f"G91 G1 X{num(-10, 10)} Y{num(-10, 10)}\nG90",
            f"G{rng.choice('23')} X{num()} Y{num()} Z{num(-2, 0)} R{num(20, 40)}",
            f"G1 Z{num(-2, 0)}"]))
    text = "\n".join([*lines, f"G40 G1 X{num()} Y{num()}", "M2"])
    return text if rng.random() < 0.5 else text.translate(str.maketrans("XYZ", "ZXY")).replace(
        "G17", "G18")


@pytest.mark.slow
@NEEDS_RS274
@settings(max_examples=80, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**32))
def test_random_compensated_paths_run_or_are_refused_as_rs274_does(seed):
    text = random_comp_program(random.Random(seed))
    try:
        theirs = programmed_ends(parse_linuxcnc(text, axes=3, tools=TOOLS), targets=True)
    except GcodeError as e:  # gouging, an R arc too short...: refused at the same line
        refused = e
    else:
        assert_ends_as_rs274s(text, theirs, tolerance_lsb(text))
        return
    with pytest.raises(GcodeError) as info:
        parse(text, axes=3, tools=TOOLS)
    assert info.value.line == refused.line, (info.value.message, refused.message)


def example_row(name: str) -> tuple[str, str, int | None]:
    """(file, outcome, largest end-point difference to rs274 in LSB) of a LinuxCNC example."""
    if name in LINUXCNC_NOT_COMPARED:
        return name, f"not compared: {LINUXCNC_NOT_COMPARED[name]}", None
    return corpus_row(LINUXCNC_NCFILES / name)


def _cause(outcome: str) -> str:
    """An outcome's cause, for the summary: ok, or what refused the program."""
    if outcome == "ok" or outcome.startswith("not compared"):
        return outcome.split(":")[0]
    message = outcome.removeprefix("clear error (").removesuffix(")")
    return message.split(":", 1)[-1].strip() if message[:1] in "GM#" else message


if __name__ == "__main__":
    rows = [*map(corpus_row, FILES), *map(example_row, sorted(
        LINUXCNC_EXAMPLES.keys() | LINUXCNC_NOT_COMPARED.keys() | LINUXCNC_BOTH_REFUSE.keys()))]
    print("| file | built-in front end | largest difference to rs274 (LSB) |")
    print("|---|---|---|")
    for name, outcome, diff in rows:
        print(f"| {name} | {outcome} | {'-' if diff is None else diff} |")
    causes: dict[str, int] = {}
    for _, outcome, _ in rows:
        causes[_cause(outcome)] = causes.get(_cause(outcome), 0) + 1
    print(f"\n{len(rows)} files:")
    for cause, count in sorted(causes.items(), key=lambda item: -item[1]):
        print(f"- {count} {cause}")
    sys.exit(0)

