"""Cutter radius compensation (G41/G42 with the tool table's diameters, G41.1/G42.1 D, G40)
in the built-in front end: the entry
move, outside corners as arcs, inside corners where the compensated paths cross, arcs and
the gouging errors, as LinuxCNC's ``rs274`` runs them (its canonical end points, in mm)."""

from __future__ import annotations

import pytest

from k37.firmware_model.gcode.parser import GcodeError, parse
from k37.firmware_model.gcode.tool_table import Tool, ToolTable
from k37.firmware_model.motion.program import Arc

#: A tool table: tool 1 of diameter 4 mm, tool 2 of 2 mm, tool 3 a length only.
TOOLS = {1: Tool(length=10.0, diameter=4.0), 2: Tool(diameter=2.0), 3: 5.0}


def path(text: str, tools: ToolTable | None = None) -> list[tuple[str, tuple[int, int]]]:
    """Each move's kind and XY end (LSB, 1 um; an arc's programmed end)."""
    out = []
    for m in parse(f"G21 G90 G17 F100\n{text}\nM30", axes=3, tools=tools).moves:
        if isinstance(m, Arc):
            out.append(("arc", (m.start[0] + m.xe, m.start[1] + m.ye)))
        elif not m.correction:
            out.append(("line", m.end[:2]))
    return out


def error_of(text: str) -> str:
    with pytest.raises(GcodeError) as info:
        parse(f"G21 G90 G17 F100\n{text}\nM30", source="t.ngc", axes=3, tools=TOOLS)
    return str(info.value)


def test_a_square_inside_has_an_entry_an_outside_arc_and_inside_corners():
    # rs274: the entry ends square to it, the first corner is outside (an arc round the
    # corner's point), the others inside (the paths cross)
    assert path("G0 X-10 Y-10\nG41.1 D2\nG1 X0 Y0\nX20\nY20\nX0\nY0\nG40\nG0 X-10 Y-10") == [
        ("line", (-10_000, -10_000)), ("line", (-707, 707)), ("arc", (0, 1000)),
        ("line", (19_000, 1000)), ("line", (19_000, 19_000)), ("line", (1000, 19_000)),
        ("line", (1000, 0)), ("line", (-10_000, -10_000))]


def test_the_right_side_turns_the_other_way_and_the_exit_goes_to_the_programmed_point():
    assert path("G0 X-10 Y0\nG42.1 D2\nG1 X0 Y0\nX20\nX30 Y-10\nX40 Y10\n"
                "G40 G1 X50 Y10") == [
        ("line", (-10_000, 0)), ("line", (0, -1000)), ("line", (19_586, -1000)),
        ("line", (29_293, -10_707)), ("arc", (30_894, -10_447)), ("line", (40_894, 9553)),
        ("line", (50_000, 10_000))]


def test_nearly_straight_corners_join_without_an_arc():
    assert path("G0 X-10 Y0\nG41.1 D2\nG1 X0 Y0\nX20 Y0.1\nX40 Y0") == [
        ("line", (-10_000, 0)), ("line", (0, 1000)), ("line", (19_995, 1100)),
        ("line", (40_005, 1000))]


def test_an_arc_is_offset_by_the_radius_and_its_corners_cross_or_round():
    assert path("G0 X-10 Y0\nG41.1 D2\nG1 X0 Y0\nG2 X10 Y0 R5\nG1 X20\nG3 X30 Y0 R5\n"
                "G1 X30 Y-10\nG40 G1 X40 Y-20") == [
        ("line", (-10_000, 0)), ("line", (-916, 1000)), ("arc", (10_916, 1000)),
        ("line", (20_000, 1000)), ("arc", (21_000, 0)), ("arc", (29_000, 0)),
        ("arc", (31_000, 0)), ("line", (31_000, -10_000)), ("line", (40_000, -20_000))]


