"""The CAM words of the built-in front end: events, offsets, cycles, planes, R arcs, the
lexer's characters, every error at once, and exact ends with no drift."""

from __future__ import annotations

import math

import pytest

from k37.firmware_model.gcode.parser import GcodeError, parse
from k37.firmware_model.gcode.units import MAX_ERRORS
from k37.firmware_model.gcode.words import G_CODES, M_CODES, markdown
from k37.firmware_model.job import gcode_job
from k37.firmware_model.motion.program import Arc, Dwell, Event, Line
from k37.sim.run.jobfile import load_job
from k37.sim.run.report import validate
from k37.sim.run.runner import RunOptions, run_job
from tests.firmware_model.gcode.test_gcode import error_of


def ends(text: str, **kwargs) -> list[tuple[int, ...]]:
    return [m.end for m in parse(text, **kwargs).moves]


# --- events ---------------------------------------------------------------------------------

def test_words_with_no_hardware_are_events_with_their_lines_in_rs274_order():
    prog = parse("G21 F600\nT2 M6 S8000 M3 M8\nG01 X1 M0\nM1\nM5 M9\nM30")
    events = [(e.line_no, e.word, e.kind, e.value) for e in prog.events]
    assert events == [(2, "S8000", "spindle_speed", 8000.0), (2, "T2", "tool_select", 2.0),
                      (2, "M6", "tool_change", 2.0), (2, "M3", "spindle_cw", None),
                      (2, "M8", "coolant_flood", None), (3, "M0", "program_stop", None),
                      (4, "M1", "optional_stop", None), (6 - 1, "M5", "spindle_stop", None),
                      (5, "M9", "coolant_off", None)]
    # M00 comes after the motion of its block
    kinds = [type(it).__name__ for it in prog.items]
    assert kinds[5:7] == ["Line", "Event"]
    assert prog.to_dict()["events"] == 9 and prog.end


def test_a_two_axis_programs_summary_has_no_new_keys():
    assert set(parse("G01 X1 F1\nM30").to_dict()) == {
        "source", "lsb_mm", "sqrt2", "arc_tolerance", "end", "lines", "arcs", "dwells"}


def test_the_firmware_records_each_event_at_its_cycle():
    job = gcode_job("ev", "G21 F600 M3 S1000\nG01 X0.05\nM5\nM30", "<ev>")
    report = run_job(job, RunOptions(backend="cxxrtl", max_cycles=2_000_000)).report
    assert report["status"] == "ok"
    validate(report)
    events = report["events"]
    assert [(e["line"], e["word"]) for e in events] == [(1, "S1000"), (1, "M3"), (3, "M5")]
    (block,) = report["blocks"]
    assert events[1]["cycle"] <= block["start_cycle"] < block["end_cycle"] <= events[2]["cycle"]


# --- offsets, home, tool length ----------------------------------------------------------------

def test_g92_offsets_the_coordinates_and_g92_1_clears_them():
    assert ends("G00 X5 Y5\nG92 X0 Y0\nG01 X1 F1\nG92.1\nG00 X1") == [
        (5000, 5000), (6000, 5000), (1000, 5000)]


def test_g53_moves_in_machine_coordinates_for_its_block_only():
    assert ends("G00 X5\nG92 X0\nG53 G00 X1\nG00 X1") == [(5000, 0), (1000, 0), (6000, 0)]
    assert "G53 is only for G00/G01" in error_of("G53 G02 X1 I1 F1")
    assert error_of("G91 G53 G00 X1") == (
        "t.ngc:1:5: G53 takes absolute machine coordinates: not in G91")


def test_g28_and_g30_go_to_the_origin_through_the_programmed_point():
    assert ends("G00 X5 Y5\nG28 X3\nG00 X2 Y2\nG30") == [
        (5000, 5000), (3000, 5000), (0, 5000), (2000, 2000), (2000, 2000), (0, 0)]


def test_g43_adds_the_tool_length_from_the_table_to_z_and_g49_removes_it():
    text = "G00 Z0\nT1 M6\nG43 H1\nG00 Z5\nG43\nG00 Z5\nG49\nG00 Z5"
    assert [e[2] for e in ends(text, axes=3, tools={1: 10.0})] == [0, 15000, 15000, 5000]
    assert [e[2] for e in ends(text, axes=3)] == [0, 5000, 5000, 5000]  # no table: zero
    assert error_of("G43 H3", tools={1: 10.0}) == (
        "t.ngc:1:5: H3: tool 3 is not in the job's tool table ([1])")


