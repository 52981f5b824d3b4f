"""``k37 plan``, the LinuxCNC front end's command-line face, and a fuzz of the front end:
no input gives a traceback."""

from __future__ import annotations

import json

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from k37.firmware_model.gcode import canon
from k37.firmware_model.gcode.parser import GcodeError, parse
from k37.sim.cli import main
from tests.programs import mixed_program

HAVE_RS274 = canon.shutil.which(canon.RS274) is not None


def test_plan_prints_every_block_with_its_line_end_and_fp(tmp_path, capsys):
    path = tmp_path / "p.ngc"
    path.write_text("G21 F600 M3\nG01 X1\nG02 X1 Y-0.003 I0.012 J0.009\nG04 P1\nM30\n")
    assert main(["plan", str(path)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split() == ["#", "line", "kind", "end", "(LSB)", "FP", "note"]
    assert out[1].split() == ["0", "1", "event", "M3", "spindle_cw"]
    assert out[2].split() == ["1", "2", "line", "(1000,", "0)", "1000"]
    assert out[3].split()[:3] == ["2", "3", "arc"] and out[4].split()[:4] == [
        "3", "3", "correction", "(1000,"]
    assert out[-2].startswith("3 blocks, ") and out[-2].endswith("M02/M30")
    assert out[-1].startswith("planned machine time ") and ", 1.000 s of dwells, " in out[-1]


def test_plan_of_many_short_blocks_on_an_exact_stop_machine_names_the_keys_that_shorten_it(
        tmp_path, capsys):
    path = tmp_path / "z.ngc"
    path.write_text("G21 G90 F600\n" + "\n".join(f"G01 X{k % 2} Y{k / 100:.2f}"
                                                   for k in range(1, 41)) + "\nM30\n")
    assert main(["plan", str(path)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[-2].startswith("planned machine time 1 min ")
    assert out[-1].startswith("the exact stop behind the accel/decel circuit at each of the 40 "
                              "blocks (tau 300 ms) takes most of it: machine.accel = \"post\"")


def test_plan_json_has_the_program_and_its_items(tmp_path, capsys):
    path = tmp_path / "p.ngc"
    path.write_text("G01 X1 Y1 F100\nG04 P0.5\n")
    assert main(["plan", "--json", str(path)]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["program"]["lines"] == 1
    # 1000 diagonal steps (1.414 mm) at F100: 1500 FP at 1,667 FP/s
    assert data["items"] == [
        {"index": 0, "line": 1, "kind": "line", "end": [1000, 1000], "fp": 1500, "steps": 1000,
         "seconds": pytest.approx(0.9, rel=1e-4)},
        {"index": 1, "line": 2, "kind": "dwell", "seconds": 0.5}]


def test_plan_reports_every_error_and_exits_2(tmp_path, capsys):
    path = tmp_path / "p.ngc"
    path.write_text("G01 X1\nG07\n")
    assert main(["plan", str(path)]) == 2
    assert capsys.readouterr().err.splitlines() == [
        f"k37: error: {path}:1:1: G01 without a feed rate: program F first",
        f"k37: error: {path}:2:1: G07 is unsupported"]


def test_plan_of_a_thousand_lines_lists_every_block(tmp_path, capsys):
    path = tmp_path / "big.ngc"
    path.write_text(mixed_program(1000))
    assert main(["plan", str(path)]) == 0
    rows = capsys.readouterr().out.splitlines()
    # a row per block (the arcs' correction lines add to the 999 moves), their lines in order
    assert len(rows) > 1000
    assert main(["plan", "--json", str(path)]) == 0
    items = json.loads(capsys.readouterr().out)["items"]
    lines = [item["line"] for item in items]
    assert lines == sorted(lines) and lines[0] == 2 and lines[-1] == 1000


def test_without_rs274_the_linuxcnc_front_end_says_how_to_get_it(tmp_path, capsys,
                                                                  monkeypatch):
    monkeypatch.setattr(canon.shutil, "which", lambda _: None)
    path = tmp_path / "p.ngc"
    path.write_text("G01 X1 F1\n")
    assert main(["plan", "--frontend", "linuxcnc", str(path)]) == 2
    assert capsys.readouterr().err == (
        f"k37: error: {path}:1:1: --frontend linuxcnc needs LinuxCNC's interpreter rs274 on "
        f"the PATH (Debian: apt-get install linuxcnc-uspace)\n")


@pytest.mark.skipif(not HAVE_RS274, reason="LinuxCNC's rs274 is not installed (Debian: "
                                           "apt-get install linuxcnc-uspace)")
def test_the_linuxcnc_front_end_runs_rs274_nc_and_places_its_errors(tmp_path, capsys):
    path = tmp_path / "p.ngc"
    path.write_text("#1 = 2\nG21 F600\no1 repeat [2]\nG91 G01 X#1\no1 endrepeat\nM2\n")
    assert main(["plan", "--json", "--frontend", "linuxcnc", str(path)]) == 0
    items = json.loads(capsys.readouterr().out)["items"]
    assert [it["end"] for it in items if it["kind"] == "line"] == [[2000, 0], [4000, 0]]
    path.write_text("G21 F600\nG01 X1\nG02 X1 Y5 I7\nM2\n")
    assert main(["plan", "--frontend", "linuxcnc", str(path)]) == 2
    assert capsys.readouterr().err.startswith(
        f"k37: error: {path}:3:1: rs274: Radius to end of arc differs from radius to start")


@pytest.mark.skipif(not HAVE_RS274, reason="LinuxCNC's rs274 is not installed (Debian: "
                                           "apt-get install linuxcnc-uspace)")
def test_rs274_finds_subroutine_files_beside_the_program(tmp_path, capsys):
    (tmp_path / "square.ngc").write_text("o<square> sub\nG91 G01 X#1\nY#1\nX-#1\nY-#1\n"
                                         "G90\no<square> endsub\nM2\n")
    path = tmp_path / "p.ngc"
    path.write_text("G21 F600\no<square> call [2]\nM2\n")
    assert main(["plan", "--json", "--frontend", "linuxcnc", str(path)]) == 0
    ends = [it["end"] for it in json.loads(capsys.readouterr().out)["items"] if "end" in it]
    assert ends == [[2000, 0], [2000, 2000], [0, 2000], [0, 0]]


def test_canonical_offsets_keep_their_length_when_the_units_change():
    text = ("   1 N..... USE_LENGTH_UNITS(CANON_UNITS_MM)\n"
            "   2 N..... SET_G92_OFFSET(-1.0000, -2.0000, 0.0000, 0.0000, 0.0000, 0.0000)\n"
            "   3 N..... USE_LENGTH_UNITS(CANON_UNITS_INCHES)\n"
            "   4 N..... STRAIGHT_TRAVERSE(1.0000, 0.0000, 0.0000, 0.0000, 0.0000, 0.0000)\n")
    (line,) = canon.parse_canon(text).moves
    assert line.end == (25_400 - 1_000, -2_000) and line.line_no == 4


@pytest.mark.parametrize(("program", "feeds"), [
    ("G21\nG20 G1 X1 F10\nG21 G1 X30 F100\nM2", [254.0, 100.0]),  # F in its block's units
    ("G21 F100\nG20\nG1 X1\nM2", [100.0]),  # a later G20 keeps it
    ("G20 F10\nG1 X1\nG21 F600 G1 X50\nG20 G2 X1 Y0 R2 F5\nM2", [254.0, 600.0, 127.0])])
def test_a_feed_is_in_the_units_of_its_block_in_both_front_ends(program, feeds):
    # rs274 writes a block's SET_FEED_RATE before its USE_LENGTH_UNITS
    assert [m.feed_mm_min for m in parse(program, axes=3).moves] == feeds
    if HAVE_RS274:
        assert [m.feed_mm_min for m in canon.parse_linuxcnc(program, axes=3).moves] == feeds


_WORDS = st.sampled_from(
    ["G0", "G1", "G2", "G3", "G4", "G17", "G18", "G19", "G20", "G21", "G28", "G30", "G40",
     "G43", "G49", "G53", "G54", "G61", "G64", "G80", "G81", "G82", "G83", "G90", "G91",
     "G90.1", "G91.1", "G92", "G92.1", "G93", "G94", "G98", "G99", "M0", "M1", "M2", "M3",
     "M5", "M6", "M8", "M9", "M30", "F600", "F0", "S100", "T1", "H1", "P1", "P-1", "Q1",
     "R2", "R-1", "(c)", ";c", "/", "%", "O1", "#1", "[", "\u0661", "\x0b", "\ufeff", "E3"])
_NUMBERS = st.builds(lambda letter, n: f"{letter}{n}", st.sampled_from("XYZIJKR"),
                     st.one_of(st.integers(-20, 20), st.decimals(-1e4, 1e4, places=4,
                                                                 allow_nan=False)))
_LINES = st.lists(st.lists(st.one_of(_WORDS, _NUMBERS, st.text(max_size=3)), max_size=6)
                  .map(" ".join), max_size=12).map("\n".join)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(text=_LINES, axes=st.sampled_from([2, 3]))
def test_the_front_end_never_raises_anything_but_a_gcode_error(text, axes):
    try:
        parse(text, axes=axes)
    except GcodeError as e:
        message = str(e)
    else:
        return
    assert message and all(line.count(":") >= 3 for line in message.splitlines())


_CANON = st.sampled_from([
    "STRAIGHT_FEED(1.0, 2.0, 0.0, 0, 0, 0)", "STRAIGHT_TRAVERSE(x)", "ARC_FEED(1, 0)",
    "ARC_FEED(1, 0, 0.5, 0, 1, 0, 0, 0, 0)", "ARC_FEED(1e400, 0, 0.5, 0, 1, 0)", "DWELL(abc)",
    "SET_FEED_RATE(0)", "SET_FEED_RATE(100)", "SELECT_PLANE(CANON_PLANE_XZ)",
    "SELECT_PLANE(FOO)", "USE_LENGTH_UNITS(CANON_UNITS_INCHES)", "SET_G92_OFFSET()",
    "SET_XY_ROTATION(5)", "SET_SPINDLE_SPEED(0, 100)", "START_SPINDLE_CLOCKWISE(0)",
    "NURBS_FEED(1)"])


@settings(max_examples=100, deadline=None)
@given(commands=st.lists(st.tuples(st.sampled_from(["N.....", "N12", "N"]), _CANON),
                         max_size=8), axes=st.sampled_from([2, 3]))
def test_the_canonical_command_reader_never_raises_anything_but_a_gcode_error(commands,
                                                                                axes):
    text = "\n".join(f"   {k} {n} {c}" for k, (n, c) in enumerate(commands, start=1))
    try:
        canon.parse_canon(text, axes=axes)
    except GcodeError as e:
        assert str(e).startswith("<canon> (rs274 output):")  # noqa: PT017


@settings(max_examples=25, deadline=None)
@given(text=_LINES)
def test_plan_exits_0_or_2_on_any_program(tmp_path_factory, text):
    path = tmp_path_factory.mktemp("fuzz") / "p.ngc"
    path.write_text(text, encoding="utf-8")
    assert main(["plan", str(path)]) in (0, 2)
