"""Fuzz of ``k37 run``: random TOML jobs (good and bad keys, values, types; G-code with good
and bad words) under random command-line flags (good and bad) always end as documented:
exit 0, 1 or 2, one ``error:`` line for a 2, and never a traceback."""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from k37.firmware_model.job import MachineConfig, RunConfig, ServoConfig
from k37.sim.cli import main

NUMBERS = st.one_of(
    st.integers(-3, 3), st.integers(-(2**70), 2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0, 1, 4, 8, 12, 15, 16, 24, 25, 1e6, 1e-9, 0.5, 2**24, 2**48]))
VALUES = st.one_of(NUMBERS, st.booleans(), st.text(max_size=8),
                   st.sampled_from(["pre", "post", "none", "square.ngc", "folder", "",
                                    "a\x00b", "$x^$"]),
                   st.lists(st.integers(-5, 5), max_size=3))

#: Words of G-code, good and bad.
WORDS = st.one_of(
    st.sampled_from(["G00", "G01", "G02", "G03", "G04", "G17", "G18", "G20", "G21", "G90",
                     "G91", "M02", "M30", "M03", "T1", "N10", "(a comment)", "; end", "%",
                     "X", "G", "G1.5", "Q5", "X1.2.3", "F-5", "F0", "P-1", "F1e9", "I0 J0",
                     "Xé", "(unclosed", "G02 X0 Y0 I0 J0", "G04 P" + "9" * 40]),
    st.builds(lambda letter, value: f"{letter}{value}",
              st.sampled_from("XYIJFPN"),
              st.one_of(st.integers(-3, 3), st.decimals(-2, 2, places=3,
                                                         allow_nan=False).map(str),
                        st.sampled_from(["300", "1200", "0.001", "-0", "1e2", "nan", "inf"]))))
#: A move of plausible size (mm; arcs full circles) with, sometimes, a bad word in it.
MOVE = st.builds(
    lambda code, x, y, extra: f"{code} {extra}" if code.startswith(("G04", "G02", "G03"))
    else f"{code} X{x} Y{y} {extra}",
    st.sampled_from(["G00", "G01", "G01", "G02 I0.1 J0", "G03 I0 J-0.05", "G04 P0.01", ""]),
    st.decimals("-0.3", "0.3", places=3).map(str), st.decimals("-0.3", "0.3", places=3).map(str),
    st.integers(0, 3).flatmap(lambda k: WORDS if k == 3 else st.just("")))
GCODE = st.integers(0, 3).flatmap(lambda k: st.lists(
    st.lists(WORDS, max_size=5).map(" ".join), max_size=6).map("\n".join) if k == 3 else
    st.builds(lambda head, moves, end: "\n".join([head, *moves, end]),
              st.sampled_from(["G21 G90 F1200", "G21 G91 F600", "G20 G91 F20", "G21 F3000"]),
              st.lists(MOVE, min_size=1, max_size=4), st.sampled_from(["M30", "M02", ""])))

#: Keys of each table, known and unknown.
TABLE_KEYS = {"machine": [*MachineConfig.__dataclass_fields__, "speed", "Accel"],
              "servo": [*ServoConfig.__dataclass_fields__, "x", "y", "z"],
              "run": [*RunConfig.__dataclass_fields__, "max_cycles"],
              "program": ["gcode", "file", "arc_tolerance", "text"]}


def _toml(value: object) -> str:
    """``value`` written as TOML (strings through JSON: a bad escape is a TOML error too)."""
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        return ("inf" if value > 0 else "-inf") if math.isinf(value) else repr(value)
    if isinstance(value, list):
        return "[" + ", ".join(map(_toml, value)) + "]"
    if isinstance(value, str):
        return json.dumps(value)
    return str(value)


#: Values a machine could have, per key (a valid job is more likely to run deep).
PLAUSIBLE = {
    "machine": {"clock_hz": [1_000_000, 500_000, 2_000_000], "lsb_mm": [0.001, 0.01, 0.0005],
                "accel": ["pre", "post", "none"], "accel_bits": [8, 15],
                "accel_fa_hz": [109226.67, 50_000.0, 400_000.0], "sqrt2": [True, False],
                "dac_bits": [8, 12, 16], "in_position": [0, 10, 100],
                "alarm_limit": [30, 2500, 20_000], "encoder_filter": [1, 3],
                "rapid_mm_min": [600.0, 3000.0]},
    "servo": {"kp": [10.0, 30.0, 400.0], "tm": [0.0, 0.01, 0.05], "max_speed": [100.0, 5000.0]},
    "run": {"max_time_s": [0.001, 0.005, 0.02]},
}