# --- planes, helices, arcs -------------------------------------------------------------------

def test_positions_have_one_coordinate_per_machine_axis():
    prog = parse("G01 X1 Y2 Z-1 F100", axes=3)
    (line,) = prog.items
    assert (line.xe, line.ye, line.ze, line.start, line.end) == (1000, 2000, -1000,
                                                                 (0, 0, 0), (1000, 2000, -1000))
    assert prog.final_position == (1000, 2000, -1000) and prog.to_dict()["axes"] == 3


def test_a_g18_arc_runs_z_first_and_x_second_as_linuxcncs_canon():
    (arc,) = parse("G18 G02 X10 Z0 I5 K0 F100", axes=3).moves
    assert isinstance(arc, Arc) and arc.plane == 18 and arc.plane_axes == (2, 0, 1)
    assert (arc.block.xe, arc.block.ye, arc.block.i, arc.block.j) == (0, 10000, 0, 5000)
    assert arc.center == (0, 5000) and arc.radius == 5000 and arc.end == (10000, 0, 0)
    (arc,) = parse("G19 G03 Y4 Z4 J4 F100", axes=3).moves
    assert arc.plane_axes == (1, 2, 0) and arc.end == (0, 4000, 4000)


def test_a_helix_moves_the_normal_axis_along_the_arc():
    (arc,) = parse("G17 G03 X0 Y0 Z-1 I5 J0 F100", axes=3).moves
    assert (arc.xe, arc.ye, arc.ze) == (0, 0, -1000) and arc.end == (0, 0, -1000)
    assert arc.span[1] == pytest.approx(math.tau)


def test_z_words_that_do_not_move_z_are_accepted_on_two_axes():
    assert ends("G00 Z0 X1\nG01 Z0.0 Y1 F10") == [(1000, 0), (1000, 1000)]
    assert "machine.axes = 3" in error_of("G17 G02 X0 Y0 Z1 I1 F1")


@pytest.mark.parametrize(("cw", "r", "centre"), [
    (True, "10", (10000, 0)), (True, "-10", (0, 10000)),
    (False, "10", (0, 10000)), (False, "-10", (10000, 0))])
def test_r_arcs_take_the_short_way_for_positive_r_and_the_long_for_negative(cw, r, centre):
    (arc,) = parse(f"G0{2 if cw else 3} X10 Y10 R{r} F100").moves
    assert arc.center == centre and arc.end == (10000, 10000)
    assert (arc.span[1] < math.pi) == (r == "10") == (not (arc.span[1] > math.pi))


def test_g90_1_takes_arc_centres_as_absolute_coordinates():
    assert parse("G00 X10\nG90.1 G03 X0 Y10 I0 J0 F1").moves[1].center == (0, 0)
    assert parse("G00 X10\nG91.1 G03 X0 Y10 I-10 J0 F1").moves[1].center == (0, 0)


def test_modal_settings_with_one_mode_here_are_accepted_and_do_nothing():
    assert parse("G40 G49 G54 G61 G94 G17 G21 G90\nG64 P0.01 Q0.01\nG59").items == ()


# --- canned cycles ---------------------------------------------------------------------------

def test_g81_expands_into_rapid_feed_rapid_and_repeats_at_each_xy():
    prog = parse("G00 Z10\nG98 G81 X1 Y1 Z-2 R1 F100\nX2", axes=3)
    moves = [(m.end, m.rapid) for m in prog.moves]
    assert moves == [((0, 0, 10000), True),
                     ((1000, 1000, 10000), True), ((1000, 1000, 1000), True),
                     ((1000, 1000, -2000), False), ((1000, 1000, 10000), True),
                     ((2000, 1000, 10000), True), ((2000, 1000, 1000), True),
                     ((2000, 1000, -2000), False), ((2000, 1000, 10000), True)]


