"""The library API (sim/api.py) does what its examples and the README say: they run here."""

from __future__ import annotations

import re
import runpy

import numpy as np
import pytest

from k37.sim import api
from k37.sim.run.report import HOW_FIELDS
from k37.sim.run.sampler import TRACE_COLUMNS
from tests.paths import ROOT

EXAMPLES = sorted((ROOT / "examples").glob("api_*.py"))


def test_there_are_api_examples():
    assert {p.name for p in EXAMPLES} >= {"api_run.py", "api_registers.py"}


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.name)
def test_api_example_runs(path, capsys):
    runpy.run_path(str(path), run_name="__main__")
    assert capsys.readouterr().out  # each prints what it found


def test_the_readmes_library_example_runs(capsys):
    readme = (ROOT / "README.md").read_text()
    section = readme[readme.index("## K37 as a library"):]
    (code,) = re.findall(r"```python\n(.*?)```", section[:section.index("\n## ", 1)], re.S)
    exec(compile(code, "README.md", "exec"), {})
    assert capsys.readouterr().out.startswith("ok ")


def test_run_traces_are_the_samples_by_column():
    result = api.run(api.load(gcode="G21 G91 F600\nG01 X0.5\nM30"), sample_every=250)
    assert result.ok
    traces = result.traces
    assert np.array_equal(traces["cycle"], np.arange(1, result.report["path"]["samples"] + 1)
                          * 250)
    assert list(traces) == list(TRACE_COLUMNS)
    assert np.array_equal(traces["x_actual"], result.samples[:, TRACE_COLUMNS.index("x_actual")])
    assert abs(traces["x_actual"][-1] - 500) <= result.job.machine.in_position


def test_machine_run_reports_as_the_command_line_runs():
    job = api.load(gcode="G21 G91 F1200\nG02 I0.2 J0\nM30")
    with api.Machine(job) as m:
        m.step(123)  # it has stepped: run starts it again from cycle 0
        mine = m.run()
        # open afterwards, where the run ended
        assert m.get("y__count") == mine.report["axes"]["y"]["actual"]
    theirs = api.run(job)
    for how in HOW_FIELDS:
        mine.report.pop(how), theirs.report.pop(how)
    assert mine.report == theirs.report


def test_machine_registers_by_name_and_their_errors():
    with api.Machine() as m:
        assert "ALARM_ZONE" in api.Machine.chips()["K3702_Y"]
        m.write("K3702_Y", "POSITION_ZONE", 7)
        assert m.read("K3702_Y", "POSITION_ZONE") == 7
        m.write("K3702_Y", "COMMAND", -40)  # signed, 3 bytes
        assert m.read("K3702_Y", "COMMAND") == -40
        with pytest.raises(KeyError, match="no chip 'K3703'"):
            m.write("K3703", "CMD", 1)
        with pytest.raises(KeyError, match="K3702 has no register 'SPEED'"):
            m.read("K3702_X", "SPEED")
        with pytest.raises(ValueError, match="read-only"):
            m.write("K3702_X", "STATUS", 0)


def test_load_takes_a_path_or_gcode_not_both():
    assert api.load(ROOT / "examples" / "square.toml").name == "square"
    assert api.load().name == "demo"
    with pytest.raises(ValueError, match="not both"):
        api.load("x.toml", gcode="G01 X1")
