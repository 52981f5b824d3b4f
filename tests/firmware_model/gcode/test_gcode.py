"""G-code front end: words, modes, units, arcs and their K3701 check, and every error kind."""

from __future__ import annotations

import math
from itertools import pairwise

import pytest

from k37.firmware_model.gcode.parser import GcodeError, parse
from k37.firmware_model.job import gcode_job
from k37.firmware_model.motion.program import Arc, Dwell, Line
from k37.hdl.k3701.block import COORD_MAX, Block, Kind, quadrant_of
from k37.hdl.k3701.model.chip import plan


def moves(text: str, **kwargs) -> list[tuple[int, int]]:
    """The (xe, ye) of every move of a program."""
    return [(it.xe, it.ye) for it in parse(text, **kwargs).moves]


def error_of(text: str, **kwargs) -> str:
    with pytest.raises(GcodeError) as info:
        parse(text, source="t.ngc", **kwargs)
    return str(info.value)


# --- lines, modes and units -------------------------------------------------------------------

def test_absolute_lines_are_loaded_relative_to_their_start():
    prog = parse("G90 G01 X10 Y5 F100\nX4 Y-2")
    assert moves("G90 G01 X10 Y5 F100\nX4 Y-2") == [(10_000, 5_000), (-6_000, -7_000)]
    assert [it.start for it in prog.items] == [(0, 0), (10_000, 5_000)]
    assert prog.final_position == (4_000, -2_000)


def test_incremental_lines_add_to_the_position():
    prog = parse("G91 G01 X10 Y5 F100\nX4 Y-2\nG90 X0 Y0")
    assert [(it.xe, it.ye) for it in prog.items] == [(10_000, 5_000), (4_000, -2_000),
                                                     (-14_000, -3_000)]
    assert prog.final_position == (0, 0)


def test_arc_centres_are_relative_to_the_start_in_both_distance_modes():
    for mode in ("G90 G01 X1 F1\nG03 X2 Y1", "G91 G01 X1 F1\nG03 X1 Y1"):
        _, arc = parse(mode + " I0 J1").items
        assert (arc.xe, arc.ye, arc.i, arc.j, arc.start) == (1_000, 1_000, 0, 1_000, (1_000, 0))
        assert arc.end == (2_000, 1_000)


def test_inch_mode_scales_coordinates_and_feed_by_25_4():
    prog = parse("G20 G01 X1 Y-0.5 F10\nG21 X0 Y10")
    first, second = prog.items
    assert (first.xe, first.ye) == (25_400, -12_700)
    assert first.feed_mm_min == pytest.approx(254.0)
    assert (second.xe, second.ye) == (-25_400, 22_700)
    assert second.feed_mm_min == pytest.approx(254.0)  # F keeps the value it was given
    (arc,) = parse("G20 G02 X0.1 I0.05 F1").items
    assert (arc.xe, arc.ye, arc.i, arc.j) == (2_540, 0, 1_270, 0)


def test_unit_and_distance_modes_apply_to_their_whole_block():
    assert moves("G01 X1 F1 G20") == [(25_400, 0)]
    assert moves("G01 X1 F1\nX1 G91") == [(1_000, 0), (1_000, 0)]


def test_lsb_mm_sets_the_resolution():
    assert moves("G01 X1.23 Y-4 F1", lsb_mm=0.01) == [(123, -400)]
    assert moves("G01 X1 F1", lsb_mm=0.0005) == [(2_000, 0)]


def test_coordinates_round_to_the_nearest_lsb_halves_away_from_zero():
    # the exact positions are (1.5, -1.5), (2.9, -2.9), (5.4, -2.4) LSB: each rounds alone
    assert moves("G91 G01 X0.0015 Y-0.0015 F1\nX0.0014 Y-0.0014\nX0.0025 Y.0005") == [
        (2, -2), (1, -1), (2, 1)]


def test_absolute_coordinates_are_rounded_each_so_errors_never_accumulate():
    # Ten moves of 0.0004 mm each in absolute terms: the sum of rounded moves is the rounded
    # end, not ten roundings.
    text = "G01 F1\n" + "\n".join(f"X{k * 0.0004:.4f}" for k in range(1, 11))
    prog = parse(text)
    assert sum(it.xe for it in prog.items) == 4
    assert prog.final_position == (4, 0)