@st.composite
def toml_jobs(draw: st.DrawFn) -> str:
    """A TOML job: the known tables with plausible values, or (chaos) keys known and unknown,
    values of any type, broken TOML."""
    chaos = draw(st.booleans())
    lines = []
    if chaos and draw(st.booleans()):
        lines.append(f"name = {_toml(draw(VALUES))}")
    for table, keys in TABLE_KEYS.items():
        if table != "program" and draw(st.integers(0, 2)) == 0:
            continue
        lines.append(f"[{table}]")
        if table == "program":
            if not chaos or draw(st.booleans()):
                lines.append(f"gcode = {_toml(draw(GCODE))}")
            else:
                key = draw(st.sampled_from(keys))
                lines.append(f"{key} = {_toml(draw(st.one_of(VALUES, GCODE)))}")
            continue
        if not chaos:
            plausible = PLAUSIBLE[table]
            for key in draw(st.lists(st.sampled_from(list(plausible)), max_size=4, unique=True)):
                lines.append(f"{key} = {_toml(draw(st.sampled_from(plausible[key])))}")
            continue
        for key in draw(st.lists(st.sampled_from(keys), max_size=3, unique=True)):
            value = draw(st.one_of(VALUES, st.just({}))) if key in "xy" else draw(VALUES)
            lines.append(f"{key} = {{}}" if value == {} else f"{key} = {_toml(value)}")
    if chaos and draw(st.booleans()):
        lines.insert(draw(st.integers(0, len(lines))), draw(st.sampled_from(
            ["[[machine]]", "= 3", "x = ", "[program", "a.b = 1", "\x00"])))
    return "\n".join(lines) + "\n"


def _mostly(good: list[str], bad: list[str]) -> st.SearchStrategy[str]:
    """One of ``good``, and one of ``bad`` about one time in eight."""
    return st.integers(0, 7).flatmap(lambda k: st.sampled_from(bad if k == 7 else good))


@st.composite
def flags(draw: st.DrawFn) -> list[str]:
    """Flags of ``k37 run``, each usually good and sometimes bad."""
    out = ["--max-cycles", draw(_mostly(["2000", "5000", "20000", "1_000"], ["0", "-5", "a"]))]
    if draw(st.booleans()):
        out += ["--sample-every", draw(_mostly(["1", "7", "1000", "50000"], ["0", "x"]))]
    out += ["--backend", draw(_mostly(["auto", "cxxrtl", "pysim"], ["verilog"]))]
    if out[-1] == "pysim":  # about 1e4 cycles/s
        out[1] = "2000"
    optional = {
        "--json": _mostly(["-", "out.json"], ["no/such/dir/r.json", "."]),
        "--trace": _mostly(["t.csv"], ["no/such/t.csv", "."]),
        "--plot": _mostly(["p.png", "p.svg", "p.pdf"], ["p.xyz", "p", "no/p.png", "."]),
        "--html": _mostly(["r.html"], ["r.txt", "no/r.html", "."]),
        "--stall": _mostly(["x", "y"], ["z"]),
        "--break-line": _mostly(["x", "y"], ["xy"]),
    }
    for option in draw(st.lists(st.sampled_from(list(optional)), max_size=3, unique=True)):
        out += [option, draw(optional[option])]
    if draw(st.booleans()):
        out.append("-q")
    return out


#: A job: TOML text, G-code text (``gcode:...``, written as a .ngc file), or a bad path.
JOBS = st.integers(0, 9).flatmap(
    lambda k: toml_jobs() if k < 6 else GCODE.map(lambda g: "gcode:" + g) if k < 9
    else st.sampled_from(["missing.toml", "folder", "bad.toml"]))


def _run(argv: list[str]) -> tuple[int, str]:
    """``main(argv)`` in-process: its exit code (argparse's SystemExit included) and stderr."""
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        try:
            code = main(argv)
        except SystemExit as e:  # argparse refusing an option
            code = e.code
    return code, err.getvalue()


def _in(folder: Path, argv: list[str]) -> tuple[int, str]:
    """:func:`_run` with ``folder`` as the working folder."""
    cwd = os.getcwd()
    os.chdir(folder)
    try:
        return _run(argv)
    finally:
        os.chdir(cwd)


@pytest.mark.slow
@settings(max_examples=40, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(job=JOBS, options=flags())
def test_every_job_and_flag_combination_exits_as_documented(job: str, options: list[str]):
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        (folder / "square.ngc").write_text("G21 G91 F1200\nG01 X0.1\nM30\n")
        (folder / "folder").mkdir()
        (folder / "bad.toml").write_bytes(b"[program]\ngcode = '\xff'\n")
        if job.startswith("gcode:"):
            (folder / "job.ngc").write_text(job[len("gcode:"):])
            path = "job.ngc"
        elif job.endswith(("missing.toml", "folder", "bad.toml")):
            path = job
        else:
            (folder / "job.toml").write_text(job)
            path = "job.toml"
        code, err = _in(folder, ["run", path, *options])
    assert code in (0, 1, 2, 3), (code, err)
    assert "Traceback" not in err
    if code == 2:
        assert err.strip().splitlines()[-1].startswith(("k37: error: ", "k37 run: error: ")), err


def test_a_nul_in_the_program_file_name_is_one_error_line(tmp_path):
    # found while fuzzing: open() raised ValueError (embedded null byte), a traceback
    (tmp_path / "job.toml").write_text('[program]\nfile = "a\\u0000b"\n')
    code, err = _in(tmp_path, ["run", "job.toml", "-q"])
    assert (code, err) == (2, "k37: error: job.toml: program.file a\x00b: cannot read: "
                              "embedded null byte\n")


def test_a_job_name_with_dollar_signs_is_plotted_as_written(tmp_path):
    # found while fuzzing: the plot's title parsed "$x^$" as TeX and failed to render
    (tmp_path / "job.toml").write_text('name = "$x^$"\n[program]\ngcode = "G21 G91 F600\\n'
                                       'G01 X0.01"\n')
    code, err = _in(tmp_path, ["run", "job.toml", "-q", "--plot", "p.png"])
    assert (code, err) == (0, "")
    assert (tmp_path / "p.png").stat().st_size > 10_000
