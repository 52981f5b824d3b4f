"""The RS-274/NGC language of the built-in front end: expressions, parameters, O-word
subroutines and loops, polar coordinates, messages, and its errors (never a traceback)."""

from __future__ import annotations

import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from k37.firmware_model.gcode import ngc
from k37.firmware_model.gcode.lex import LexError, read_line
from k37.firmware_model.gcode.parser import GcodeError, parse
from tests.firmware_model.gcode.test_gcode import error_of


def xs(text: str, **kwargs) -> list[int]:
    """The X end (LSB, 1 um) of every move."""
    return [m.end[0] for m in parse(text, **kwargs).moves]


def value_of(expression: str) -> float:
    """An expression's value, read back from a move to it (mm, to the LSB)."""
    return xs(f"G0 X[{expression}]")[0] / 1000


# --- expressions -----------------------------------------------------------------------------

@pytest.mark.parametrize(("expression", "value"), [
    ("1 + 2 * 3 - 4 / 2", 5),
    ("2 ** 3 ** 2", 64),  # left to right, as LinuxCNC
    ("5 - 3 - 1", 1),
    ("-7 MOD 3", 2),
    ("7 MOD -3", 1),
    ("-2 ** 2", 4),  # the sign belongs to the number
    ("1 + 1 EQ 2", 1),
    ("1 EQ 1.00005", 1),  # EQ within 0.0001
    ("1 LT 1.00001", 1),
    ("1 OR 0 AND 0", 0),  # one level, left to right
    ("1 XOR 1", 0),
    ("[1 + 2] * 3", 9),
    ("- [2 + 1]", -3),
    ("2 ** 0.5", math.sqrt(2)),
])
def test_operators_have_linuxcncs_precedence_and_associativity(expression, value):
    assert value_of(expression) == pytest.approx(value, abs=0.0005)


@pytest.mark.parametrize(("expression", "value"), [
    ("SIN[30]", 0.5), ("COS[60]", 0.5), ("TAN[45]", 1), ("ASIN[0.5]", 30),
    ("ACOS[0.5]", 60), ("ATAN[1]/[1]", 45), ("ATAN[1]/[-1]", 135), ("SQRT[16]", 4),
    ("ABS[-3]", 3), ("EXP[1]", math.e), ("LN[EXP[2]]", 2), ("FIX[-2.5]", -3),
    ("FUP[-2.5]", -2), ("ROUND[2.5]", 3), ("ROUND[-2.5]", -3),
    ("EXISTS[#<nothing>]", 0), ("sin[30] + cos [ 60 ]", 1),
])
def test_functions_take_and_give_degrees_as_linuxcnc(expression, value):
    assert value_of(expression) == pytest.approx(value, abs=0.0005)


# --- parameters ------------------------------------------------------------------------------

def test_numbered_parameters_are_zero_until_set_and_may_be_indirect():
    assert xs("G0 X#7\n#2 = 5\n#1 = 2\nG0 X##1\nG0 X#[1 + 1]") == [0, 5000, 5000]


def test_settings_on_a_line_take_effect_after_the_line_is_read():
    assert xs("#1 = 1\n#1 = 2 #2 = #1\nG0 X#2\nG0 X#1") == [1000, 2000]
    assert xs("#1 = 3\n#1 = 4 G0 X#1\nG0 X#1") == [3000, 4000]


def test_named_parameters_ignore_case_and_spaces_and_unset_ones_are_errors():
    assert xs("#<Tool Dia> = 3\nG0 X#<tooldia>") == [3000]
    assert error_of("G0 X#<nothing>") == "t.ngc:1:5: parameter #<nothing> is not set"


def test_local_parameters_belong_to_their_call_and_globals_to_all():
    text = """#<x> = 1
#<_g> = 2
#1 = 7
o<s> sub
  #<x> = 5
  G0 X#<_g> Y#1
  #<_g> = 3
o<s> endsub
o<s> call [4]
G0 X#<x> Y#1
G0 X#<_g>
"""
    program = parse(text)
    assert [m.end[:2] for m in program.moves] == [(2000, 4000), (1000, 7000), (3000, 7000)]


def test_a_subroutines_local_is_not_visible_to_its_caller():
    text = "o1 sub\n#<a> = 1\no1 endsub\no1 call\nG0 X#<a>"
    assert error_of(text) == "t.ngc:5:5: parameter #<a> is not set"


