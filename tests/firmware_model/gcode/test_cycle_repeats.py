"""Canned cycles repeated with L and placed with polar coordinates (bolt circles), and the
initial level they keep, as LinuxCNC's ``rs274`` runs them."""

from __future__ import annotations

import math

import pytest

from k37.firmware_model.gcode.parser import GcodeError, parse


def holes(text: str) -> list[tuple[int, int]]:
    """The X/Y of every hole: where a feed move goes down (LSB)."""
    program = parse(text, axes=3)
    return [m.end[:2] for m in program.moves if m.feed_mm_min and m.end[2] < m.start[2]]


def z_levels(text: str) -> list[int]:
    return [m.end[2] for m in parse(text, axes=3).moves]


def test_a_bolt_circle_of_six_holes_is_one_polar_block_repeated():
    found = holes("G21 G90 G0 X30 Y0 Z10\nG91 G81 R-8 Z-5 ^60 L6 F200\nM30")
    expected = [(round(30_000 * math.cos(math.radians(60 * k))),
                 round(30_000 * math.sin(math.radians(60 * k)))) for k in range(1, 7)]
    assert found == expected


def test_an_incremental_repeat_moves_by_x_y_and_keeps_the_first_blocks_planes():
    text = "G21 G90 G0 X0 Y0 Z5\nG91 G81 X10 Y-2 R-3 Z-4 L3 F100\nM30"
    assert holes(text) == [(10_000, -2000), (20_000, -4000), (30_000, -6000)]
    assert z_levels(text)[-3:] == [2000, -2000, 2000]  # each hole: to R, to the bottom, out


def test_an_absolute_repeat_drills_the_same_hole_again():
    assert holes("G21 G90 G0 Z5\nG81 X2 Y3 R1 Z-1 L2 F100\nM30") == [(2000, 3000)] * 2


def test_polar_coordinates_place_an_absolute_cycles_hole():
    assert holes("G21 G90 G0 Z5\nG81 @20 ^90 R1 Z-1 F100\n^180\nM30") == [
        (0, 20_000), (-20_000, 0)]


def test_g91_cycles_take_r_from_the_initial_level_until_another_motion_mode():
    # the first cycle starts at Z0 (the initial level); the G91 block's R is from there,
    # not from the R plane the first hole left the tool at
    text = "G20 G90 G0 X0 Y0 Z0\nG81 X1 R.1 Z-.5 F60\nG91 G82 X1 R.1 Z-.5 P1\nM30"
    assert z_levels(text)[-3:] == [2540, -10_160, 2540]
    text = "G20 G90 G0 X0 Y0 Z0\nG81 X1 R.1 Z-.5 F60\nG80\nG91 G81 X1 R.1 Z-.5\nM30"
    assert z_levels(text)[-3:] == [5080, -7620, 5080]


@pytest.mark.parametrize(("line", "message"), [
    ("G91 G81 X1 R1 Z-1 L0", "3:19: L0: a canned cycle's L (repeats) is a whole number from 1 "
                             "to 10,000"),
    ("G91 G81 X1 R1 Z-1 L1.5", "3:19: L1.5: a canned cycle's L (repeats) is a whole number "
                               "from 1 to 10,000"),
    ("G1 X1 L2", "3:7: L2: L is only for G05.2 (a NURBS's order), G10, G41/G42 and canned "
                 "cycles (repeats)"),
])
def test_a_bad_repeat_count_is_an_error_naming_it(line, message):
    with pytest.raises(GcodeError) as info:
        parse(f"G21 G90 F100\nG0 Z5\n{line}\nM30", source="t.ngc", axes=3)
    assert str(info.value) == f"t.ngc:{message}"
