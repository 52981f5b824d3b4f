"""What ``k37 run`` writes: the summary, JSON report and trace CSV (the plot is made by
:mod:`sim.run.plot`, the GTKWave file by :mod:`sim.run.waveform`); and the check of every output
path before a run starts."""

from __future__ import annotations

import csv
import json
import sys
from pathlib import Path

from sim.backends.contract import CLOCK_PERIOD
from sim.machine.plant_model import DAC_VOLTS
from sim.run.ballbar import BallbarError, ballbar, ballbar_figure
from sim.run.plot import write_plot
from sim.run.report import validate
from sim.run.runner import RunResult
from sim.run.waveform import WAVE_FORMATS, wave_span, write_gtkw

__all__ = ["OutputError", "check_outputs", "summary", "write_outputs", "write_trace"]


class OutputError(ValueError):
    """An output the run could not write; one line naming the option."""


def plot_formats() -> list[str]:
    """The file suffixes matplotlib can write (without the dot)."""
    from matplotlib.backend_bases import FigureCanvasBase

    return sorted(FigureCanvasBase.get_supported_filetypes())


def check_outputs(*, json_path: str | None, trace: Path | None, plot: Path | None,
                  vcd: Path | None, gtkw: Path | None, ballbar: Path | None = None) -> None:
    """Refuse, before a run, outputs it could not write: a missing folder, a folder where the
    file should be, a plot format matplotlib does not write, a waveform that is neither VCD nor FST,
    ``--gtkw`` without ``--vcd``."""
    paths = {"--json": None if json_path in (None, "-") else Path(json_path),
             "--trace": trace, "--plot": plot, "--vcd": vcd, "--gtkw": gtkw,
             "--ballbar": ballbar}
    for option, path in paths.items():
        if path is None:
            continue
        if path.is_dir():
            raise OutputError(f"{option} {path}: is a folder, not a file")
        folder = path.parent
        if not folder.is_dir():
            raise OutputError(f"{option} {path}: the folder {folder} does not exist")
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


def _mm(lsb: float, lsb_mm: float) -> str:
    return f"{lsb * lsb_mm:.3f} mm"


def _point(xy: list[int], lsb_mm: float) -> str:
    return f"({xy[0] * lsb_mm:.3f}, {xy[1] * lsb_mm:.3f}) mm = ({xy[0]}, {xy[1]}) LSB"


def summary(result: RunResult) -> str:
    """A few lines for the terminal, every figure with its unit."""
    r = result.report
    machine = result.job.machine
    lsb_mm, clock = machine.lsb_mm, r["clock_hz"]
    skipped = f", {r['skipped_cycles']:,} idle cycles skipped" if r["skipped_cycles"] else ""
    end, path = r["end_point"], r["path"]
    off = max(abs(a - p) for a, p in zip(end["actual"], end["programmed"], strict=True))
    if end["reached"]:
        reached = f"reached (within the in-position zone, {machine.in_position} LSB)"
    else:
        why = "" if end["program_ran"] else "the program did not run to its end; "
        reached = (f"NOT reached: {why}actual {_point(end['actual'], lsb_mm)}, {off} LSB off "
                   f"(in-position zone {machine.in_position} LSB)")
    lines = [f"k37 run {result.job.name}: {r['status']}: {r['reason']}",
             f"  time: {r['cycles']:,} cycles = {r['machine_seconds']:.3f} s machine time in "
             f"{r['wall_seconds']:.2f} s wall ({r['cycles_per_second']:,.0f} cycles/s on "
             f"{r['backend']}{skipped})",
             f"  end point {_point(end['programmed'], lsb_mm)}: {reached}",
             f"  {len(r['blocks'])} block{'s' if len(r['blocks']) != 1 else ''} run; "
             f"contour error max "
             f"{path['max_contour_error']:.2f} LSB ({_mm(path['max_contour_error'], lsb_mm)}), "
             f"rms {path['rms_contour_error']:.2f} LSB "
             f"({_mm(path['rms_contour_error'], lsb_mm)}) over {path['samples']:,} samples"]
    half = 1 << (machine.dac_bits - 1)
    for axis, a in r["axes"].items():
        volts = DAC_VOLTS * min(a["max_abs_error"], half) / half
        lines.append(f"  {axis}: command {a['command']} LSB, actual {a['actual']} LSB "
                     f"({_mm(a['actual'], lsb_mm)}), error {a['error']} LSB, max |error| "
                     f"{a['max_abs_error']} LSB ({_mm(a['max_abs_error'], lsb_mm)}, "
                     f"{volts:.2f} V at the D/A)")
    lines += [f"  {a['kind']}{' on axis ' + a['axis'] if a['axis'] else ''} at cycle "
              f"{a['cycle']:,} ({a['cycle'] / clock:.3f} s)" for a in r["alarms"]]
    lines += [f"  warning: {w}" for w in r["warnings"]]
    return "\n".join(lines)


def write_trace(result: RunResult, path: Path) -> None:
    """The samples as CSV, one row per sample, columns :func:`sim.run.sampler.trace_columns`
    of the machine's axes (read from the store a chunk at a time)."""
    columns = result.store.columns
    with open(path, "w", newline="") as f:
        out = csv.writer(f)
        out.writerow(columns)
        volts = ["volts" in name for name in columns]
        for chunk in result.store.chunks():
            out.writerows([f"{v:.4f}" if is_volts else int(v)
                           for is_volts, v in zip(volts, row, strict=True)]
                          for row in chunk.tolist())


def add_ballbar(result: RunResult, path: Path, settle_deg: float = 0.0) -> None:
    """Write the ballbar plot of ``result`` to ``path`` and its figures into the report (or,
    for a run that is no circle, a warning)."""
    try:
        b = ballbar(result, settle_deg)
    except BallbarError as e:
        result.report["warnings"].append(f"--ballbar {path}: {e}; no ballbar plot written")
        return
    result.report["ballbar"] = b.figures()
    validate(result.report)
    ballbar_figure(b, f"k37 run {result.job.name}").savefig(path, dpi=110)


def write_outputs(result: RunResult, *, json_path: str | None, trace: Path | None,
                  plot: Path | None, gtkw: Path | None, vcd: Path | None,
                  vcd_start: int = 0, quiet: bool = False) -> None:
    """Write every output the command line asked for (checked by :func:`check_outputs`); no
    GTKWave save file for a waveform the run did not write (its report warns)."""
    if json_path == "-":
        json.dump(result.report, sys.stdout, indent=2)
        print()
    elif json_path:
        Path(json_path).write_text(json.dumps(result.report, indent=2) + "\n")
    if trace:
        write_trace(result, trace)
    if plot:
        write_plot(result, plot)
    if gtkw and vcd is not None and vcd.exists():
        window = round(vcd_start * CLOCK_PERIOD * 1e15), wave_span(vcd)[1]
        write_gtkw(vcd, gtkw, window=window)
    if not quiet and json_path != "-":
        print(summary(result))