def test_motion_mode_is_modal():
    prog = parse("G01 X1 F100\nY1\nG00 X0\nY0\nG02 X1 Y1 I1 J0\nX2 Y0 I0 J-1")
    kinds = [(type(it).__name__, getattr(it, "rapid", None)) for it in prog.items]
    assert kinds == [("Line", False), ("Line", False), ("Line", True), ("Line", True),
                     ("Arc", None), ("Arc", None)]
    assert all(it.cw for it in prog.items[4:])


def test_feed_is_modal_in_units_per_minute():
    prog = parse("G01 X1 F250\nX2\nF125 X3\nG00 X0\nG01 X1")
    assert [it.feed_mm_min for it in prog.items] == [250.0, 250.0, 125.0, None, 125.0]


def test_rapid_moves_are_flagged_and_need_no_feed():
    (line,) = parse("G00 X3 Y4").items
    assert line.rapid
    assert line.feed_mm_min is None
    assert line.block == Block.line(3_000, 4_000, sqrt2=True)


def test_a_motion_word_alone_sets_the_mode_without_moving():
    prog = parse("G01 F100\nG02\nX2 Y0 I1 J0")
    assert len(prog.items) == 1
    assert isinstance(prog.items[0], Arc)


def test_dwell_takes_seconds_and_keeps_the_motion_mode():
    prog = parse("G01 X1 F60\nG04 P1.25\nX2")
    assert prog.items[1] == Dwell(1, 2, 1.25)
    assert isinstance(prog.items[2], Line)
    assert [it.index for it in prog.items] == [0, 1, 2]
    assert [it.line_no for it in prog.items] == [1, 2, 3]


def test_comments_sequence_numbers_and_tape_markers_are_skipped():
    text = "%\n(header) ; more\nN10 G01 (inline) X1 F100 ; tail\n\n  n20 x 2 y-1.5\n%\n"
    assert moves(text) == [(1_000, 0), (1_000, -1_500)]


def test_words_are_case_insensitive_and_may_hold_spaces():
    assert moves("g01 x1 f100\nG 1 X - 2\n\tY\t+.5") == [(1_000, 0), (-3_000, 0), (0, 500)]


def test_line_numbers_count_crlf_lines():
    assert error_of("G17\r\nG21\r\nG01 X1") == "t.ngc:3:1: G01 without a feed rate: program F first"


@pytest.mark.parametrize(("text", "end"), [("G01 X1 F1\nM02", True), ("G01 X1 F1 M30", True),
                                           ("G01 X1 F1", False)])
def test_m02_and_m30_end_the_program(text, end):
    prog = parse(text)
    assert prog.end is end
    assert len(prog.items) == 1


def test_sqrt2_setting_decides_the_fp_counts():
    on, = parse("G01 X10 Y3 F1", lsb_mm=1.0).items
    off, = parse("G01 X10 Y3 F1", lsb_mm=1.0, sqrt2=False).items
    assert on.plan.fp == 10 + 2  # N_long + ceil(N_diag / 2)
    assert off.plan.fp == 10
    assert on.block.sqrt2 and not off.block.sqrt2


def test_a_zero_length_move_is_kept_and_does_nothing():
    (line,) = parse("G01 X0 Y0 F100").items
    assert (line.xe, line.ye, line.plan.steps, line.plan.fp) == (0, 0, 0, 0)


# --- arcs -------------------------------------------------------------------------------------

def test_a_full_circle_is_an_arc_back_to_its_start():
    (arc,) = parse("G02 I5 J0 F100").items
    assert (arc.xe, arc.ye, arc.i, arc.j, arc.cw) == (0, 0, 5_000, 0, True)
    assert arc.plan.end == (0, 0)
    assert not arc.plan.error
    assert arc.plan.pulses["x+"] == arc.plan.pulses["x-"] == 10_000
    assert arc.plan.pulses["y+"] == arc.plan.pulses["y-"] == 10_000
    assert arc.plan == plan(arc.block)


# Quarter arcs of radius 1 mm around (0, 0), one for each quadrant and direction; the arc
# starts on an axis (quadrant q's first axis point in the direction of motion).
QUARTERS = [(q, cw) for q in (1, 2, 3, 4) for cw in (False, True)]


