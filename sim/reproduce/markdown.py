"""The report of a reproduction: its rows and sections, ``report.md`` and the figures' plumbing.

Each experiment fills a :class:`Section` with :class:`Row` s (the paper's figure, the
emulator's, the tolerance, pass or fail, and the row's kind, one of :data:`KINDS`) and a
figure; :func:`report_markdown` writes them
with what each scale shrank and the run times.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from k37.firmware_model.motion.program import Arc, Line
from k37.sim.reproduce.paper import FEED_HIGH, FEED_LOW, PAPER_TAU_S
from k37.sim.reproduce.runs import MACHINE, QUICK, SERVO, RunData, Scale, run_specs
from k37.sim.reproduce.theory import fp_rate

__all__ = ["KINDS", "PREDICTION", "Reproduction", "Row", "Section", "pct", "pyplot",
           "report_markdown", "save_figure", "scoreboard", "table_markdown"]


#: What a row's pass means: the paper's number reproduced within the stated tolerance; the
#: paper's trend, direction or observation in words only (its number, if it gives one, is not
#: reached); the paper's figure quoted where it has none comparable (the emulator is
#: checked against its own model); or a prediction: a parameter the paper leaves out is
#: identified from one of its numbers and another is predicted with it. A prediction is
#: counted apart: whether it held is reported, and one that did not hold is no failure of the
#: reproduction.
KINDS = {"number": "reproduce the paper's number", "trend": "its trend or direction only",
         "quoted": "have no comparable figure in the paper (the emulator against a model)",
         "prediction": "predictions from parameters identified on another of the paper's "
                       "numbers held"}
#: The kind whose rows are reported, not scored.
PREDICTION = "prediction"


@dataclass
class Row:
    """One line of the report's table: an observation of the paper and the emulator's."""

    what: str
    paper: str
    emulator: str
    tolerance: str
    passed: bool
    kind: str

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"a row's kind is one of {', '.join(KINDS)}, not {self.kind!r}")

    @property
    def failed(self) -> bool:
        """A scored row that did not pass (a prediction that did not hold is reported, not
        failed)."""
        return not self.passed and self.kind != PREDICTION

    @property
    def verdict(self) -> str:
        """The table's last column."""
        if self.kind == PREDICTION:
            return "held" if self.passed else "did not hold"
        return "pass" if self.passed else "**FAIL**"


@dataclass
class Section:
    """One experiment: its rows, what the paper and the emulator show, its figure."""

    number: int
    title: str
    #: The keys of the runs it observes (the run-time table names each run's experiments).
    runs: tuple[str, ...]
    rows: list[Row] = field(default_factory=list)
    text: list[str] = field(default_factory=list)
    figure: str | None = None

    def row(self, what: str, paper: str, emulator: str, tolerance: str,
            passed: bool | np.bool_, *, kind: str) -> None:
        """Add a row of ``kind`` (one of :data:`KINDS`) to the table."""
        self.rows.append(Row(what, paper, emulator, tolerance, bool(passed), kind))


@dataclass
class Reproduction:
    """The outcome of :func:`k37.sim.reproduce.experiments.reproduce`."""

    scale: Scale
    sections: list[Section]
    runs: dict[str, RunData]
    seconds: float
    model_seconds: float
    #: The first-order plants' update period of the closed-loop runs (1: every cycle).
    update_cycles: int = 1

    @property
    def rows(self) -> list[Row]:
        return [row for section in self.sections for row in section.rows]

    @property
    def failed(self) -> list[Row]:
        """The rows that fail (:attr:`Row.failed`)."""
        return [row for row in self.rows if row.failed]


def pct(value: float) -> str:
    """A fraction as a percentage with one decimal."""
    return f"{100 * value:.1f}%"


def pyplot() -> Any:
    """matplotlib's pyplot on the non-interactive Agg backend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig: Any, out: Path, name: str) -> str:
    """Write ``fig`` as ``out / name``, close it and return ``name``."""
    fig.tight_layout()
    fig.savefig(out / name, dpi=80)
    pyplot().close(fig)
    return name


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def table_markdown(result: Reproduction) -> str:
    """The report's table: one row per observation, with its experiment and figure."""
    lines = ["| # | observation | paper | emulator | tolerance | kind | pass |",
             "|---|---|---|---|---|---|---|"]
    for sec in result.sections:
        for k, row in enumerate(sec.rows):
            number = f"{sec.number}{'abcdefghijklmnopqrstuvwxyz'[k]}"
            lines.append(f"| {number} | {_cell(row.what)} | {_cell(row.paper)} | "
                         f"{_cell(row.emulator)} | {_cell(row.tolerance)} | {row.kind} | "
                         f"{row.verdict} |")
    return "\n".join(lines) + "\n"


def scoreboard(rows: list[Row]) -> str:
    """The headline: how many rows pass, counted by kind, and how many predictions held."""
    scored = [row for row in rows if row.kind != PREDICTION]
    predictions = [row for row in rows if row.kind == PREDICTION]
    passed = [row for row in scored if row.passed]
    counts = [f"{sum(row.kind == kind for row in passed)} {text}"
              for kind, text in KINDS.items() if kind != PREDICTION]
    line = (f"{len(passed)} of {len(scored)} rows pass: {counts[0]} within the stated "
            f"tolerance, {counts[1]}, {counts[2]}")
    if predictions:
        line += (f"; {sum(row.passed for row in predictions)} of {len(predictions)} "
                 f"{KINDS[PREDICTION]}")
    return line


