"""Conformance of the built-in G-code front end with LinuxCNC's interpreter, ``rs274``.

Every program of ``tests/gcode_corpus`` (small programs written in the styles of LinuxCNC's
examples, grbl and UGS test files, Fusion 360 and CamBam posts, and RS-274/NGC programs of
parameters, expressions, subroutines, loops and polar coordinates) and LinuxCNC's own example
programs read from the installed package (:data:`LINUXCNC_EXAMPLES`) are parsed by the
built-in front end (on a three-axis machine) and by ``rs274`` (``--frontend linuxcnc``); the
motion end points of K37's plan (where the K3701 really stops) must equal ``rs274``'s
canonical end points within 1 LSB on every axis (in G20 programs, 1 LSB plus ``rs274``'s
rounding of its output to 0.0001 in). Where ``rs274`` is not installed the comparison is
skipped, saying so. A slow test does the same on random programs (moves, I/J and R arcs,
drilling, mode changes). ``python tests/test_conformance.py`` prints the corpus table.
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

from firmware_model.gcode.canon import RS274, parse_linuxcnc
from firmware_model.gcode.parser import Arc, GcodeError, Program, parse

CORPUS = Path(__file__).parent / "gcode_corpus"
FILES = sorted(p for p in CORPUS.iterdir() if p.is_file())
#: LinuxCNC's example programs (Debian's linuxcnc-uspace) and what the built-in front end
#: does with each: None, it runs them; else the unsupported feature its error names.
LINUXCNC_NCFILES = Path("/usr/share/linuxcnc/ncfiles")
LINUXCNC_EXAMPLES: dict[str, str | None] = {
    "factorial.ngc": None, "retval.ngc": None, "flowsnake.ngc": None, "spiral.ngc": None,
    "3dtest.ngc": None, "g881.ngc": None, "m6demo.ngc": None, "3D_Chips.ngc": None,
    "hole-circle.ngc": "polar coordinates (@, ^) are for G00 and G01 moves",
    "polar.ngc": "polar coordinates (@, ^) are for G00 and G01 moves",
    "daisy.ngc": "K37's axes are X, Y and Z",
    "m73-demo.ngc": "saving and restoring modal state (M70-M73) is unsupported",
    "comp.ngc": "cutter radius compensation is unsupported",
    "lathe_g7x_quadrants.ngc": "G70 is unsupported",
}
#: rs274 writes coordinates with four decimals: in G20, up to 0.00005 in from the value.
RS274_INCH_ROUNDING_LSB = 0.00005 * 25.4 / 0.001
HAVE_RS274 = shutil.which(RS274) is not None
#: The tool table both front ends get (mm; whole hundredths of an inch, as rs274 reads them).
TOOLS = {1: 12.7, 2: 25.4}


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


@pytest.mark.skipif(not HAVE_RS274, reason="LinuxCNC's rs274 is not installed (Debian: "
                                           "apt-get install linuxcnc-uspace): no comparison")
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
                                     "G18", "G19", "G90.1", "G91.1", "G54", "G55"]))
        elif k < 0.4:
            z = f" Z{num()}" if rng.random() < 0.3 else ""
            lines.append(f"G{rng.choice('01')} X{num()} Y{num()}{z}")
        elif k < 0.6:
            lines.append(f"G{rng.choice('23')} X{num()} Y{num()} R{num()}")
        elif k < 0.8:
            lines.append(f"G{rng.choice('23')} I{num()} J{num()}")
        elif k < 0.9:
            lines += [f"G17 G81 X{num()} Y{num()} Z{num()} R{num()}", "G80"]
        else:
            lines.append(f"G28 X{num()}")
    return "\n".join([*lines, "M2"])


@pytest.mark.slow
@pytest.mark.skipif(not HAVE_RS274, reason="LinuxCNC's rs274 is not installed (Debian: "
                                           "apt-get install linuxcnc-uspace): no comparison")
@settings(max_examples=150, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**32))
def test_random_programs_run_as_rs274_runs_them(seed):
    text = random_program(random.Random(seed))
    try:
        theirs = programmed_ends(parse_linuxcnc(text, axes=3), targets=True)
    except GcodeError:
        return  # rs274 refuses it (an R arc too short for its chord...): so do we, or more
    ours = programmed_ends(parse(text, axes=3))
    assert largest_difference(ours, theirs) is not None, text
    assert largest_difference(ours, theirs) <= 1, text


if __name__ == "__main__":
    print("| file | built-in front end | largest difference to rs274 (LSB) |")
    print("|---|---|---|")
    for name, outcome, diff in map(corpus_row, FILES):
        shown = "-" if diff is None else diff
        print(f"| {name} | {outcome} | {shown} |")
    sys.exit(0)