@pytest.mark.parametrize(("quadrant", "cw"), QUARTERS)
def test_arcs_run_in_every_quadrant_and_direction(quadrant, cw):
    step = -1 if cw else 1
    a0 = (quadrant - 1) * 90 if not cw else quadrant * 90 % 360
    a1 = a0 + 90 * step
    p0 = (round(math.cos(math.radians(a0))), round(math.sin(math.radians(a0))))
    p1 = (round(math.cos(math.radians(a1))), round(math.sin(math.radians(a1))))
    text = (f"G00 X{p0[0]} Y{p0[1]}\nG0{2 if cw else 3} X{p1[0]} Y{p1[1]} "
            f"I{-p0[0]} J{-p0[1]} F100")
    _, arc = parse(text).items
    xe, ye = (p1[0] - p0[0]) * 1000, (p1[1] - p0[1]) * 1000
    assert (arc.xe, arc.ye, arc.i, arc.j, arc.cw) == (xe, ye, -p0[0] * 1000, -p0[1] * 1000, cw)
    assert quadrant_of(-arc.i, -arc.j, cw) == quadrant  # it runs through quadrant q only
    assert arc.block == Block(Kind.CIRCULAR, xe, ye, arc.i, arc.j, cw, True,
                              quadrant_of(xe - arc.i, ye - arc.j, cw))
    assert arc.plan.end == (xe, ye)
    assert arc.end == (p1[0] * 1000, p1[1] * 1000)


@pytest.mark.parametrize("cw", [False, True])
def test_arcs_cross_quadrants(cw):
    # Three quarters of a circle from (1, 0) mm around the origin.
    end = "X0 Y-1" if not cw else "X0 Y1"
    _, arc = parse(f"G00 X1\nG0{2 if cw else 3} {end} I-1 J0 F100").items
    assert arc.plan.end == (arc.xe, arc.ye)
    assert sum(arc.plan.pulses.values()) > 3 * 1000  # more than a quarter


def test_arc_end_within_the_tolerance_is_accepted_and_corrected_to_the_programmed_end():
    # The end is 1.5 LSB outside the circle: accepted; the chip stops on its digital path
    # near it and the host's correction line takes the machine to the programmed end.
    arc, fix = parse("G03 X-0.014 Y-0.012 I-0.006 J-0.006 F100").items
    assert math.hypot(arc.xe - arc.i, arc.ye - arc.j) - math.hypot(arc.i, arc.j) == (
        pytest.approx(1.51, abs=0.01))
    assert not arc.plan.error
    assert arc.plan.end == (-12, -12)
    assert isinstance(fix, Line) and fix.correction and fix.feed_mm_min == arc.feed_mm_min
    assert (fix.start, fix.end, fix.line_no) == (arc.end, (-14, -12), arc.line_no)


def test_arc_end_beyond_the_tolerance_is_an_error():
    assert error_of("G01 F100\nG03 X-0.014 Y-0.012 I-0.006 J-0.006", arc_tolerance=1.0) == (
        "t.ngc:2:1: the arc's end is not on its circle: radius 0.008 mm at the start, 0.010 mm "
        "at the end (they differ by 1.5 LSB; tolerance 1 LSB)")
    assert error_of("G02 X10 I3 F100") == (
        "t.ngc:1:1: the arc's end is not on its circle: radius 3.000 mm at the start, 7.000 mm "
        "at the end (they differ by 4000.0 LSB; tolerance 28 LSB)")
    # LinuxCNC's default tolerance: 0.028 mm in G21, 0.0028 in in G20
    assert "tolerance 71.12 LSB" in error_of("G20 G02 X1 I0.3 F1")


def test_every_block_starts_where_the_previous_one_really_ended():
    prog = parse("G03 X-0.014 Y-0.012 I-0.006 J-0.006 F100\nG01 X0.010 Y0.010")
    _, fix, line = prog.items
    assert line.start == fix.end == (-14, -12)
    assert line.end == (10, 10)
    # A full circle after it stays a full circle around the programmed centre.
    prog = parse("G03 X-0.014 Y-0.012 I-0.006 J-0.006 F100\nG02 I0.003")
    _, fix, circle = prog.items
    assert circle.start == fix.end == (-14, -12)
    assert (circle.xe, circle.ye) == (0, 0)
    assert (circle.start[0] + circle.i, circle.start[1] + circle.j) == (-14 + 3, -12)


def test_an_arc_the_k3701_would_not_finish_gets_a_block_end_it_reaches():
    # Radius 1 LSB: (0, 1) is within the tolerance but not on the digital path, and the chip
    # would leave the end quadrant without reaching it: the block's end moves to a grid point
    # the chip stops on; 1 LSB from the programmed end (``docs/chips/k3701.md``), it needs no
    # correction line, and the next block runs to its programmed point.
    arc, line = parse("G02 X0 Y0.001 I-0.001 J0 F100\nG01 X0.002").items
    assert plan(Block.arc(0, 1, -1, 0, cw=True, sqrt2=True)).error
    assert not arc.plan.error and arc.plan.end == (arc.block.xe, arc.block.ye) == (-1, 1)
    assert (line.start, line.end, line.correction) == ((-1, 1), (2, 1), False)


