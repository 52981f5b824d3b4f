"""Job files: TOML and G-code jobs, the demo, defaults, and one-line errors for bad input."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest

from firmware_model.gcode import Arc, GcodeError, Line, parse
from firmware_model.job import (
    AXES,
    DEMO_GCODE,
    Job,
    JobError,
    MachineConfig,
    RunConfig,
    ServoConfig,
    demo_job,
    job_keys_markdown,
    load_job,
)
from hdl.encoder import ENCODER_MAP
from hdl.k3702 import K3702_MAP

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
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
    path = write(tmp_path, "G17\nG01 X1 Z2 F1\n", "part.ngc")
    with pytest.raises(GcodeError, match=r"^.*part\.ngc:2:8: unsupported word Z2 "):
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


def test_a_gcode_error_in_an_inline_program_names_the_job_key(tmp_path):
    path = write(tmp_path, '[program]\ngcode = """\nG17\nG01 X1\n"""\n')
    with pytest.raises(GcodeError) as info:
        load_job(path)
    assert str(info.value) == (f"{path}:program.gcode:2:1: G01 without a feed rate: "
                               f"program F first")


@pytest.mark.parametrize(("text", "key"), [
    ("nmae = 'x'\n" + PROGRAM, "nmae"),
    ("[machine]\nacel = 'pre'\n" + PROGRAM, "machine.acel"),
    ("[servo]\nkpp = 1\n" + PROGRAM, "servo.kpp"),
    ("[servo.x]\nkp = 1\nkpp = 1\n" + PROGRAM, "servo.x.kpp"),
    ("[servo.z]\nkp = 1\n" + PROGRAM, "servo.z"),
    ("[run]\nmax_time = 1\n" + PROGRAM, "run.max_time"),
    (PROGRAM + "tolerance = 1\n", "program.tolerance"),
    ("[machnie]\n" + PROGRAM, "machnie"),
])
def test_an_unknown_key_is_named_with_its_full_path(tmp_path, text, key):
    assert load_error(tmp_path, text) == f": unknown key {key}"


@pytest.mark.parametrize(("table", "message"), [
    ("[machine]\nclock_hz = 1000000.5", "machine.clock_hz must be an integer, not 1000000.5"),
    ("[machine]\nclock_hz = 0", "machine.clock_hz must be in 1..1000000000, not 0"),
    ("[machine]\nlsb_mm = -1", "machine.lsb_mm must be positive, not -1.0"),
    ("[machine]\nlsb_mm = nan", "machine.lsb_mm must be finite, not nan"),
    ("[machine]\naccel = 'pre2'",
     "machine.accel must be one of 'pre', 'post', 'none', not 'pre2'"),
    ("[machine]\naccel_bits = 0", "machine.accel_bits must be in 1..24, not 0"),
    ("[machine]\naccel_fa_hz = 1e6",
     "machine.accel_fa_hz must be below clock_hz = 1000000, not 1000000.0"),
    ("[machine]\nsqrt2 = 1", "machine.sqrt2 must be true or false, not 1"),
    ("[machine]\ndac_bits = 17", "machine.dac_bits must be in 8..16, not 17"),
    ("[machine]\ndac_bits = '12'", "machine.dac_bits must be an integer, not '12'"),
    ("[machine]\nin_position = -1", "machine.in_position must be in 0..16777215, not -1"),
    ("[machine]\nalarm_limit = 16777216",
     "machine.alarm_limit must be in 0..16777215, not 16777216"),
    ("[machine]\nencoder_filter = 0", "machine.encoder_filter must be in 1..255, not 0"),
    ("[machine]\nrapid_mm_min = 0", "machine.rapid_mm_min must be positive, not 0.0"),
    ("[servo]\nkp = -30", "servo.kp must be positive, not -30.0"),
    ("[servo]\nkp = true", "servo.kp must be a number, not True"),
    ("[servo.y]\ntm = 0", "servo.y.tm must be positive, not 0.0"),
    ("[servo.x]\nmax_speed = 'fast'", "servo.x.max_speed must be a number, not 'fast'"),
    ("[run]\nmax_time_s = 0", "run.max_time_s must be positive, not 0.0"),
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
     "program.arc_tolerance must not be negative, not -1.0"),
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
    (ServoConfig, {"kp": 0}, ValueError, "kp must be positive, not 0.0"),
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
                               "sqrt2": True, "arc_tolerance": 2.0, "end": True, "lines": 6,
                               "arcs": 0, "dwells": 0}


def test_the_keys_table_documents_every_key():
    doc = job_keys_markdown()
    for table, cls in (("machine", MachineConfig), ("servo", ServoConfig), ("run", RunConfig)):
        for f in dataclasses.fields(cls):
            assert f"| {table}.{f.name} | " in doc
    for key in ("name", "program.gcode", "program.file", "program.arc_tolerance"):
        assert f"| {key} | " in doc
    assert '| machine.accel | "pre" |' in doc
    assert "| machine.sqrt2 | true |" in doc


# --- the example jobs -------------------------------------------------------------------------

@pytest.mark.parametrize("path", sorted(p.name for p in EXAMPLES.iterdir()))
def test_every_example_loads(path):
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