def test_the_interpreters_parameters_give_modes_and_position():
    text = ("G20 G91 G0 X1 Y2 Z0.5\nG55 G1 F10 X0.1\n"
            "G90 G0 X[#5420 * 10] Y[#<_y> * 10] Z[#5220 + #<_imperial> + #<_incremental>]")
    # the line is read before its G90 acts: _incremental is still 1
    assert parse(text, axes=3).moves[-1].end == (279_400, 508_000, 101_600)


def test_the_interpreters_parameters_cannot_be_set_and_unsupported_ones_are_named():
    assert error_of("#<_x> = 1") == "t.ngc:1:1: #<_x> is the interpreter's: it cannot be set"
    assert error_of("#5221 = 1") == ("t.ngc:1:1: #5221 is the interpreter's: setting it "
                                     "(offsets, tool data) is unsupported")
    assert error_of("G0 X#5061") == ("t.ngc:1:5: #5061 is a probe result: probing (G38.x) is "
                                     "unsupported")


# --- O-words ---------------------------------------------------------------------------------

def test_subroutines_return_values_and_recurse():
    factorial = """o<fact> sub
  o<if> if [#1 EQ 0]
    o<fact> return [1]
  o<if> else
    o<fact> call [#1 - 1]
    o<fact> return [#<_value> * #1]
  o<if> endif
o<fact> endsub
o<fact> call [5]
G0 X#<_value>
o<none> sub
o<none> endsub [7]
o<none> call
G0 X#<_value>
"""
    assert xs(factorial) == [120_000, 7000]


def test_a_subroutine_may_be_defined_after_its_call():
    assert xs("o10 call [3]\nM2\no10 sub\nG0 X#1\no10 endsub") == [3000]


@pytest.mark.parametrize(("loop", "expected"), [
    ("#1 = 0\no1 while [#1 LT 3]\n#1 = [#1 + 1]\nG0 X#1\no1 endwhile", [1000, 2000, 3000]),
    ("#1 = 5\no1 do\nG0 X#1\n#1 = [#1 + 1]\no1 while [#1 LT 3]", [5000]),
    ("#1 = 0\no1 repeat [3]\n#1 = [#1 + 2]\nG0 X#1\no1 endrepeat", [2000, 4000, 6000]),
    ("#1 = 0\no1 while [1]\n#1 = [#1 + 1]\no2 if [#1 EQ 2]\no1 continue\no2 elseif "
     "[#1 GT 3]\no1 break\no2 endif\nG0 X#1\no1 endwhile", [1000, 3000]),
    ("#1 = 2\no<a> if [#1 EQ 1]\nG0 X1\no<a> elseif [#1 EQ 2]\nG0 X2\no<a> else\nG0 X3\n"
     "o<a> endif", [2000]),
])
def test_loops_and_conditions_run_as_linuxcnc(loop, expected):
    assert xs(loop) == expected


def test_the_program_end_inside_a_subroutine_ends_the_program():
    program = parse("o1 sub\nM2\no1 endsub\nG0 X1\no1 call\nG0 X2\nG0 X3")
    assert program.end and xs("o1 sub\nM2\no1 endsub\nG0 X1\no1 call\nG0 X2") == [1000]


@pytest.mark.parametrize(("text", "message"), [
    ("o1 while [1]\nG0 X1", "1:1: o1 while is not closed: o1 endwhile missing"),
    ("o1 while [1]\no2 endwhile", "2:1: o2 endwhile does not close o1 while"),
    ("o1 endif", "1:1: o1 endif has no opening statement"),
    ("o1 break", "1:1: o1 break is not inside an o1 loop"),
    ("o1 call", "1:1: o1 call: the program has no o1 sub (subroutine files are not searched)"),
    ("o1 sub\no2 sub\no2 endsub\no1 endsub", "2:1: o2 sub inside another structure: "
                                             "subroutines are defined at the top level"),
    ("o1 sub\no1 call\no1 endsub\no1 call", "2:1: o1 call: more than 64 nested calls (a "
                                            "recursion that never ends?)"),
    ("o1 frob", "1:4: unknown O-word keyword 'frob' (sub, endsub, call, return, if, elseif, "
                "else, endif, while, endwhile, do, repeat, endrepeat, break, continue; o1 "
                "alone on its line is a program number)"),
    ("O100 G1 X5", "1:6: unknown O-word keyword 'g' (sub, endsub, call, return, if, elseif, "
                   "else, endif, while, endwhile, do, repeat, endrepeat, break, continue; "
                   "o100 alone on its line is a program number)"),
    ("o#1 sub\no1 endsub", "1:1: o#1 sub: only a call takes a computed O-word number"),
    ("o-1 call", "1:1: o-1 call: an O-word number is not negative"),
    ("#1 = 2.5\no#1 call", "2:1: o#1 call: the O-word number 2.5 is not a whole number >= 0"),
    ("o1 if\no1 endif", "1:4: o1 if takes one value [..]"),
    ("G0 X1 o1 sub", "1:7: an O-word must begin its line"),
    ("o1 while [#<u> GT 1]\no1 endwhile", "1:11: parameter #<u> is not set"),
])
def test_o_word_errors_stop_the_program_at_their_place(text, message):
    assert error_of(text) == f"t.ngc:{message}"