def test_an_arc_of_radius_zero_is_an_error():
    assert error_of("G01 F1\nX1 G02 I0 J0") == (
        "t.ngc:2:4: the arc's centre is its start point (radius 0)")


def test_an_arc_too_big_for_the_k3701_that_leaves_the_coordinate_range_is_an_error():
    assert error_of("G03 I6000 J-6000 F1") == (
        "t.ngc:1:1: the arc leaves the coordinate range on X: it reaches 14485281 LSB, beyond "
        "+-(2^23-1) LSB (+-8388.607 mm)")


def test_an_arc_bulging_out_of_the_coordinate_range_is_an_error():
    # Centre at X838500 Y0 (0.1 mm LSB: the range is +-838860.7 mm), start at its left, end
    # at its top: the short CW way stays in range, the long CCW way reaches X839000.
    text = "G00 X838000\nG0{} X838500 Y500 I500 J0 F100"
    (_, arc) = parse(text.format(2), lsb_mm=0.1).items
    assert arc.end == (8_385_000, 5_000)
    assert error_of(text.format(3), lsb_mm=0.1) == (
        "t.ngc:2:1: the arc leaves the coordinate range on X: it reaches 8390000 LSB, beyond "
        "+-(2^23-1) LSB (+-838860.7 mm)")


# --- errors -----------------------------------------------------------------------------------

@pytest.mark.parametrize(("text", "message"), [
    ("G01 X8388.607 F1", None),
    ("G01 X8388.608 F1", "1:5: X8388.608: the position 8388608 LSB is outside "
                         "-(2^23-1)..2^23-1 LSB (+-8388.607 mm)"),
    ("G91 G00 X8000\nY1 X400", "2:4: X400: the position 8400000 LSB is outside "
                               "-(2^23-1)..2^23-1 LSB (+-8388.607 mm)"),
    ("G00 X-5000\nX5000", "2:1: X5000: the move 10000000 LSB is outside "
                          "-(2^23-1)..2^23-1 LSB (+-8388.607 mm)"),
])
def test_out_of_range_coordinates_are_errors(text, message):
    if message is None:
        assert moves(text) == [(COORD_MAX, 0)]
    else:
        assert error_of(text) == f"t.ngc:{message}"


@pytest.mark.parametrize(("text", "message"), [
    ("G01 X1", "1:1: G01 without a feed rate: program F first"),
    ("G00 X1\nG01 F0 X2", "2:5: F0: the feed must be positive"),
    ("G00 X1\nG02 X2 I0.5", "2:1: G02 without a feed rate: program F first"),
    ("G01 F1\nG03 X1 Y1", "2:1: G03 needs I and/or J (the centre offsets) or R"),
    ("G01 X1 I1 F1", "1:8: I1: I is only for arcs (G02/G03)"),
    ("X5 Y1", "1:1: X5 without a motion mode (G00/G01/G02/G03)"),
    ("G00 X1\n  J2", "2:3: J2: J is only for arcs (G02/G03)"),
])
def test_motion_errors_name_line_and_column(text, message):
    assert error_of(text) == f"t.ngc:{message}"