def _scaled_down(scale: Scale) -> list[str]:
    machine = MACHINE["pre"]
    specs = run_specs(scale)
    f_high, f_low = fp_rate(machine, FEED_HIGH), fp_rate(machine, FEED_LOW)
    line_fp = specs["line"].move(Line).plan.fp
    low_fp = specs["post_low"].move(Arc).plan.fp
    circle_fp = specs["post_high"].move(Arc).plan.fp
    return [
        f"Scale `{scale.name}`. Nothing in the machine is scaled: the clock (1 MHz), tau "
        f"(300 ms), the feed words and the servo (Kp = {SERVO.kp:g}/s, Tm = "
        f"{1e3 * SERVO.tm:g} ms, {machine.dac_bits}-bit D/A) are the paper's or the "
        f"defaults. The paper gives no sizes, so the moves are chosen to fit the run time:",
        "",
        f"- experiments 1 and 5: the line ({scale.line[0]}, {scale.line[1]}) LSB keeps the "
        f"feed on for {line_fp / f_high:.2f} s ({line_fp / f_high / PAPER_TAU_S:.1f} tau);",
        f"- experiments 4 and 5: full circles of R = {scale.radius} LSB at the high feed "
        f"({circle_fp} FP, {circle_fp / f_high:.2f} s of feed); the low feed ({f_low:.1f} FP/s)"
        f" runs only a {scale.low_sweep} degree arc of R = {scale.low_radius} LSB ({low_fp} FP,"
        f" {low_fp / f_low:.1f} s of feed): the full circle of R = {scale.radius} would take "
        f"{circle_fp / f_low:.0f} s of machine time;",
        f"- experiment 6: an X line of {scale.hazard_steps} LSB at {scale.hazard_fp_s:g} FP/s "
        f"(the circuit's drain, about tau ln(fi tau), sets the run time whatever the length);",
        f"- experiment 2: {scale.rate_steps} steps counted per interpolation type;",
        "- sections 8-11 (the companion papers): each section's text gives its own sizes, "
        "and what (if anything) its quick scale shrinks.",
    ]


def _held(update_cycles: int) -> str:
    """What the report says of the plants' update period, if it is not every cycle."""
    if update_cycles == 1:
        return ""
    return (f"; the first-order plants' velocity updated every {update_cycles} cycles, not "
            f"every cycle as the papers' plant (the servo key update_cycles)")


def report_markdown(result: Reproduction) -> str:
    """``report.md``: the table, then each experiment with its text and figure, then timing."""
    scale = result.scale
    lines = ["# Reproducing the paper on the emulator", "",
             f"Written by `k37 reproduce{' --quick' if scale is QUICK else ''}"
             f"{f' --update-cycles {result.update_cycles}' if result.update_cycles != 1 else ''}`: "
             f"{scoreboard(result.rows)}. Each row "
             f"compares an observation of the paper (its photos, section 2 and Table 1; "
             f"sections 1-7) or of one of the four companion papers (sections 8-11) with "
             f"what the emulator does, within the tolerance given (its kind: the paper's "
             f"number, its trend only, quoted where the paper has no comparable figure, or a "
             f"prediction from parameters identified on another of its numbers, reported "
             f"whether or not it held); "
             f"the experiments ran on the whole machine (chipset, 8085 firmware model and servo "
             f"plants) on the backend the run-time table names for each run: the event-level "
             f"engine where it runs the run, else the compiled (CXXRTL) gateware"
             f"{_held(result.update_cycles)}.", "",
             table_markdown(result)]
    for sec in result.sections:
        lines += [f"## {sec.number}. {sec.title}", ""]
        for paragraph in sec.text:
            lines += [paragraph, ""]
        if sec.figure:
            lines += [f"![{sec.title}]({sec.figure})", ""]
    lines += ["## What was scaled down", "", *_scaled_down(scale), "",
              "## Run time", "",
              f"{result.seconds:.0f} s wall in all, on {os.cpu_count()} cores with the "
              f"closed-loop runs in worker processes; the table gives each run's own wall "
              f"time (builds: one per machine design, compiled in parallel and cached under "
              f"`~/.cache/k37`; a cached build still converts the design, a few seconds). The "
              f"analysis and figures took {result.model_seconds:.0f} s.", "",
              "| run | experiments | backend | machine cycles | wall (s) |",
              "|---|---|---|---|---|"]
    for key, data in result.runs.items():
        cycles = data.report.get("cycles")
        used = ", ".join(str(s.number) for s in result.sections if key in s.runs) or "all"
        lines.append(f"| {key} | {used} | {data.report.get('backend', '-')} | "
                     f"{f'{cycles:,}' if cycles else '-'} | {data.seconds:.1f} |")
    return "\n".join(lines) + "\n"