@pytest.mark.parametrize("first", ["O0000(MY GCODE)", "O1000", "O1000 (CAM POST)", "o1000;x",
                                   "O 1 0 0 ( x )", "O<prog>", "O-5", "O#<_x>", "O[100]",
                                   "/O100", "N5 O100"])
def test_a_program_number_line_is_read_and_does_nothing(first):
    assert xs(f"{first}\nG21 G90\nG1 X10 F100\nO2000\nG1 X3\nM30") == [10000, 3000]


def test_a_program_number_line_keeps_its_message():
    program = parse("O1000 (MSG, cam post)\nG0 X1")
    assert [(e.line_no, e.word) for e in program.events] == [(1, "(MSG, cam post)")]


@pytest.mark.parametrize("call", ["#2 = 100\no#2 call [5]", "o[50+50] call [5]",
                                  "O00100 call [5]", "N30 o100 call [5]"])
def test_o_word_numbers_may_be_computed_padded_or_after_a_line_number(call):
    assert xs(f"N10 O0100 sub\nG1 X#1 F100\nN20 o100 endsub\n{call}\nM30") == [5000]


def test_a_loop_that_never_ends_is_stopped_at_the_block_limit(monkeypatch):
    monkeypatch.setattr(ngc, "MAX_BLOCKS", 1000)
    assert error_of("o1 while [1]\nG0 X1\no1 endwhile") == (
        "t.ngc:3:1: more than 1,000 lines executed (loops and calls counted each time): the "
        "program is stopped here (a loop that never ends?)")


def test_an_error_in_a_loop_is_reported_once():
    with pytest.raises(GcodeError) as info:
        parse("o1 repeat [5]\nG0 X[1/0]\no1 endrepeat")
    assert info.value.errors == [(2, 7, "division by zero")]


# --- errors in values ------------------------------------------------------------------------

@pytest.mark.parametrize(("text", "message"), [
    ("G0 X[1/0]", "1:7: division by zero"),
    ("G0 X[1 MOD 0]", "1:8: MOD by zero"),
    ("G0 X[SQRT[-1]]", "1:6: SQRT[-1]: the argument must not be negative"),
    ("G0 X[ACOS[2]]", "1:6: ACOS[2]: the argument must be within -1..1"),
    ("G0 X[LN[0]]", "1:6: LN[0]: the argument must be positive"),
    ("G0 X[-8 ** 0.5]", "1:9: -8 ** 0.5: a negative number to a non-integer power"),
    ("G0 X[10 ** 400]", "1:9: 10 ** 400 is too large"),
    ("G0 X[FOO[1]]", "1:6: unknown function 'FOO'"),
    ("G0 X[1 + 2", "1:11: expression not closed: ']' missing"),
    ("G0 X[1 ? 2]", "1:8: unknown operator '?' in an expression"),
    ("G0 X#[1.5]", "1:5: a parameter number must be an integer, not 1.5"),
    ("G0 X#6000", "1:5: parameter #6000 is out of range (#1-#5000, and the interpreter's)"),
    ("#1 G0 X1", "1:4: expected '=' after the parameter (a setting: #1 = value), found 'g'"),
    ("G0 X[" + "[" * 100 + "1" + "]" * 101, "1:70: values nested more than 64 deep"),
])
def test_errors_in_values_name_their_column(text, message):
    assert error_of(text) == f"t.ngc:{message}"


# --- polar coordinates, messages, refused features ---------------------------------------------

def test_polar_coordinates_end_where_linuxcnc_puts_them():
    program = parse("G0 @10 ^90\nG0 ^180\nG91 G0 ^-90\nG0 @5\nG90 G0 @2")
    assert [m.end[:2] for m in program.moves] == [
        (0, 10_000), (-10_000, 0), (0, 10_000), (0, 15_000), (0, 2000)]


