"""What ``k37 run`` writes: the summary, JSON report and trace CSV (the plot is made by
:mod:`k37.sim.run.plot`, the HTML report by :mod:`k37.sim.run.report_html`, the GTKWave file by
:mod:`k37.sim.run.waveform`); and the check of every output path before a run starts."""

from __future__ import annotations

import csv
import json
import os
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from k37.sim.backends.contract import CLOCK_PERIOD
from k37.sim.files import (
    STDIO,
    OutputError,
    OutputFailure,
    atomic_open,
    atomic_path,
    why,
)
from k37.sim.files import check_outputs as check_files
from k37.sim.machine.plant_model import DAC_VOLTS
from k37.sim.run.ballbar import Ballbar, BallbarError, ballbar, ballbar_figure
from k37.sim.run.plot import write_plot
from k37.sim.run.report import validate
from k37.sim.run.report_html.run_page import run_page
from k37.sim.run.runner import RunResult
from k37.sim.run.sampler import SampleStore
from k37.sim.run.waveform import WAVE_FORMATS, wave_span, write_gtkw

__all__ = ["OutputError", "add_ballbar", "check_outputs", "print_stdout", "summary",
           "write_html", "write_outputs", "write_trace"]


def plot_formats() -> list[str]:
    """The file suffixes matplotlib can write (without the dot)."""
    from matplotlib.backend_bases import FigureCanvasBase

    return sorted(FigureCanvasBase.get_supported_filetypes())


def check_outputs(*, json_path: str | None, trace: Path | None, plot: Path | None,
                  vcd: Path | None, gtkw: Path | None, ballbar: Path | None = None,
                  html: Path | None = None, inputs: Sequence[str | Path | None] = (),
                  stdout: bool = False) -> None:
    """Refuse, before a run, outputs it could not write (:func:`k37.sim.files.check_outputs`: a
    missing or unwritable folder, a folder where the file should be, an input or another
    output at the same path, a closed stdout), a plot format matplotlib does not write, a
    waveform that is neither VCD nor FST, ``--gtkw`` without ``--vcd``, an HTML report whose
    name does not end in ``.html`` or ``.htm``."""
    if html is not None and html.suffix.lower() not in (".html", ".htm"):
        raise OutputError(f"--html {html}: name the report .html (a browser opens it by its "
                          f"suffix)")
    if vcd is not None and vcd.suffix.lower() not in WAVE_FORMATS:
        what = f"the suffix {vcd.suffix}" if vcd.suffix else "a file without a suffix"
        raise OutputError(f"--vcd {vcd}: {what} names no waveform format; use "
                          f"{' or '.join(WAVE_FORMATS)}")
    if gtkw is not None and vcd is None:
        raise OutputError(f"--gtkw {gtkw}: needs --vcd (the waveform the save file shows)")
    for option, figure in (("--plot", plot), ("--ballbar", ballbar)):
        if figure is None:
            continue
        formats = plot_formats()
        if figure.suffix.lower().lstrip(".") not in formats:
            what = f"the suffix {figure.suffix}" if figure.suffix else "a file without a suffix"
            raise OutputError(f"{option} {figure}: matplotlib cannot write {what}; it writes "
                              f"{', '.join('.' + f for f in formats)}")
    check_files({"--json": json_path, "--trace": trace, "--plot": plot, "--vcd": vcd,
                 "--gtkw": gtkw, "--ballbar": ballbar, "--html": html}, inputs=inputs,
                stdout=stdout)


def _mm(lsb: float, lsb_mm: float) -> str:
    return f"{lsb * lsb_mm:.3f} mm"


def _point(xy: list[int], lsb_mm: float) -> str:
    return f"({xy[0] * lsb_mm:.3f}, {xy[1] * lsb_mm:.3f}) mm = ({xy[0]}, {xy[1]}) LSB"


#: How a linked run's time line says whose count it is.
_HOST_COUNT = " by the host's count"


