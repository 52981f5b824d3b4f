# amaranth: UnusedElaboratable=no
"""Job files: TOML and G-code jobs, the demo, defaults, and one-line errors for bad input."""

from __future__ import annotations

import dataclasses
import json
import math
import sys
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
from k37.hdl.chipset.chip import Chipset
from k37.hdl.common.params import Limit
from k37.hdl.encoder.map import ENCODER_MAP
from k37.hdl.feed.map.feed_rate import DIVIDER_WIDTH
from k37.hdl.feed.rates import increment_for
from k37.hdl.k3702.map import K3702_MAP
from k37.sim.cli import main
from k37.sim.machine.plant_model import ALPHA_BITS, GAIN_BITS, VMAX_BITS, PlantParams
from k37.sim.machine.servo import plant_params, servo_limits
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


# --- every machine and servo key's range, through `k37 run` ---------------------------------

#: The range of every numeric machine and servo key on the default machine, as the blocks
#: define them (servo: the plant's fixed point, in the job's units).
DEFAULT = MachineConfig()
LIMITS: dict[str, Limit] = {
    **{f"machine.{f.name}": DEFAULT.valid(f.name) for f in dataclasses.fields(MachineConfig)
       if isinstance(DEFAULT.valid(f.name), Limit)},
    **{f"servo.{name}": limit for name, limit in servo_limits(DEFAULT).items()}}
#: A program any machine runs: it moves nothing.
DWELL = '[program]\ngcode = "G04 P0.01"\n'


def test_the_ranges_are_the_blocks():
    assert {key: limit.describe() for key, limit in LIMITS.items()} == {
        "machine.clock_hz": "in 1..1000000000 Hz",
        "machine.lsb_mm": "> 0 mm",
        "machine.accel_bits": "in 4..24",
        "machine.accel_fa_hz": ">= 0.05960464478 and < 1000000 Hz (24-bit divider at clock_hz)",
        "machine.dac_bits": "in 8..16",
        "machine.in_position": "in 0..16777215",
        "machine.alarm_limit": "in 0..16777215",
        "machine.encoder_filter": "in 1..255",
        "machine.rapid_mm_min": "> 0 mm/min",
        "machine.axes": "in 2..3",
        "servo.kp": "> 0 and < 1000000 1/s (32-bit gain at clock_hz)",
        "servo.tm": ">= 0 and <= 16.777216 s (24-bit alpha at clock_hz)",
        "servo.max_speed": "> 0 and < 3932160000 mm/min (48-bit speed limit at clock_hz and "
                           "lsb_mm)",
        "servo.kf": ">= 0 and <= 2 (fraction of the command rate)",
        "servo.kt": "> 0 N m/A", "servo.ja": "> 0 kg m^2", "servo.vg": "> 0 A s/rad",
        "servo.ti": ">= 0 s", "servo.d": ">= 0 N m s/rad", "servo.fc": ">= 0 N m",
        "servo.load": "a number N m", "servo.counts_per_rev": "> 0 counts",
        "servo.mass": "> 0 kg", "servo.ks": "> 0 N/m", "servo.cs": ">= 0 N s/m",
        "servo.lead": "> 0 m",
    }


def _step(bound: float, limit: Limit, toward: float) -> float:
    """The next value after ``bound`` toward ``toward`` that the key's type holds (near 0: the
    smallest normal float, as a subnormal speed underflows in the plant's units)."""
    if limit.integer:
        return bound + (1 if toward > bound else -1)
    if bound == 0 and toward > 0:
        return sys.float_info.min
    return math.nextafter(bound, toward)


def _bounds(limit: Limit) -> list[tuple[float, bool, float]]:
    """Each bound (as the key's type), whether it is open, and the direction of the inside."""
    kind = int if limit.integer else float
    return [(kind(bound), is_open, toward)
            for bound, is_open, toward in ((limit.low, limit.low_open, math.inf),
                                           (limit.high, limit.high_open, -math.inf))
            if bound is not None]


def outside(limit: Limit) -> list[float]:
    """The values just outside each bound."""
    return [bound if is_open else _step(bound, limit, -toward)
            for bound, is_open, toward in _bounds(limit)]


def inside(limit: Limit) -> list[float]:
    """The boundary values a key takes: each bound, or just inside it if open."""
    return [_step(bound, limit, toward) if is_open else bound
            for bound, is_open, toward in _bounds(limit)]