def test_polar_steps_in_g91_do_not_add_up_roundings():
    text = "G20 G0 X2 Y0\no1 repeat [800]\nG91 G1 F10 @-.0025 ^4.5\no1 endrepeat"
    x, y = parse(text).moves[-1].end[:2]
    r, theta = 2 - 800 * 0.0025, math.radians(800 * 4.5)
    assert (x, y) == (round(r * math.cos(theta) * 25_400), round(r * math.sin(theta) * 25_400))


def test_polar_coordinates_with_x_or_an_arc_are_errors():
    assert error_of("G0 @1 X1") == "t.ngc:1:4: polar coordinates (@, ^) and X or Y in one block"
    assert error_of("G2 @1 ^3 F1") == ("t.ngc:1:4: polar coordinates (@, ^) are for G00 and G01 "
                                       "moves and canned cycles (not G53 or arcs)")


def test_msg_and_debug_comments_are_events_with_values():
    program = parse("#<a> = 2\n(MSG, hello #<a>)\n(debug, a=#<a> b=#<b> n=#5)\nG0 X1")
    assert [(e.line_no, e.kind, e.word) for e in program.events] == [
        (2, "message", "(MSG, hello #<a>)"),
        (3, "debug", "(DEBUG, a=2.000000 b=###### n=0.000000)")]


@pytest.mark.parametrize(("text", "message"), [
    ("M100", "1:1: M100: user M-codes (M100-M199) are unsupported: K37 runs no external "
             "programs"),
    ("G38.2 Z-1 F1", "1:1: G38.2: probing is unsupported: K37 has no probe input"),
    ("G43.1 Z1", "1:1: G43.1: dynamic tool length offsets (tool-length sensing) are "
                 "unsupported: lengths come from the job's program.tools"),
])
def test_unsupported_features_are_named_once_with_their_place(text, message):
    assert error_of(text + "\n" + text) == f"t.ngc:{message}\nt.ngc:2{message[1:]}"


# --- work offsets: G10 L2/L20, G52, G54-G59.3 -------------------------------------------------

def ends(text: str) -> list[tuple[int, ...]]:
    """The end (LSB) of every move, on three axes."""
    return [m.end for m in parse(text, axes=3).moves]


def test_g10_l2_sets_a_systems_offsets_and_the_machine_stays_where_it_is():
    # rs274's ends for the same program (test_conformance.py compares a corpus)
    assert ends("G21 G90\nG0 X1 Y1 Z1\nG10 L2 P1 X10\nG0 Y0\nG0 X0\n"
                "G10 L2 P2 X5 Y5\nG55 G0 X0\nG91 G10 L2 P0 X1\nG90 G0 X0 Y0") == [
        (1000, 1000, 1000), (1000, 0, 1000), (10_000, 0, 1000), (5000, 0, 1000),
        (1000, 5000, 1000)]  # G10 in G91: still the value itself


def test_g10_l20_makes_the_current_point_the_given_one_in_its_system():
    # the G92 offset (-2 mm on X) counts: system 8's offset becomes (3, 2) mm
    assert ends("G21 G90\nG92 X2\nG0 X4 Y3\nG10 L20 P8 X1 Y1\nG59.2 G0 X0 Y0\n"
                "G0 X5 Y5") == [(2000, 3000, 0), (1000, 2000, 0), (6000, 7000, 0)]


@pytest.mark.parametrize("units", ["G21", "G20"])
def test_the_offset_parameters_give_g10s_values_in_the_programs_units(units):
    assert ends(f"{units} G90\nG10 L2 P1 X10 Y-2.5\nG10 L2 P9 Z3\nG53 G0 X[#5221] "
                f"Y[#5222] Z[#5383]\nG0 X[#5220]")[0] == tuple(
        round(v * (25.4 if units == "G20" else 1) * 1000) for v in (10, -2.5, 3))


def test_g52_sets_the_local_offset_keeping_the_axes_it_does_not_name():
    assert ends("G21 G90\nG52 X2 Y3\nG52 X5\nG0 X0 Y0\nG91 G52 X1\nG90 G0 X0\n"
                "G92.1\nG0 X0 Y0") == [(5000, 3000, 0), (1000, 3000, 0), (0, 0, 0)]