def _link_line(link: dict, clock_hz: float) -> str:
    """What a run over a link says instead of the path's figures."""
    board = link.get("board_cycles")
    if link.get("board_cycle") is None:
        return f"over {link['url']}, lost; no samples here"
    own = ("" if board is None else f"; the board's own count (its bridge's counter): "
           f"{board:,} cycles = {board / clock_hz:.3f} s")
    return (f"over {link['url']}, board at cycle {link['board_cycle']:,}{own}; no samples "
            f"here (the trace and the path's error are the board's)")


def summary(result: RunResult) -> str:
    """A few lines for the terminal, every figure with its unit."""
    r = result.report
    machine = result.job.machine
    lsb_mm, clock = machine.lsb_mm, r["clock_hz"]
    skipped = f", {r['skipped_cycles']:,} idle cycles skipped" if r["skipped_cycles"] else ""
    end, path = r["end_point"], r["path"]
    if None in end["actual"]:
        reached = "unknown: the link was lost"
    elif end["reached"]:
        reached = f"reached (within the in-position zone, {machine.in_position} LSB)"
    else:
        why = "" if end["program_ran"] else "the program did not run to its end; "
        off = max(abs(a - p) for a, p in zip(end["actual"], end["programmed"], strict=True))
        reached = (f"NOT reached: {why}actual {_point(end['actual'], lsb_mm)}, {off} LSB off "
                   f"(in-position zone {machine.in_position} LSB)")
    lines = [f"k37 run {result.job.name}: {r['status']}: {r['reason']}",
             f"  time: {r['cycles']:,} cycles = {r['machine_seconds']:.3f} s machine time"
             f"{_HOST_COUNT if 'link' in r else ''} in "
             f"{r['wall_seconds']:.2f} s wall ({r['cycles_per_second']:,.0f} cycles/s on "
             f"{r['backend']}{skipped})",
             f"  end point {_point(end['programmed'], lsb_mm)}: {reached}",
             f"  {len(r['blocks'])} block{'s' if len(r['blocks']) != 1 else ''} run; "
             + (_link_line(r["link"], clock) if "link" in r else
                f"contour error max "
                f"{path['max_contour_error']:.2f} LSB ({_mm(path['max_contour_error'], lsb_mm)}), "
                f"rms {path['rms_contour_error']:.2f} LSB "
                f"({_mm(path['rms_contour_error'], lsb_mm)}) over {path['samples']:,} samples")]
    half = 1 << (machine.dac_bits - 1)
    for axis, a in r["axes"].items():
        if a["command"] is None:
            lines.append(f"  {axis}: unknown (the link was lost)")
            continue
        most = a["max_abs_error"]
        largest = ("unknown" if most is None else
                   f"{most} LSB ({_mm(most, lsb_mm)}, "
                   f"{DAC_VOLTS * min(most, half) / half:.2f} V at the D/A)")
        lines.append(f"  {axis}: command {a['command']} LSB, actual {a['actual']} LSB "
                     f"({_mm(a['actual'], lsb_mm)}), error {a['error']} LSB, max |error| "
                     f"{largest}")
    lines += [f"  {a['kind']}{' on axis ' + a['axis'] if a['axis'] else ''} at cycle "
              f"{a['cycle']:,} ({a['cycle'] / clock:.3f} s)" for a in r["alarms"]]
    lines += [f"  warning: {w}" for w in r["warnings"]]
    return "\n".join(lines)


def write_trace(result: RunResult, path: Path) -> None:
    """The samples as CSV, one row per sample, columns :func:`k37.sim.run.sampler.trace_columns`
    of the machine's axes (read from the store a chunk at a time); written whole or not at
    all (:func:`k37.sim.files.atomic_open`)."""
    write_samples(result.store, path)


def write_samples(store: SampleStore, path: Path) -> None:
    """The samples of ``store`` as :func:`write_trace` writes a run's."""
    columns = store.columns
    with atomic_open(path, "w", newline="") as f:
        out = csv.writer(f)
        out.writerow(columns)
        volts = ["volts" in name for name in columns]
        for chunk in store.chunks():
            out.writerows([f"{v:.4f}" if is_volts else int(v)
                           for is_volts, v in zip(volts, row, strict=True)]
                          for row in chunk.tolist())