def job_text(key: str, value: float) -> str:
    """A job with ``key = value`` (under ``[servo]``, ``[servo.x]`` or ``[servo.y]`` as the
    key says); a clock comes with an fa and a kp it allows."""
    table, name = key.rsplit(".", 1)
    text = f"[{table}]\n{name} = {value!r}\n"
    if key == "machine.clock_hz":
        text += f"accel_fa_hz = {value / 2!r}\n[servo]\nkp = {value / 2!r}\n"
    return text + DWELL


def run_error(tmp_path: Path, capsys, text: str) -> str:
    """``k37 run`` of a job file of ``text``: exit 2 and the one line it printed."""
    path = write(tmp_path, text)
    assert main(["run", str(path), "-q"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    prefix = f"k37: error: {path}: "
    assert err.startswith(prefix)
    return err[len(prefix):].rstrip("\n")


OUT_OF_RANGE = [(key, value) for key, limit in LIMITS.items() for value in outside(limit)]
OVERRIDES = [(key.replace("servo.", f"servo.{axis}."), value) for axis in AXES
             for key, value in OUT_OF_RANGE if key.startswith("servo.")]


@pytest.mark.parametrize(("key", "value"), OUT_OF_RANGE + OVERRIDES)
def test_a_value_out_of_range_exits_2_naming_key_value_and_range(tmp_path, capsys, key, value):
    limit = LIMITS[key.replace(".x.", ".").replace(".y.", ".")]
    assert run_error(tmp_path, capsys, job_text(key, value)) == (
        f"{key} must be {limit.describe()}, not {value!r}")


@pytest.mark.parametrize(("key", "value"),
                         [(key, value) for key, limit in LIMITS.items() for value in inside(limit)])
def test_the_boundary_values_are_accepted_and_fit_the_blocks(tmp_path, key, value):
    job = load_job(write(tmp_path, job_text(key, value)))
    table, name = key.split(".")
    configs = [job.machine] if table == "machine" else [job.servo[axis] for axis in AXES]
    assert [getattr(config, name) for config in configs] == [value] * len(configs)
    for axis in AXES:
        plant = plant_params(job.machine, job.servo[axis])
        assert (0 <= plant.gain < 1 << GAIN_BITS and 0 < plant.alpha < 1 << ALPHA_BITS
                and 0 <= plant.vmax < 1 << VMAX_BITS)
    assert 0 < increment_for(job.machine.accel_fa_hz, width=DIVIDER_WIDTH,
                             f_clk=job.machine.clock_hz) < 1 << DIVIDER_WIDTH


@pytest.mark.parametrize(("key", "value", "block"), [
    ("machine.accel_bits", 2, lambda: Chipset(accel_bits=2)),
    ("machine.accel_fa_hz", 0.05, lambda: increment_for(0.05, width=DIVIDER_WIDTH, f_clk=1e6)),
    ("machine.lsb_mm", -1.0, lambda: parse("", lsb_mm=-1.0)),
    ("servo.kp", 2e6, lambda: PlantParams(kp=2e6, tm=0.01)),
    ("servo.tm", 40.0, lambda: PlantParams(kp=30.0, tm=40.0)),
])
def test_the_block_and_the_loader_refuse_a_value_in_the_same_words(tmp_path, capsys, key, value,
                                                                    block):
    with pytest.raises(ValueError, match=" must ") as info:
        block()
    refusal = str(info.value).split(" must ", 1)[1]
    assert run_error(tmp_path, capsys, job_text(key, value)) == f"{key} must {refusal}"


def test_the_servo_ranges_follow_the_clock_and_the_lsb(tmp_path, capsys):
    fast = "[machine]\nclock_hz = 2_000_000\nlsb_mm = 0.01\n[servo]\n"
    job = load_job(write(tmp_path, fast + "kp = 1.5e6\nmax_speed = 7e10\n" + DWELL))
    assert job.servo["x"].kp == 1.5e6
    assert run_error(tmp_path, capsys, fast + "max_speed = 8e10\n" + DWELL) == (
        "servo.max_speed must be > 0 and < 78643200000 mm/min (48-bit speed limit at clock_hz "
        "and lsb_mm), not 80000000000.0")


def test_an_extreme_valid_job_runs_without_a_traceback(tmp_path):
    path = write(tmp_path, "[machine]\naccel_bits = 4\naccel_fa_hz = 0.0596046448\n"
                           "[servo]\nkp = 999999.0\ntm = 16.777216\nmax_speed = 3.9e9\n"
                           '[program]\ngcode = "G01 X0.01 F100"\n')
    assert main(["run", str(path), "--backend", "pysim", "--max-cycles", "3000", "-q"]) in (0, 1)


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