@pytest.mark.parametrize(("text", "message"), [
    ("G10 L1 P1 Z1", "1:5: L1: setting tools with G10 (L1, L10, L11) is unsupported"),
    ("G10 P1 X1", "1:1: G10 needs L2 or L20"),
    ("G10 L2 X1", "1:1: G10 L2 needs P0-P9, the coordinate system (P0: the one in force)"),
    ("G10 L2 P10 X1", "1:8: G10 L2 needs P0-P9"),
    ("G10 L2 P1 R45", "1:11: R45: rotated coordinate systems (G10 R) are unsupported"),
])
def test_g10_errors_name_what_is_wrong_and_where(text, message):
    assert error_of(text).startswith(f"t.ngc:{message}")


# --- no traceback on any input -----------------------------------------------------------------

_ATOMS = st.sampled_from(["1", "0", "-2.5", ".5", "#1", "#<a>", "#<_g>", "##2", "#5420",
                          "#<_x>", "#9999", "1e3", "SIN[90]", "ATAN[1]/[0]", "SQRT[-1]",
                          "EXISTS[#<a>]", "ROUND[2.5]", "#[1/0]", "FOO[1]", ""])
_OPS = st.sampled_from(["+", "-", "*", "/", "**", " MOD ", " EQ ", " LT ", " AND ", " XOR ",
                        "?", ""])


@st.composite
def expressions(draw, depth: int = 0) -> str:
    if depth > 3 or draw(st.booleans()):
        return draw(_ATOMS)
    parts = [draw(expressions(depth + 1)) for _ in range(draw(st.integers(1, 3)))]
    ops = [draw(_OPS) for _ in parts[1:]]
    body = parts[0] + "".join(o + p for o, p in zip(ops, parts[1:], strict=True))
    return draw(st.sampled_from(["[{}]", "[{}", "{}]", "ABS[{}]", "-[{}]"])).format(body)


_STATEMENTS = st.sampled_from([
    "o1 sub", "o1 endsub", "o1 call [{e}]", "o1 return [{e}]", "o2 while [{e}]", "o2 endwhile",
    "o3 do", "o3 while [{e}]", "o4 repeat [{e}]", "o4 endrepeat", "o5 if [{e}]",
    "o5 elseif [{e}]", "o5 else", "o5 endif", "o2 break", "o4 continue", "#1 = {e}",
    "#<a> = {e}", "#<_g> = {e}", "G1 F100 X{e} Y[{e}]", "G0 @{e} ^{e}", "G{e} X1",
    "(DEBUG, #1 #<a>)", "M2", "G2 X{e} I1 F10",
])


@settings(max_examples=300, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(lines=st.lists(st.tuples(_STATEMENTS, expressions()), max_size=12))
@pytest.mark.usefixtures("few_blocks")
def test_any_ngc_program_parses_or_is_a_clear_error(lines):
    text = "\n".join(s.format(e=e) for s, e in lines)
    errors: list[tuple[int, int, str]] = []
    try:
        parse(text, axes=3)
    except GcodeError as error:
        errors = error.errors
    assert all(line >= 1 and col >= 1 and message for line, col, message in errors)


@pytest.fixture(scope="module")
def few_blocks():
    """A block limit a fuzzed loop reaches quickly."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(ngc, "MAX_BLOCKS", 2000)
        yield


_PLAIN_WORDS = st.lists(st.tuples(
    st.sampled_from("gmxyzijkrfspqnthlabcdeuvw@^o"),
    st.from_regex(r"[+-]?(?:[0-9]{1,4}(?:\.[0-9]{0,3})?|\.[0-9]{1,3})", fullmatch=True),
    st.sampled_from(["", " ", "\t", "  "])), max_size=8)


@settings(max_examples=300, deadline=None, derandomize=True)
@given(words=_PLAIN_WORDS, case=st.booleans(), lead=st.sampled_from(["", " ", "\t"]))
def test_a_line_of_plain_words_reads_as_the_full_reader_reads_it(words, case, lead):
    # a comment before the words sends a line through the full reader: what it reads must
    # not change (columns three to the right)
    text = lead + "".join(f"{letter.upper() if case else letter}{number}{blank}"
                          for letter, number, blank in words)
    try:
        plain = read_line(text)
    except LexError as e:
        plain = (e.col, e.message)
    try:
        full = read_line("(c)" + text)
        full = type(full)(tuple(w._replace(col=w.col - 3) for w in full.words),
                          full.assignments, full.o)
    except LexError as e:
        full = (e.col - 3, e.message)
    assert plain == full