def _attempt(label: str, path: Path | str, write: Callable[[], object]) -> list[OutputFailure]:
    """Run ``write``; an error in it is the output's failure (its partial file is gone), never
    the other outputs' loss."""
    try:
        write()
    except Exception as e:  # any writer's failure: reported by name, the others still written
        return [OutputFailure(label, str(path), why(e))]
    return []


def add_ballbar(result: RunResult, path: Path, settle_deg: float | None = None
                ) -> tuple[Ballbar | None, list[OutputFailure]]:
    """Write the ballbar plot of ``result`` to ``path`` and its figures into the report (or,
    for a run that is no circle, a warning); the analysis (None: no circle) and the plot's
    failure to be written, if it was not."""
    try:
        b = ballbar(result, settle_deg)
    except BallbarError as e:
        result.report["warnings"].append(f"--ballbar {path}: {e}; no ballbar plot written")
        return None, []
    result.report["ballbar"] = b.figures()
    validate(result.report)

    def write() -> None:
        with atomic_path(path) as tmp:
            ballbar_figure(b, f"k37 run {result.job.name}",
                           result.job.machine.lsb_mm).savefig(tmp, dpi=110)

    return b, _attempt("--ballbar", path, write)


def print_stdout(text: str) -> None:
    """Print ``text`` and flush it, so a full or closed stdout is found here (OSError), and
    leave stdout on ``/dev/null`` if so, so nothing fails again at exit."""
    try:
        print(text, flush=True)
    except OSError:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        raise


def write_html(result: RunResult, path: Path, ballbar: Ballbar | None = None) -> None:
    """The run's HTML report (:func:`k37.sim.run.report_html.run_page.run_page`), written
    whole or not at all."""
    text = run_page(result, summary(result), ballbar)
    with atomic_open(path, "w", encoding="utf-8") as f:
        f.write(text)


def write_outputs(result: RunResult, *, json_path: str | None, trace: Path | None,
                  plot: Path | None, gtkw: Path | None, vcd: Path | None,
                  vcd_start: int = 0, quiet: bool = False, html: Path | None = None,
                  ballbar: Ballbar | None = None) -> list[OutputFailure]:
    """Write every output the command line asked for (checked by :func:`check_outputs`), each
    whole or not at all; return those that could not be written (each also a warning in the
    report, which is written last to carry them). No GTKWave save file for a waveform the run
    did not write (its report warns). ``ballbar``: the run's ballbar analysis, for the HTML
    report."""
    failures = list(result.failures)
    if trace:
        failures += _attempt("--trace", trace, lambda: write_trace(result, trace))
    if plot:
        def write_figure() -> None:
            with atomic_path(plot) as tmp:
                write_plot(result, tmp)

        failures += _attempt("--plot", plot, write_figure)
    if html:
        failures += _attempt("--html", html, lambda: write_html(result, html, ballbar))
    if gtkw and vcd is not None and vcd.exists():
        def write_save_file() -> None:
            window = round(vcd_start * CLOCK_PERIOD * 1e15), wave_span(vcd)[1]
            with atomic_path(gtkw) as tmp:
                write_gtkw(vcd, tmp, window=window, save_name=gtkw.name)

        failures += _attempt("--gtkw", gtkw, write_save_file)
    known = set(result.report["warnings"])
    result.report["warnings"] += [str(f) for f in failures if str(f) not in known]
    text = json.dumps(result.report, indent=2)
    if json_path == STDIO:
        failures += _attempt("--json", "stdout", lambda: print_stdout(text))
    elif json_path:
        def write_json() -> None:
            with atomic_open(json_path, "w") as f:
                f.write(text + "\n")

        failures += _attempt("--json", json_path, write_json)
    if not quiet and json_path != STDIO:
        failures += _attempt("", "stdout", lambda: print_stdout(summary(result)))
    return failures