def test_an_entry_arc_ends_square_to_its_programmed_end_on_an_arc_from_the_tool():
    # rs274: the arc's end moves by the radius along the arc's radius (outside the arc on the
    # left of a CW arc); its centre moves along the line from that end to the programmed one
    assert path("G0 X-10 Y0\nG41.1 D2\nG2 X10 Y0 R10\nG1 X20\nG40 G1 X30 Y-5") == [
        ("line", (-10_000, 0)), ("arc", (10_952, 1000)), ("line", (20_000, 1000)),
        ("line", (30_000, -5000))]
    # inside the arc (right of a CW arc): the end moves towards the centre (then round the
    # outside corner)
    assert path("G0 X-10 Y0\nG42.1 D2\nG2 X10 Y0 R10\nG1 X20\nG40 G1 X30 Y-5") == [
        ("line", (-10_000, 0)), ("arc", (9000, 0)), ("arc", (10_000, -1000)),
        ("line", (20_000, -1000)), ("line", (30_000, -5000))]


def test_an_arc_may_follow_the_line_after_g40():
    assert path("G41.1 D2\nG1 X10\nG40\nG1 X0 Y10\nG2 X10 Y10 R5") == [
        ("line", (10_000, 1000)), ("line", (0, 10_000)), ("arc", (10_000, 10_000))]


@pytest.mark.parametrize(("orientation", "shift"), [
    (0, (0, 0)), (1, (-1000, 1000)), (2, (-1000, -1000)), (3, (1000, -1000)), (4, (1000, 1000)),
    (5, (0, 1000)), (6, (-1000, 0)), (7, (0, -1000)), (8, (1000, 0)), (9, (0, 0))])
def test_a_lathe_tools_orientation_shifts_the_compensated_path_in_g18(orientation, shift):
    # rs274: the path of the tool's point, a radius off the cutter's centre (X, Z); the
    # exit move goes from there to its programmed point
    def ends(text):
        return [m.end for m in parse(f"G21 G90 G18 F100\n{text}\nM30", axes=3).moves]
    program = "G0 X5 Z5\nG41.1 D2 L{}\nG1 Z-10\nX10\nG3 X15 Z-15 R5\nG40 G1 X20"
    shifted = ends(program.format(orientation))
    plain = ends(program.format(0))
    assert shifted[-1] == plain[-1] == (20_000, 0, -15_000)
    assert shifted[1:-1] == [(x + shift[0], y, z + shift[1]) for x, y, z in plain[1:-1]]


def test_a_move_along_z_is_held_with_the_move_before_it_and_follows_its_end():
    # rs274: the inside corner after it moves the line's end and the Z move's with it
    def ends(text):
        return [m.end for m in parse(f"G21 G90 G17 F100\n{text}\nM30", axes=3).moves]
    assert ends("G41.1 D2\nG1 X10\nG1 Z-1\nG1 Y10\nX0\nG40 G1 X-10 Y0") == [
        (9000, 1000, 0), (9000, 1000, -1000), (9000, 9000, -1000), (0, 9000, -1000),
        (-10_000, 0, -1000)]


def test_d0_runs_the_path_as_programmed():
    assert path("G41.1 D0\nG1 X10 Y5\nX20") == [("line", (10_000, 5000)), ("line", (20_000, 5000))]


SQUARE = "G0 X-10 Y-10\n{on}\nG1 X0 Y0\nX20\nY20\nX0\nY0\nG40\nG0 X-10 Y-10"


@pytest.mark.parametrize("on", ["T2 M6 G41", "G41 D2", "T1 M6 G41 D2", "T2 M6 G41 D0"])
def test_g41_takes_the_loaded_tools_diameter_or_tool_ds(on):
    assert path(SQUARE.format(on=on), TOOLS) == path(SQUARE.format(on="G41.1 D2"))


def test_g42_turns_the_other_way_with_the_tools_diameter():
    assert path(SQUARE.format(on="T1 M6 G42"), TOOLS) == path(SQUARE.format(on="G42.1 D4"))


@pytest.mark.parametrize(("on", "tools"), [("G41", TOOLS), ("T3 M6 G41", TOOLS),
                                           ("T1 M6 G41", None)])
def test_g41_without_a_diameter_runs_the_path_as_programmed(on, tools):
    # no tool loaded, a tool of length only, or no tool table: diameter zero
    assert path(SQUARE.format(on=on), tools) == path(SQUARE.format(on="G41.1 D0"))


