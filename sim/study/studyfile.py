"""Study files: what ``k37 sweep STUDY.toml`` runs. ::

    name = "kp"                       # optional; default: the file's stem
    base = "circle.toml"              # the base job, relative to this file
    design = "L16"                    # grid | L4 | L8 | L9 | L16 | L27 | random
    runs = 20                         # random only: how many
    seed = 1                          # random only
    max_cycles = 20_000_000           # per run (default 10^9)
    sample_every = 200                # cycles between samples (default 1000)
    ballbar_settle_deg = 90           # ballbar figures leave out the first 90 degrees
                                      # (default: the feed-in and feed-out, as ISO 230-4)

    [factors]                         # each with its levels, in order
    "servo.kp" = [20.0, 30.0, 40.0, 50.0]     # a job key, dotted as in the job file
    "servo.y.kp" = [20.0, 25.0, 30.0, 35.0]
    radius = [5, 10, 15, 20]                  # a program parameter: {radius} in the G-code

A factor with a dot is a job key (its value replaces the base job's, and is checked when
each run's job loads, as in ``k37 run``); one without is a program parameter, written
``{name}`` in the base job's G-code (inline, or its ``program.file``) and replaced by the
level's text. Errors are :class:`~k37.sim.run.jobfile.JobError` naming the study file.
"""

from __future__ import annotations

import copy
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from k37.firmware_model.job import Job
from k37.sim.files import read_input_text, why
from k37.sim.run.jobfile import JobError, job_from_data, read_toml
from k37.sim.study.design import DESIGNS, DesignError, design

__all__ = ["Study", "StudyRun", "load_study"]

_KEYS = ("name", "base", "design", "runs", "seed", "max_cycles", "sample_every",
         "ballbar_settle_deg", "factors")
_PARAMETER = re.compile(r"\{([A-Za-z_][A-Za-z0-9_]*)\}")


@dataclass(frozen=True)
class StudyRun:
    """One run of a study: its number (from 0) and each factor's level."""

    number: int
    levels: tuple[tuple[str, Any], ...]


@dataclass(frozen=True)
class Study:
    """A loaded study: the base job's TOML data and the runs of its design."""

    name: str
    source: str
    base_path: Path
    base: dict[str, Any]
    factors: dict[str, list[Any]]
    design: str
    runs: tuple[StudyRun, ...]
    max_cycles: int
    sample_every: int
    settle_deg: float | None
    #: Other files the study reads (the base job's program file).
    inputs: tuple[Path, ...] = ()

    def job(self, run: StudyRun) -> Job:
        """The job of ``run``: the base job with its levels applied."""
        return job_from_data(self.base_path, self.job_data(run))

    def job_data(self, run: StudyRun) -> dict[str, Any]:
        """The job file's tables of ``run``: the base job's, with its levels applied."""
        data = copy.deepcopy(self.base)
        for factor, value in run.levels:
            if "." in factor:
                *tables, key = factor.split(".")
                table = data
                for name in tables:
                    table = table.setdefault(name, {})
                    if not isinstance(table, dict):
                        raise JobError(f"{self.source}: factor {factor}: {name} is not a table "
                                       f"in the base job")
                table[key] = value
        parameters = {f: str(v) for f, v in run.levels if "." not in f}
        if parameters:
            program = data.setdefault("program", {})
            program["gcode"] = _PARAMETER.sub(lambda m: parameters.get(m[1], m[0]),
                                              program["gcode"])
        data["name"] = f"{self.name}-{run.number}"
        return data


def _fail(source: str, message: str) -> JobError:
    return JobError(f"{source}: {message}")


def load_study(path: str | Path) -> Study:
    """Read and check a study file (its base job's program parameters included)."""
    path = Path(path)
    source = str(path)
    try:
        text = read_input_text(path)
    except (OSError, UnicodeDecodeError, ValueError) as e:
        raise _fail(source, f"cannot read: {why(e)}") from None
    data = read_toml(text, source)
    unknown = set(data) - set(_KEYS)
    if unknown:
        raise _fail(source, f"unknown key {sorted(unknown)[0]}; keys are {', '.join(_KEYS)}")
    if not isinstance(data.get("base"), str):
        raise _fail(source, "base must name the base job file (a string)")
    base_path = path.parent / data["base"]
    try:
        base = read_toml(read_input_text(base_path), str(base_path))
    except (OSError, UnicodeDecodeError, ValueError) as e:
        if isinstance(e, JobError):
            raise
        raise _fail(source, f"base {base_path}: cannot read: {why(e)}") from None
    factors = data.get("factors")
    if not isinstance(factors, dict) or not factors:
        raise _fail(source, "[factors] must list at least one factor with its levels")
    for name, levels in factors.items():
        if not isinstance(levels, list) or not levels:
            raise _fail(source, f"factors.{name} must be a non-empty list of levels")
    program = base.get("program", {})
    inputs = []
    if isinstance(program, dict) and isinstance(program.get("file"), str):
        # parameters are replaced in the text: read it inline
        file = base_path.parent / program.pop("file")
        try:
            program["gcode"] = read_input_text(file)
        except (OSError, UnicodeDecodeError, ValueError) as e:
            raise _fail(source, f"base {base_path}: program.file {file}: cannot read: "
                                f"{why(e)}") from None
        inputs.append(file)
    if not isinstance(program, dict):
        raise _fail(source, f"base {base_path}: program must be a table")
    text = program.get("gcode", "")
    text = text if isinstance(text, str) else ""  # the job's own check names a bad one
    used = set(_PARAMETER.findall(text))
    parameters = {f for f in factors if "." not in f}
    if parameters - used:
        raise _fail(source, f"factor {sorted(parameters - used)[0]} is neither a dotted job "
                            f"key nor a {{name}} in the base job's G-code")
    if used - parameters:
        raise _fail(source, f"the base job's G-code uses {{{sorted(used - parameters)[0]}}}, "
                            f"which no factor gives")
    name = data.get("design", "grid")
    if name not in DESIGNS:
        raise _fail(source, f"design {name!r}: designs are {', '.join(DESIGNS)}")
    try:
        levels = design(name, [len(v) for v in factors.values()], runs=data.get("runs"),
                        seed=data.get("seed", 0))
    except DesignError as e:
        raise _fail(source, str(e)) from None
    runs = tuple(StudyRun(k, tuple((f, factors[f][i])
                                   for f, i in zip(factors, row, strict=True)))
                 for k, row in enumerate(levels))
    limits = {}
    for key, default in (("max_cycles", 10**9), ("sample_every", 1000)):
        value = data.get(key, default)
        if not isinstance(value, int) or isinstance(value, bool) or value < 1:
            raise _fail(source, f"{key} must be a positive integer, not {value!r}")
        limits[key] = value
    settle = data.get("ballbar_settle_deg", None)
    if settle is not None and (not isinstance(settle, int | float) or isinstance(settle, bool)
                               or not 0 <= settle < math.inf):
        raise _fail(source, f"ballbar_settle_deg must be a number of degrees >= 0, not "
                            f"{settle!r}")
    return Study(data.get("name", path.stem), source, base_path, base, factors, name, runs,
                 settle_deg=None if settle is None else float(settle), inputs=tuple(inputs),
                 **limits)