@pytest.mark.parametrize(("text", "message"), [
    ("G18 G02 X1 I1 F1", "1:5: G02 in G18 moves Z: this machine has two axes (machine.axes "
                         "= 3 runs it)"),
    ("G17 G19", "1:5: G17 and G19 are in the same modal group (plane)"),
    ("G17.1", "1:1: G17.1 is unsupported"),
    ("M03.5", "1:1: M03.5 is unsupported"),
    ("G01 X1 Z5 F1", "1:8: Z5 moves Z: this machine has two axes (machine.axes = 3 runs it)"),
    ("G02 X1 K1 F1", "1:8: K1: a G17 arc takes I and J"),
    ("G01 X1E3", "1:7: unsupported word E3"),
    ("G01 X1 A3", "1:8: unsupported word A3 (K37's axes are X, Y and Z)"),
    ("#1 = [2", "1:8: expression not closed: ']' missing"),
    ("G95", "1:1: G95 is unsupported"),
    ("G33 Z-1 K1", "1:1: G33 is unsupported"),
    ("G41 D1.5", "1:5: D1.5: D must be a non-negative integer"),
    ("G01 X", "1:5: word X has no number"),
    ("G01 X1 (open", "1:8: comment '(' is not closed on its line"),
    ("G01 G00 X1", "1:5: G01 and G00 are in the same modal group (motion)"),
    ("G20 G21", "1:5: G20 and G21 are in the same modal group (units)"),
    ("G90 G91", "1:5: G90 and G91 are in the same modal group (distance)"),
    ("G01 X1 X2 F1", "1:8: X appears twice in one block"),
    ("M02 M30", "1:5: M02 and M30 are in the same modal group (stop)"),
    ("N-1 G00 X1", "1:1: N-1: N must be a non-negative integer"),
    ("N1.5 G00 X1", "1:1: N1.5: N must be a non-negative integer"),
    ("G04", "1:1: G04 needs P (the dwell in seconds)"),
    ("G04 P-1", "1:5: P-1: the dwell must not be negative"),
    ("G04 P1 X2", "1:8: X2: G04 takes only P (seconds)"),
    ("G01 X1 P2 F1", "1:8: P2: P is only for G04 (dwell), G10, G82, G64 and arcs"),
])
def test_word_errors_name_line_and_column(text, message):
    assert error_of(text) == f"t.ngc:{message}"


def test_errors_are_one_line_with_their_position_as_attributes():
    with pytest.raises(GcodeError) as info:
        parse("G17\n\n   G01 X1", source="dir/part.nc")
    e = info.value
    assert (e.source, e.line, e.col) == ("dir/part.nc", 3, 4)
    assert str(e) == f"dir/part.nc:3:4: {e.message}"
    assert "\n" not in str(e)
    assert isinstance(e, ValueError)


def test_the_default_source_name_is_gcode():
    with pytest.raises(GcodeError, match=r"^<gcode>:1:1: "):
        parse("G28.5")


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"lsb_mm": 0}, "lsb_mm must be > 0 mm, not 0"),
    ({"lsb_mm": "1"}, "lsb_mm must be a number, not '1'"),
    ({"arc_tolerance": -1}, "arc_tolerance must be >= 0 LSB, not -1"),
])
def test_bad_parser_parameters_are_refused(kwargs, message):
    with pytest.raises((TypeError, ValueError), match=f"^{message}$"):
        parse("", **kwargs)


def test_an_empty_program_has_no_items():
    prog = parse("")
    assert (prog.items, prog.end, prog.final_position) == ((), False, (0, 0))


def test_a_refused_block_is_reported_once_and_the_blocks_after_it_start_at_its_end():
    # the arc at line 3 starts where line 2 meant to end (X10), so it is on its circle
    with pytest.raises(GcodeError) as info:
        parse("G21 G90 F100\nG01 X10 F-1\nG02 X20 I5 J0\nG03 X10 I-5 J0\nG01 X0\nM30")
    assert info.value.errors == [(2, 9, "F-1: the feed must be positive")]


def test_a_refused_incremental_block_moves_the_next_start_by_its_distance():
    with pytest.raises(GcodeError) as info:
        parse("G21 G91 F100\nG01 X4 Y0\nG01 X6 Y0 P2\nG02 X10 Y0 I5 J0\nM30")
    assert [line for line, _, _ in info.value.errors] == [3]


def test_an_error_in_a_program_that_names_z_is_never_hidden_behind_two_axes():
    with pytest.raises(GcodeError) as info:
        gcode_job("t", "G21 G90 F100\nG18\nG01 X1 Z1 F-3\nG01 Z5\nM30", "t.ngc")
    assert info.value.errors == [(3, 11, "F-3: the feed must be positive")]


@pytest.mark.parametrize(("cycle", "message"), [
    ("G83 X1 Y1 Z-3 R2 Q0.0004", "3:1: G83: the peck Q0.0004 is under half an LSB (0.001 mm)"),
    ("G83 X1 Y1 Z-8000 R2 Q0.5", "3:1: G83: 16004 pecks of Q0.5 from R to Z; at most 10000 a "
                                 "hole"),
])
def test_a_peck_drilling_cycle_too_fine_to_expand_is_refused_before_expanding(cycle, message):
    with pytest.raises(GcodeError) as info:
        parse(f"G21 G90 F100\nG0 Z5\n{cycle}\nM30", source="t.ngc", axes=3)
    assert str(info.value) == f"t.ngc:{message}"


