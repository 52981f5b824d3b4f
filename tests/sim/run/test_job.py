# amaranth: UnusedElaboratable=no
"""Job files: TOML and G-code jobs, the demo, defaults, and one-line errors for bad input."""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path

import pytest

from k37.firmware_model.gcode.parser import GcodeError, parse
from k37.firmware_model.job import (
    AXES,
    DEMO_GCODE,
    Job,
    MachineConfig,
    RunConfig,
    ServoConfig,
    demo_job,
)
from k37.firmware_model.motion.program import Arc, Line
from k37.hdl.encoder.map import ENCODER_MAP
from k37.hdl.k3702.map import K3702_MAP
from k37.sim.run.jobfile import JobError, job_keys_markdown, load_job
from k37.sim.run.runner import system_params
from tests.paths import ROOT

EXAMPLES = ROOT / "examples"
PROGRAM = '[program]\ngcode = "G01 X1 F100"\n'


def write(tmp_path: Path, text: str, name: str = "job.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def load_error(tmp_path: Path, text: str) -> str:
    path = write(tmp_path, text)
    with pytest.raises(JobError) as info:
        load_job(path)
    message = str(info.value)
    assert "\n" not in message
    prefix = f"{path}"
    assert message.startswith(prefix)
    return message[len(prefix):]


# --- the demo and the defaults ----------------------------------------------------------------

def test_no_job_runs_the_demo_circle():
    job = load_job(None)
    assert job.name == "demo"
    (arc,) = job.program.items
    assert isinstance(arc, Arc)
    assert (arc.xe, arc.ye, arc.i, arc.j, arc.cw) == (0, 0, -10_000, 0, False)
    assert arc.feed_mm_min == 1200.0
    assert job.program.end
    assert job.machine.accel == "pre"
    assert job.program.items == parse(DEMO_GCODE).items


def test_defaults_are_the_papers_and_the_chips():
    m = MachineConfig()
    assert (m.clock_hz, m.accel, m.accel_bits, m.sqrt2) == (1_000_000, "pre", 15, True)
    assert m.tau_s == pytest.approx(0.300)
    assert m.dac_bits == K3702_MAP["DAC_BITS"].init == 12
    assert m.encoder_filter == ENCODER_MAP["FILTER"].init
    assert (m.lsb_mm, m.in_position, m.alarm_limit) == (0.001, 10, 20_000)
    s = ServoConfig()
    assert (s.kp, s.tm, s.max_speed) == (30.0, 0.01, None)
    assert RunConfig().max_time_s is None


# --- G-code jobs ------------------------------------------------------------------------------

@pytest.mark.parametrize("suffix", [".ngc", ".nc", ".gcode", ""])
def test_a_gcode_file_runs_on_the_default_machine(tmp_path, suffix):
    job = load_job(write(tmp_path, "G01 X1 F100\nM30\n", f"part{suffix}"))
    assert job.name == "part"
    assert job.machine == MachineConfig()
    assert job.servo == dict.fromkeys(AXES, ServoConfig())
    assert job.program.source == str(tmp_path / f"part{suffix}")
    assert [(it.xe, it.ye) for it in job.program.items] == [(1_000, 0)]


def test_a_bad_gcode_file_names_its_line_and_column(tmp_path):
    path = write(tmp_path, "G17\nG01 X1 A2 F1\n", "part.ngc")
    with pytest.raises(GcodeError, match=r"^.*part\.ngc:2:8: .*A2"):
        load_job(path)


# --- TOML jobs --------------------------------------------------------------------------------

def test_inline_and_file_programs_load_the_same(tmp_path):
    write(tmp_path, "G01 X1 Y2 F100\nG02 X2 Y1 I1 J0\n", "part.ngc")
    inline = load_job(write(tmp_path, '[program]\ngcode = """\nG01 X1 Y2 F100\n'
                                      'G02 X2 Y1 I1 J0\n"""\n', "a.toml"))
    by_file = load_job(write(tmp_path, '[program]\nfile = "part.ngc"\n', "b.toml"))
    assert inline.program.items == by_file.program.items
    assert by_file.program.source == str(tmp_path / "part.ngc")
    assert inline.program.source == f"{tmp_path / 'a.toml'}:program.gcode"
    assert (inline.name, by_file.name) == ("a", "b")


def test_the_program_file_is_relative_to_the_job_file(tmp_path, monkeypatch):
    (tmp_path / "jobs").mkdir()
    write(tmp_path / "jobs", "G00 X3\n", "p.ngc")
    write(tmp_path / "jobs", '[program]\nfile = "p.ngc"\n')
    monkeypatch.chdir(tmp_path)
    job = load_job("jobs/job.toml")
    assert job.program.source == str(Path("jobs/p.ngc"))


def test_machine_servo_and_run_keys_reach_the_job(tmp_path):
    job = load_job(write(tmp_path, """
name = "custom"
[machine]
clock_hz = 2e6
lsb_mm = 0.01
accel = "post"
accel_bits = 12
accel_fa_hz = 40960
sqrt2 = false
dac_bits = 16
in_position = 0
alarm_limit = 16777215
encoder_filter = 255
rapid_mm_min = 500
[servo]
kp = 20
tm = 0.02
max_speed = 3000
[servo.y]
kp = 15.5
[run]
max_time_s = 2
[program]
gcode = "G01 X1 Y1 F100"
arc_tolerance = 0.5
"""))
    assert job.name == "custom"
    assert job.machine == MachineConfig(2_000_000, 0.01, "post", 12, 40960.0, False, 16, 0,
                                        16_777_215, 255, 500.0)
    assert isinstance(job.machine.clock_hz, int)
    assert job.machine.tau_s == pytest.approx(0.1)
    assert job.servo == {"x": ServoConfig(20.0, 0.02, 3000.0), "y": ServoConfig(15.5, 0.02, 3000.0)}
    assert job.run == RunConfig(2.0)
    (line,) = job.program.items
    assert (line.xe, line.ye, line.plan.fp) == (100, 100, 100)  # lsb 0.01 mm, sqrt2 off
    assert job.program.arc_tolerance == 0.5


def test_arc_tolerance_reaches_the_parser(tmp_path):
    arc = 'gcode = "G03 X-0.014 Y-0.012 I-0.006 J-0.006 F100"\n'
    assert isinstance(load_job(write(tmp_path, "[program]\n" + arc)).program.items[0], Arc)
    with pytest.raises(GcodeError, match="tolerance 1 LSB"):
        load_job(write(tmp_path, "[program]\narc_tolerance = 1\n" + arc))


def test_a_gcode_error_in_an_inline_program_names_the_job_files_own_line(tmp_path):
    path = write(tmp_path, '[program]\ngcode = """\nG17\nG01 X1\n"""\n')
    with pytest.raises(GcodeError) as info:
        load_job(path)
    assert str(info.value) == f"{path}:4:1: G01 without a feed rate: program F first"
    # a one-line string: the program's line 1 is the key's line
    path = write(tmp_path, '\n[program]\ngcode = "G01 X1"\n')
    with pytest.raises(GcodeError, match=r"job\.toml:3:1: G01 without a feed rate"):
        load_job(path)


@pytest.mark.parametrize(("text", "key"), [
    ("nmae = 'x'\n" + PROGRAM, "nmae"),
    ("[machine]\nacel = 'pre'\n" + PROGRAM, "machine.acel"),
    ("[servo]\nkpp = 1\n" + PROGRAM, "servo.kpp"),
    ("[servo.x]\nkp = 1\nkpp = 1\n" + PROGRAM, "servo.x.kpp"),
    ("[servo.w]\nkp = 1\n" + PROGRAM, "servo.w"),
    ("[run]\nmax_time = 1\n" + PROGRAM, "run.max_time"),
    (PROGRAM + "tolerance = 1\n", "program.tolerance"),
    ("[machnie]\n" + PROGRAM, "machnie"),
    ("[contour]\nkp = 1\n" + PROGRAM, "contour.kp"),
])
def test_an_unknown_key_is_named_with_its_full_path(tmp_path, text, key):
    assert load_error(tmp_path, text) == f": unknown key {key}"


@pytest.mark.parametrize(("table", "message"), [
    ("[machine]\nclock_hz = 1000000.5", "machine.clock_hz must be an integer, not 1000000.5"),
    ("[machine]\nclock_hz = 0", "machine.clock_hz must be in 1..1000000000 Hz, not 0"),
    ("[machine]\nlsb_mm = -1", "machine.lsb_mm must be > 0 mm, not -1"),
    ("[machine]\nlsb_mm = nan", "machine.lsb_mm must be finite, not nan"),
    ("[machine]\naccel = 'pre2'",
     "machine.accel must be one of 'pre', 'post', 'none', not 'pre2'"),
    ("[machine]\naccel_bits = 2", "machine.accel_bits must be in 4..24, not 2"),
    ("[machine]\naccel_fa_hz = 1e6",
     "machine.accel_fa_hz must be >= 0.05960464478 and < 1000000 Hz (24-bit divider at "
     "clock_hz), not 1000000.0"),
    ("[machine]\naccel_fa_hz = 0.05",
     "machine.accel_fa_hz must be >= 0.05960464478 and < 1000000 Hz (24-bit divider at "
     "clock_hz), not 0.05"),
    ("[machine]\nsqrt2 = 1", "machine.sqrt2 must be true or false, not 1"),
    ("[machine]\ndac_bits = 17", "machine.dac_bits must be in 8..16, not 17"),
    ("[machine]\ndac_bits = '12'", "machine.dac_bits must be an integer, not '12'"),
    ("[machine]\nin_position = -1", "machine.in_position must be in 0..16777215, not -1"),
    ("[machine]\nalarm_limit = 16777216",
     "machine.alarm_limit must be in 0..16777215, not 16777216"),
    ("[machine]\nencoder_filter = 0", "machine.encoder_filter must be in 1..255, not 0"),
    ("[machine]\nrapid_mm_min = 0", "machine.rapid_mm_min must be > 0 mm/min, not 0"),
    ("[servo]\nkp = -30", "servo.kp must be > 0 and < 1000000 1/s (32-bit gain at clock_hz), "
                          "not -30.0"),
    ("[servo]\nkp = 2e6", "servo.kp must be > 0 and < 1000000 1/s (32-bit gain at clock_hz), "
                          "not 2000000.0"),
    ("[servo]\nkp = true", "servo.kp must be a number, not True"),
    ("[servo.y]\ntm = -1", "servo.y.tm must be >= 0 and <= 16.777216 s (24-bit alpha at "
                           "clock_hz), not -1.0"),
    ("[servo.x]\nmax_speed = 'fast'", "servo.x.max_speed must be a number, not 'fast'"),
    ("[servo]\nmax_speed = 1e300", "servo.max_speed must be > 0 and < 3932160000 mm/min "
                                   "(48-bit speed limit at clock_hz and lsb_mm), not 1e+300"),
    ("[run]\nmax_time_s = 0", "run.max_time_s must be > 0 s, not 0"),
    ("[contour]\ncontroller = 'pid'", "contour.controller must be one of 'none', 'ccc', "
                                      "'vgccc', 'cec', not 'pid'"),
    ("[contour]\nperiod_ms = 0", "contour.period_ms must be >= 0.05 and <= 100 ms, not 0"),
    ("name = 5", "name must be a non-empty string, not 5"),
    ("machine = 5", "machine must be a table, not 5"),
    ("servo = {x = 3}", "servo.x must be a table, not 3"),
])
def test_a_bad_value_is_named_with_its_key(tmp_path, table, message):
    assert load_error(tmp_path, f"{table}\n{PROGRAM}") == f": {message}"


@pytest.mark.parametrize(("text", "message"), [
    ("[machine]\n", "missing [program] table (give gcode or file)"),
    ("[program]\n", "program must give exactly one of gcode (inline) and file"),
    ('[program]\ngcode = "G00 X1"\nfile = "a.ngc"\n',
     "program must give exactly one of gcode (inline) and file"),
    ("[program]\ngcode = 5\n", "program.gcode must be a string, not 5"),
    ("[program]\nfile = ['a']\n", "program.file must be a string, not ['a']"),
    ('[program]\ngcode = ""\narc_tolerance = -1\n',
     "program.arc_tolerance must be >= 0 LSB, not -1"),
    ("program = 'G00 X1'\n", "program must be a table, not 'G00 X1'"),
])
def test_the_program_table_needs_exactly_one_program(tmp_path, text, message):
    assert load_error(tmp_path, text) == f": {message}"


def test_a_missing_program_file_is_one_error_line(tmp_path):
    assert load_error(tmp_path, '[program]\nfile = "none.ngc"\n') == (
        f": program.file {tmp_path / 'none.ngc'}: cannot read: No such file or directory")


@pytest.mark.parametrize(("text", "message"), [
    ("[machine]\nclock_hz = \n", ":2:12: Invalid value"),
    ("[machine]\n[machine]\n", ":2:9: Cannot declare ('machine',) twice"),
    ('name = "x', ": Unterminated string (at end of document)"),
])
def test_toml_syntax_errors_name_line_and_column(tmp_path, text, message):
    assert load_error(tmp_path, text) == message


def test_unreadable_job_files_are_one_error_line(tmp_path):
    with pytest.raises(JobError, match=r"^.*nothere\.toml: cannot read: No such file or "
                                       r"directory$"):
        load_job(tmp_path / "nothere.toml")
    bad = tmp_path / "latin1.ngc"
    bad.write_bytes(b"(caf\xe9)\nG00 X1\n")
    with pytest.raises(JobError, match=r"^.*latin1\.ngc: not UTF-8 text \(byte 4\)$"):
        load_job(bad)


def test_job_errors_carry_no_chained_exception(tmp_path):
    with pytest.raises(JobError) as info:
        load_job(write(tmp_path, "[machine]\ndac_bits = 7\n" + PROGRAM))
    assert info.value.__cause__ is None
    assert info.value.__suppress_context__


# --- direct construction and the JSON form ----------------------------------------------------

@pytest.mark.parametrize(("cls", "kwargs", "error", "message"), [
    (MachineConfig, {"dac_bits": 7}, ValueError, "dac_bits must be in 8..16, not 7"),
    (MachineConfig, {"accel_bits": 1.5}, TypeError, "accel_bits must be an integer, not 1.5"),
    (MachineConfig, {"clock_hz": 100_000}, ValueError,
     r"accel_fa_hz must be >= 0\.005960464478 and < 100000 Hz \(24-bit divider at clock_hz\), "
     r"not 109226\.66666666667"),
    (ServoConfig, {"kp": "30"}, TypeError, "kp must be a number, not '30'"),
    (RunConfig, {"max_time_s": "1"}, TypeError, "max_time_s must be a number, not '1'"),
])
def test_configs_built_in_python_are_checked_too(cls, kwargs, error, message):
    with pytest.raises(error, match=f"^{message}$"):
        cls(**kwargs)


def test_to_dict_is_json_and_rebuilds_the_configuration():
    job = load_job(EXAMPLES / "square.toml")
    data = json.loads(json.dumps(job.to_dict()))
    assert data["name"] == "square"
    assert MachineConfig(**data["machine"]) == job.machine
    assert {axis: ServoConfig(**data["servo"][axis]) for axis in AXES} == job.servo
    assert RunConfig(**data["run"]) == job.run
    assert data["program"] == {"source": str(EXAMPLES / "square.ngc"), "lsb_mm": 0.001,
                               "sqrt2": True, "arc_tolerance": None, "end": True, "lines": 6,
                               "arcs": 0, "dwells": 0}


def test_the_keys_table_documents_every_key():
    doc = job_keys_markdown()
    for table, cls in (("machine", MachineConfig), ("servo", ServoConfig), ("run", RunConfig)):
        for f in dataclasses.fields(cls):
            assert f"| {table}.{f.name} | " in doc
    for key in ("name", "program.gcode", "program.file", "program.arc_tolerance",
                "program.tools"):
        assert f"| {key} | " in doc
    assert '| machine.accel | "pre" |' in doc
    assert "| machine.sqrt2 | true |" in doc


# --- the example jobs -------------------------------------------------------------------------

@pytest.mark.parametrize("path", sorted(p.name for p in EXAMPLES.iterdir()
                                         if p.suffix in (".toml", ".ngc")
                                         and not p.name.startswith("study_")))
def test_every_example_loads(path):  # the jobs (studies: test_study.py; api_*.py: test_api.py)
    job = load_job(EXAMPLES / path)
    assert isinstance(job, Job)
    assert job.program.items
    assert job.program.end
    assert job.program.final_position == (0, 0)  # each returns to where it started


def test_the_circle_example_is_the_demo():
    example, demo = load_job(EXAMPLES / "circle.toml"), demo_job()
    assert example.machine == demo.machine
    assert example.servo == demo.servo
    assert [it.block for it in example.program.items] == [it.block for it in demo.program.items]


def test_the_square_example_runs_its_file_with_a_softer_y_servo():
    job = load_job(EXAMPLES / "square.toml")
    assert job.program.items == load_job(EXAMPLES / "square.ngc").program.items
    assert job.servo["x"] == ServoConfig(30.0, 0.01)
    assert job.servo["y"] == ServoConfig(20.0, 0.02)
    lines = job.program.items
    assert all(isinstance(it, Line) for it in lines)
    assert [it.rapid for it in lines] == [True, False, False, False, False, True]


@pytest.mark.parametrize(("text", "message"), [
    ('[machine]\n[machine.x]\naccel_bits = 12\n',
     'per-axis accel/decel ([machine.x]) needs machine.accel = "post", not \'pre\''),
    ('[machine]\naccel = "post"\n[machine.y]\naccel_bits = 30\n',
     "machine.y.accel_bits must be in 4..24, not 30"),
    ('[machine]\naccel = "post"\n[machine.y]\ntau = 1\n', "unknown key machine.y.tau"),
    ('[machine]\naccel = "post"\n[machine.w]\naccel_bits = 5\n', "unknown key machine.w"),
    ('[machine]\naccel_shape = "scurve"\n',
     "machine.accel_shape must be one of 'exponential', 'linear', 'bell', not 'scurve'"),
    ('[servo]\ndrive = "hydraulic"\n',
     "servo.drive must be one of 'first_order', 'torque', 'two_mass', not 'hydraulic'"),
    ('[servo]\ndrive = "two_mass"\nks = 1e15\n', "servo.ks / mass is too large for the clock "
     "(the two-mass drive's natural frequency must stay below clock_hz / 100)"),
    ('[servo]\nscale = 1\n', "servo.scale must be true or false, not 1"),
    ('[servo.x]\nkf = 3\n', "servo.x.kf must be >= 0 and <= 2 (fraction of the command rate), "
                            "not 3.0"),
    ('[servo]\ndrive = "torque"\nja = 1e-9\n', "servo.kt * vg / ja = 1e+08 1/s must be below "
                                               "clock_hz (the torque drive's 24-bit coefficients)"),
])
def test_bad_accel_shape_per_axis_and_drive_keys_are_one_error_line(tmp_path, text, message):
    assert load_error(tmp_path, text + PROGRAM) == f": {message}"


def test_per_axis_accel_and_the_drive_reach_the_job(tmp_path):
    job = load_job(write(tmp_path, '[machine]\naccel = "post"\naccel_shape = "linear"\n'
                                   '[machine.y]\naccel_shape = "bell"\naccel_bits = 13\n'
                                   '[servo.x]\ndrive = "torque"\nkf = 0.5\n' + PROGRAM))
    assert job.accel_circuits() == {"y": ("bell", 13)}
    assert job.to_dict()["machine"]["y"] == {"accel_shape": "bell", "accel_bits": 13,
                                             "accel_fa_hz": None}
    assert job.fa_axes() == ()
    assert (job.servo["x"].drive, job.servo["x"].kf, job.servo["y"].drive) == \
        ("torque", 0.5, "first_order")


def test_an_axis_with_its_own_addition_clock_sets_its_time_constant_freely(tmp_path):
    job = load_job(write(tmp_path, '[machine]\naccel = "post"\naccel_bits = 14\n'
                                   'accel_fa_hz = 585142.8571428572\n'
                                   '[machine.x]\naccel_fa_hz = 630153.8461538461\n' + PROGRAM))
    assert job.fa_axes() == ("x",)
    assert (job.fa_hz("x"), job.fa_hz("y")) == (630153.8461538461, 585142.8571428572)
    assert job.axis_accel["x"].tau_s(job.machine) == pytest.approx(0.026)
    assert job.to_dict()["machine"]["x"]["accel_fa_hz"] == 630153.8461538461
    assert system_params(job)["axis_fa"] == ("x",)


@pytest.mark.parametrize(("text", "message"), [
    ('[machine]\naccel = "post"\n[machine.y]\naccel_fa_hz = 1e6\n',
     "machine.y.accel_fa_hz must be >= 0.05960464478 and < 1000000 Hz (24-bit divider at "
     "clock_hz), not 1000000.0"),
    ('[machine]\naccel = "post"\n[machine.x]\naccel_fa_hz = -5\n',
     "machine.x.accel_fa_hz must be > 0 Hz, not -5"),
    ('[machine.x]\naccel_fa_hz = 5e5\n',
     'per-axis accel/decel ([machine.x]) needs machine.accel = "post", not \'pre\''),
])
def test_a_bad_per_axis_addition_clock_is_one_error_line(tmp_path, text, message):
    assert load_error(tmp_path, text + PROGRAM) == f": {message}"


def test_a_tool_table_gives_lengths_and_diameters(tmp_path):
    job = load_job(write(tmp_path, '[program]\ntools = { 1 = 25.0, 2 = { length = 30.0, '
                                   'diameter = 6.0 }, 3 = { diameter = 2.0 } }\ngcode = """\n'
                                   'G21 G90 F100\nT3 M6\nG41\nG1 X10\nG40\n"""\n'))
    # G41 with tool 3's 2 mm diameter: the entry ends 1 mm left of X10
    assert job.program.moves[0].end[:2] == (10_000, 1000)


@pytest.mark.parametrize(("tools", "message"), [
    ("{ 1 = { diameter = -1.0 } }", "program.tools.1.diameter must be >= 0 mm, not -1.0"),
    ("{ 1 = { radius = 1.0 } }", "unknown key program.tools.1.radius"),
    ("{ 1 = 'long' }", "program.tools.1 must be a number"),
])
def test_a_bad_tool_is_one_error_naming_its_key(tmp_path, tools, message):
    with pytest.raises(JobError, match=re.escape(message)):
        load_job(write(tmp_path, f'[program]\ntools = {tools}\ngcode = "G01 X1 F100"\n'))