def test_g99_retracts_to_r_and_g82_dwells_at_the_bottom():
    prog = parse("G00 Z10\nG99 G82 X1 Y1 Z-2 R1 P0.5 F100", axes=3)
    assert [type(it).__name__ for it in prog.items] == ["Line"] * 4 + ["Dwell", "Line"]
    assert prog.items[-1].end == (1000, 1000, 1000) and prog.items[-2].seconds == 0.5


def test_g83_pecks_back_to_r_and_rapids_down_to_just_above_the_last_peck():
    prog = parse("G00 Z5\nG98 G83 X0 Y0 Z-3 R1 Q2 F100", axes=3)
    zs = [(m.end[2], m.rapid) for m in prog.moves[3:]]
    assert zs == [(-1000, False), (1000, True), (-746, True), (-3000, False), (5000, True)]


def test_a_canned_cycle_needs_its_words_and_three_axes():
    assert error_of("G81 X1 Y1 R1 F1", axes=3) == "t.ngc:1:1: G81 needs Z"
    assert error_of("G81 X1 Y1 Z-1 R1 F1") == (
        "t.ngc:1:1: G81 moves Z: this machine has two axes (machine.axes = 3 runs it)")
    assert "Q-1 must be positive" in error_of("G83 X1 Z-1 R1 Q-1 F1", axes=3)
    assert error_of("G81 X1 Z2 R1 F1", axes=3) == (
        "t.ngc:1:1: G81: the retract plane R is below the bottom Z")
    assert error_of("G19 G81 X1 Z-1 R1 F1", axes=3) == (
        "t.ngc:1:5: G81 in G19 is unsupported: canned cycles drill along Z, in G17")


# --- the lexer -------------------------------------------------------------------------------

def test_a_utf8_byte_order_mark_and_percent_lines_are_skipped(tmp_path):
    assert ends("\ufeff%\nG00 X1\n%") == [(1000, 0)]
    path = tmp_path / "job.toml"
    path.write_bytes(b'\xef\xbb\xbf[program]\ngcode = "G00 X1"\n')
    assert load_job(path).program.final_position == (1000, 0)


def test_spaces_and_tabs_may_stand_inside_a_word_and_its_number():
    assert ends("G0 X 1 2.\t5 Y - 3") == [(12_500, -3_000)]


@pytest.mark.parametrize(("text", "message"), [
    ("G01 X\u0661\u0662 F1", "1:6: unexpected character '\u0661' (U+0661 ARABIC-INDIC DIGIT "
                             "ONE): numbers take ASCII digits 0-9"),
    ("G01 X1\x0b2 F1", "1:7: unexpected white space '\\x0b' (U+000B): only spaces and tabs "
                       "separate words"),
    ("G01\u00a0X1 F1", "1:4: unexpected white space '\\xa0' (U+00A0 NO-BREAK SPACE): only "
                       "spaces and tabs separate words"),
    ("G01 X1 (a (b) c)", "1:11: nested comment '('"),
    ("G01 X1 ! F1", "1:8: unexpected character '!' (U+0021 EXCLAMATION MARK)"),
])
def test_characters_the_lexer_cannot_read_are_clear_errors(text, message):
    assert error_of(text).startswith(f"t.ngc:{message}")


# --- every error at once ---------------------------------------------------------------------

def test_every_error_of_a_program_is_reported_with_its_place():
    with pytest.raises(GcodeError) as info:
        parse("G01 X1\nG00 Y1 Q3\nG01 X2 F1\nG07\nG17 G18", source="p.nc")
    assert str(info.value).splitlines() == [
        "p.nc:1:1: G01 without a feed rate: program F first",
        "p.nc:2:8: Q3: Q is only for G83 (peck depth) and G64",
        "p.nc:4:1: G07 is unsupported",
        "p.nc:5:5: G17 and G18 are in the same modal group (plane)"]
    assert (info.value.line, info.value.col) == (1, 1) and len(info.value.errors) == 4


def test_rs274_ngc_constructs_run_and_their_errors_are_reported_with_the_others():
    with pytest.raises(GcodeError) as info:
        parse("#1 = 2\nG01 X#1 F1\nG01 X[#1 / 0]\nG07")
    assert info.value.errors == [(3, 10, "division by zero"), (4, 1, "G07 is unsupported")]