def _chord_errors(program, centre: tuple[float, float], radius: float) -> list[float]:
    """Each line's largest distance from the circle (its ends' and its midpoint's), LSB."""
    errors = []
    start = (0, 0)
    for move in program.moves:
        for point in (move.end[:2], ((start[0] + move.end[0]) / 2, (start[1] + move.end[1]) / 2)):
            errors.append(abs(math.dist(point, centre) - radius))
        start = move.end[:2]
    return errors


def test_an_arc_beyond_the_24_bit_registers_runs_as_chords_within_the_tolerance():
    # a near-straight arc: its centre 9,238 mm away, beyond the K3701's radius registers
    program = parse("G21 G90 F500\nG03 X100 Y0 I50 J9238.47\nM30", source="flat.ngc")
    assert all(isinstance(m, Line) for m in program.moves) and len(program.moves) == 3
    assert program.moves[-1].end == (100_000, 0)
    centre = (50_000, 9_238_470)
    assert max(_chord_errors(program, centre, math.dist((0, 0), centre))) <= 28
    assert program.notes == ("flat.ngc:2: an arc run as 3 lines within the arc tolerance "
                             "(28 LSB): its radius 9238.605 mm is beyond the K3701's 24-bit "
                             "registers",)


def test_an_r_form_arc_beyond_the_24_bit_registers_runs_as_its_i_j_twin_does():
    program = parse("G21 G90 F100\nG02 X20 Y0 R10000\nM30", source="r.ngc")
    centre = (10_000, -round(math.sqrt(10_000_000**2 - 10_000**2)))
    twin = parse(f"G21 G90 F100\nG02 X20 Y0 I10 J{centre[1] / 1000}\nM30", source="r.ngc")
    assert all(isinstance(m, Line) for m in program.moves)
    assert [m.end for m in program.moves] == [m.end for m in twin.moves]
    assert program.moves[-1].end == (20_000, 0)
    assert max(_chord_errors(program, centre, 10_000_000)) <= 28
    assert program.notes == twin.notes != ()


def test_a_helix_steeper_than_the_chips_runs_as_chords_ending_exactly():
    # a ramp: R 0.5 mm, 5 mm down in one turn (the K3701's helix moves Z at most once per step)
    program = parse("G21 G90 F500\nG03 X0 Y0 I0.5 J0 Z-5\nM30", source="ramp.ngc", axes=3)
    lines = program.moves
    assert all(isinstance(m, Line) for m in lines) and lines[-1].end == (0, 0, -5000)
    assert max(_chord_errors(program, (500, 0), 500)) <= 28
    zs = [m.end[2] for m in lines]
    assert zs == sorted(zs, reverse=True) and max(a - b for a, b in pairwise(zs)) <= 501
    assert "more than one LSB per arc step" in program.notes[0]


def test_a_helix_the_chip_runs_stays_one_helical_block():
    program = parse("G21 G90 F500\nG03 X0 Y0 I2 J0 Z-3\nM30", source="h.ngc", axes=3)
    assert [type(m) for m in program.moves] == [Arc] and program.notes == ()


def test_an_arc_ends_within_one_lsb_of_its_exact_programmed_end_not_of_its_rounding():
    # the chip stops at (2461, -4756): 1 LSB from the rounded end (2461, -4757) but 1.42 LSB
    # from the exact one (0.0969 in, -0.1873 in = 2461.26, -4757.42 LSB): a correction follows
    program = parse("G20 G90 F10\nG02 X0.0969 Y-0.1873 I0.2019 J-0.0142\nM30")
    arc, correction = program.moves
    assert isinstance(arc, Arc) and arc.end == (2461, -4756)
    assert isinstance(correction, Line) and correction.correction
    assert correction.end == (2461, -4757)
    assert max(abs(a - b) for a, b in zip(correction.end, (2461.26, -4757.42), strict=True)) <= 1


def test_incremental_moves_add_to_the_exact_position_so_their_roundings_do_not_add_up():
    # 100 x 0.00123 in = 3.124 mm: each step rounds to 31 LSB, the sum must not (3,100)
    inch = parse("G20 G91 F10\n" + "G01 X0.00123\n" * 100 + "M30")
    assert inch.moves[-1].end == (3124, 0)
    # each step under half an LSB moves nothing alone, together 0.4 mm
    fine = parse("G21 G91 F100\n" + "G01 X0.0004 Y-0.0006\n" * 1000 + "M30")
    assert fine.moves[-1].end == (400, -600)
    steps = [m.end[0] - m.start[0] for m in fine.moves]
    assert set(steps) <= {0, 1} and sum(steps) == 400