def test_in_g18_the_geometry_is_the_same_in_the_zx_plane():
    # G17's (X, Y) are G18's (Z, X); Y, the normal, moves as Z does in G17
    xy = ("G0 X-10 Y-10 Z2\nG41.1 D2\nG1 X0 Y0\nX20\nG3 X30 Y10 R10\nG1 Y20 Z1\nX0\nY0\n"
          "G40 X-10 Y-10")
    zx = xy.translate(str.maketrans("XYZ", "ZXY"))
    for m17, m18 in zip(parse(f"G21 G90 G17 F100\n{xy}\nM30", axes=3).moves,
                        parse(f"G21 G90 G18 F100\n{zx}\nM30", axes=3).moves, strict=True):
        assert m18.end == (m17.end[1], m17.end[2], m17.end[0])


@pytest.mark.parametrize(("text", "message"), [
    ("G41.1 D2\nG1 X1", "3:1: the cutter radius compensation entry move is not longer than "
                        "the cutter's radius"),
    ("G41.1 D2\nG2 X1 R5", "3:1: the cutter radius compensation entry arc ends within the "
                           "cutter's radius of its start"),
    ("G0 Z1\nG41.1 D2\nG1 Z0", "4:1: the cutter radius compensation entry move is not longer "
                                "than the cutter's radius"),
    ("G41.1 D4\nG1 X10\nY0.5\nG40 G1 X0 Y20", "5:1: cutter radius compensation: the line "
                                              "before G40 is too short for a cutter of radius "
                                              "2.000 mm (it would gouge)"),
    ("G41.1 D4\nG1 X10\nY0.5", "5:1: cutter radius compensation: the line before M30 is too "
                               "short for a cutter of radius 2.000 mm (it would gouge)"),
    ("G41.1 D2\nG1 X10\nG40\nG2 X20 R5", "5:1: G02 just after G40: the move after the end of "
                                         "cutter radius compensation is a line (G00/G01)"),
    ("G42.1\nG1 X10", "2:1: G42.1 needs D, the cutter's diameter (>= 0)"),
    ("G41.1 D2\nG42.1 D2", "3:1: G42.1: cutter radius compensation is already on (G40 first)"),
    ("G19 G41.1 D2", "2:5: G41.1 in G19: cutter radius compensation is in the XY and XZ "
                     "planes (G17, G18), as LinuxCNC's"),
    ("G41.1 D2\nG1 X10\nG18 X20", "4:1: G18: the plane cannot change with cutter radius "
                                   "compensation on (G40 first)"),
    ("G41.1 D2 L3\nG1 X10", "2:10: L3: G41.1/G42.1's L (a lathe tool's orientation) is for "
                            "G18"),
    ("G18 G41.1 D2 L2.5\nG1 X10", "2:14: L2.5: L must be an integer"),
    ("G18 G0 X-5 Z5\nG41.1 D2 L2\nG2 X5 Z5 R5", "4:1: an entry arc with a lathe tool's "
                                                "orientation (G41.1/G42.1 L1-L8) is "
                                                "unsupported: enter with a line"),
    ("G1 X1 D2", "2:7: D2: D is only for G41/G42 (a tool number) and G41.1/G42.1 (the "
                 "cutter's diameter)"),
    ("G41 D7", "2:5: D7: tool 7 is not in the job's tool table ([1, 2, 3])"),
    ("T7 M6\nG42", "3:1: G42: tool 7 is not in the job's tool table ([1, 2, 3])"),
    ("G41 D1.5", "2:5: D1.5: D must be a non-negative integer"),
    ("G41.1 D10\nG1 X20\nG1 X30\nG3 X38 R4", "5:1: the arc's radius 4.000 mm is not more than "
                                            "the cutter's: cutter radius compensation cannot "
                                            "follow it inside"),
    ("G0 Z5\nG41.1 D2\nG1 X10\nG81 X20 R1 Z-1", "5:1: G81 with cutter radius compensation: "
                                                "G40 first"),
    ("G41.1 D4\nG1 X10\nX10.5\nY10", "5:1: cutter radius compensation: the line before the "
                                      "inside corner at X10.500 mm Y0.000 mm is too short "
                                      "for a cutter of radius 2.000 mm (it would gouge)"),
])
def test_compensation_errors_name_what_is_wrong(text, message):
    assert error_of(text) == f"t.ngc:{message}"
