"""M70-M73 (the modal state saved and restored, in and around subroutines) and G93 (inverse
time feed) in the built-in front end, as LinuxCNC's ``rs274`` has them."""

from __future__ import annotations

import math

import pytest

from k37.firmware_model.feeds import clamped_feeds
from k37.firmware_model.gcode.parser import parse
from k37.firmware_model.job import gcode_job
from tests.firmware_model.gcode.test_gcode import error_of
from tests.firmware_model.gcode.test_gcode_words import ends

# --- M70-M73 -----------------------------------------------------------------------------------

def test_m72_restores_the_units_distance_mode_and_feed_m70_saved():
    program = parse("G21 G90 F600\nM70\nG20 G91 F5\nG1 X1\nM72\nG1 X5\nM30")
    assert [(m.end, m.feed_mm_min) for m in program.moves] == [
        ((25_400, 0), 127.0), ((5_000, 0), 600.0)]


def test_m72_keeps_the_motion_mode():
    assert ends("G21 G90 F600\nM70\nG0 X1\nM72\nX2") == [(1000, 0), (2000, 0)]
    assert [m.rapid for m in parse("G21 G90 F600\nM70\nG0 X1\nM72\nX2").moves] == [True, True]


def test_m72_may_restore_again_until_m71_forgets():
    assert error_of("G21 F600\nM70\nG91\nM72\nG91\nM72\nM71\nM72") == (
        "t.ngc:8:1: M72: no modal state saved in this call (M70 or M73 saves it)")


def test_m73_restores_the_callers_state_at_endsub_and_at_return():
    sub = ("o<s> sub\nM73\nG20 G91 F5\nG1 X1\no<r> if [#1 GT 0]\no<s> return\no<r> endif\n"
           "G1 X1\no<s> endsub\n")
    program = parse(sub + "G21 G90 F600\no<s> call [0]\nG1 X0\no<s> call [1]\nG1 Y1\nM30")
    assert [(m.end, m.feed_mm_min) for m in program.moves] == [
        ((25_400, 0), 127.0), ((50_800, 0), 127.0), ((0, 0), 600.0),
        ((25_400, 0), 127.0), ((25_400, 1000), 600.0)]


def test_a_state_saved_in_a_subroutine_ends_with_it():
    assert error_of("o1 sub\nM70\no1 endsub\no1 call\nM72") == (
        "t.ngc:5:1: M72: no modal state saved in this call (M70 or M73 saves it)")


def test_restoring_records_the_spindle_and_coolant_changes_and_the_speed_is_rpm():
    program = parse("G21 F600 S1000 M3\nM70\nS20 M5 M8\n(DEBUG, #<_rpm>)\nM72\n"
                    "(DEBUG, #<_rpm>)\nG1 X1")
    assert [(e.line_no, e.kind, e.value) for e in program.events] == [
        (1, "spindle_speed", 1000.0), (1, "spindle_cw", None), (3, "spindle_speed", 20.0),
        (3, "spindle_stop", None), (3, "coolant_flood", None), (4, "debug", None),
        (5, "spindle_speed", 1000.0), (5, "spindle_cw", None), (5, "coolant_off", None),
        (6, "debug", None)]
    assert [e.word for e in program.events if e.kind == "debug"] == [
        "(DEBUG, 20.000000)", "(DEBUG, 1000.000000)"]


# --- G93 ---------------------------------------------------------------------------------------

def test_in_g93_a_lines_feed_is_f_times_its_length():
    program = parse("G21 G93\nG1 X30 Y40 F2\nG1 X0 Y0 F0.5\nG0 X10\nM30")
    assert [m.feed_mm_min for m in program.moves] == [100.0, 25.0, None]


def test_in_g93_an_arcs_feed_is_f_times_its_length_along_the_helix():
    program = parse("G21 G93 G17\nG2 X10 Y-10 I0 J-10 Z-5 F3\nM30", axes=3)
    quarter = math.pi / 2 * 10
    assert program.moves[0].feed_mm_min == pytest.approx(3 * math.hypot(quarter, 5))


def test_in_g93_inch_programs_feed_in_the_same_time():
    (line,) = parse("G20 G93 G1 X1 F2\nM30").moves
    assert line.feed_mm_min == pytest.approx(50.8)


def test_changing_the_feed_mode_forgets_the_feed():
    assert error_of("G21 F600\nG93\nG94\nG1 X1") == (
        "t.ngc:4:1: G01 without a feed rate: program F first")


@pytest.mark.parametrize(("text", "message"), [
    ("G93 G1 X1", "1:5: G01 in inverse time (G93) needs F (the inverse of the move's time in "
                  "minutes)"),
    ("G93 G1 X1 F2\nY1", "2:1: G01 in inverse time (G93) needs F (the inverse of the move's "
                         "time in minutes)"),
    ("G93 G1 X1 F0", "1:11: F0: the feed must be positive"),
    ("G0 Z5\nG93 G81 X1 Z-1 R1 F2", "2:5: G81 in inverse time (G93): G93 is for G01, G02 and "
                                    "G03 (G94 first)"),
    ("G93 G05.1 X9 Y1 I4 J8 F2", "1:5: G05.1 in inverse time (G93): G93 is for G01, G02 and "
                                 "G03 (G94 first)"),
])
def test_g93_errors_name_what_is_missing(text, message):
    assert error_of(text, axes=3) == f"t.ngc:{message}"


def test_a_g93_feed_above_the_maximum_is_clamped_and_warned_as_any_feed():
    job = gcode_job("fast", "G21 G93\nG1 X100 F10000\nM30", "t.ngc")
    assert job.program.moves[0].feed_mm_min == 1_000_000.0
    (warning,) = clamped_feeds(job)
    assert warning.startswith("t.ngc:2: feeds above the K3701's maximum run at it: line 2 at ")