def test_blocks_after_the_program_end_are_ignored_with_one_note():
    # as LinuxCNC: the first M02/M30 ends the program, even a file of several jobs
    program = parse("G01 X1 F100\nM30\n(next job)\nG00 X1\nG00 X2\nG07", source="jobs.nc")
    assert program.end and len(program.moves) == 1
    assert program.notes == ("jobs.nc:4: the program ended (M02/M30) before this line: the "
                             "rest of the file is ignored",)


def test_grbl_setting_and_status_lines_are_notes_not_errors():
    program = parse("$110=5000\n?\nG01 X1 F100\n$H\nM30", source="g.nc")
    assert len(program.moves) == 1
    assert [note.split(": ")[0] for note in program.notes] == ["g.nc:1", "g.nc:2", "g.nc:4"]
    assert all("ignored" in note for note in program.notes)


def test_a_program_with_nothing_after_its_end_has_no_note():
    assert parse("G01 X1 F100\nM30\n\n(trailing comment)\n%\n").notes == ()


def test_errors_stop_at_the_limit():
    with pytest.raises(GcodeError) as info:
        parse("G07\n" * 100)
    assert len(info.value.errors) == MAX_ERRORS + 1
    assert info.value.errors[-1][2] == f"stopped after {MAX_ERRORS} errors"


# --- exact ends, no drift ----------------------------------------------------------------------

@pytest.mark.parametrize("arc", ["G02 X0 Y-0.003 I0.012 J0.009", "G02 X0 Y-0.007 I-0.005 J-0.002"])
def test_small_arcs_end_at_their_programmed_end(arc):
    prog = parse(f"G21 G90 F600\n{arc}")
    assert prog.final_position == (0, -3 if "0.003" in arc else -7)


def test_chained_off_grid_arcs_never_drift():
    # a CamBam-style circle of four quarter arcs of radius 0.9205 mm (off the grid at every
    # quarter), twelve laps: every lap ends exactly where it started
    lap = ("G3 X0.0 Y0.9205 I-0.9205 J0.0\nG3 X-0.9205 Y0.0 I0.0 J-0.9205\n"
           "G3 X0.0 Y-0.9205 I0.9205 J0.0\nG3 X0.9205 Y0.0 I0.0 J0.9205\n")
    prog = parse("G21 G90 F600\nG0 X0.9205 Y0\n" + lap * 12)
    arcs = [m for m in prog.moves if isinstance(m, Arc)]
    assert len(arcs) == 48
    for k, arc in enumerate(arcs):
        nxt = prog.items[arc.index + 1] if arc.index + 1 < len(prog.items) else None
        end = nxt.end if isinstance(nxt, Line) and nxt.correction else arc.end
        assert end == [(0, 921), (-921, 0), (0, -921), (921, 0)][k % 4], k
        assert arc.radius == pytest.approx(921)


def test_an_arc_stopping_within_1_lsb_needs_no_correction_and_nothing_drifts():
    # a 45 degree arc of radius 100 LSB: the chip stops at (-29, 70), 1 LSB from (-29, 71);
    # incremental moves after it are from the programmed point, not from the stop
    prog = parse("G21 G91 F100\nG03 X-0.029 Y0.071 I-0.100 J0\nG01 X0.029 Y-0.071\nX1")
    arc, back, line = prog.items
    assert arc.end == (-29, 70) and not back.correction
    assert (back.start, back.end, line.end) == ((-29, 70), (0, 0), (1000, 0))


def test_a_correction_line_is_a_short_line_at_the_arcs_feed():
    prog = parse("G21 F600\nG03 X-0.014 Y-0.012 I-0.006 J-0.006")
    arc, fix = prog.items
    assert isinstance(fix, Line) and fix.correction and not fix.rapid
    assert max(abs(fix.xe), abs(fix.ye)) <= 3 and fix.feed_mm_min == arc.feed_mm_min == 600


# --- the word table --------------------------------------------------------------------------

def test_the_word_table_documents_every_code_it_dispatches():
    doc = markdown()
    for key in G_CODES:
        number = f"{key // 10:02d}" if key % 10 == 0 else f"{key / 10:04.1f}"
        assert f"| G{number} |" in doc
    for key in M_CODES:
        assert f"| M{key:02d} |" in doc
    assert isinstance(parse("G04 P1").items[0], Dwell)
    assert isinstance(parse("M3").items[0], Event)
