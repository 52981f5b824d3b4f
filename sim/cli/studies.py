"""``k37 sweep``, ``k37 effects`` and ``k37 reproduce``: many runs, their analysis, the
papers' rows."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from k37.sim.cli.shared import (
    EXIT_OUTPUT,
    check,
    interrupted,
    positive_int,
    print_error,
    stdout,
    stopped,
)

__all__ = ["add_commands"]


def update_cycles(text: str) -> int:
    """``--update-cycles``: a plant update period in its range."""
    from k37.sim.machine.plant_model import UPDATE_CYCLES_LIMIT

    value = positive_int(text)
    if value not in UPDATE_CYCLES_LIMIT:
        raise argparse.ArgumentTypeError(f"must be {UPDATE_CYCLES_LIMIT.describe()}, not {text}")
    return value


def _cmd_reproduce(args: argparse.Namespace) -> int:
    from k37.sim.reproduce.experiments import reproduce
    from k37.sim.reproduce.markdown import scoreboard

    def progress(message: str) -> None:
        if not args.quiet:
            print(f"k37 reproduce: {message}", file=sys.stderr, flush=True)

    out = Path(args.out)
    if not check(folders={"--out": out}):
        return 2
    try:
        result = reproduce(out, quick=args.quick, progress=progress,
                           update_cycles=args.update_cycles)
    except KeyboardInterrupt:
        print(f"k37 reproduce: {stopped()}; the workers are stopped", file=sys.stderr)
        return interrupted()
    except OSError as e:
        from k37.sim.files import why

        print(f"k37: error: {e.filename or out}: not written: {why(e)}", file=sys.stderr)
        return EXIT_OUTPUT
    failed = result.failed

    def lines() -> None:
        print(f"k37 reproduce: {scoreboard(result.rows)} ({result.seconds:.0f} s); wrote "
              f"{out / 'report.md'} and "
              f"{sum(1 for s in result.sections if s.figure)} figures")
        for row in failed:
            print(f"  FAIL: {row.what}: {row.emulator} (tolerance: {row.tolerance})")

    return stdout(lines) or (0 if not failed else 1)


def _cmd_sweep(args: argparse.Namespace) -> int:
    from k37.sim.run.jobfile import JobError
    from k37.sim.study.studyfile import load_study
    from k37.sim.study.sweep import SweepError, sweep

    def progress(message: str) -> None:
        if not args.quiet:
            print(f"k37 sweep: {message}", file=sys.stderr, flush=True)

    out = Path(args.out)
    try:
        study = load_study(args.study)
    except JobError as e:
        print_error(e)
        return 2
    outputs = [("", out / "results.csv"), ("", out / "results.parquet")] if out.is_dir() else []
    if not check(outputs, folders={"--out": out},
                  inputs=[args.study, study.base_path, *study.inputs]):
        return 2
    try:
        path = sweep(study, out, jobs=args.jobs, scheduler=args.scheduler, report=progress,
                     html=args.html, retry_errors=args.retry_errors)
    except (JobError, SweepError) as e:
        print_error(e)
        return 2
    except OSError as e:
        from k37.sim.files import why

        print(f"k37: error: {e.filename or out}: {why(e)}", file=sys.stderr)
        return EXIT_OUTPUT
    except KeyboardInterrupt:
        print(f"k37 sweep: {stopped()}; the workers are stopped and the finished runs are in "
              f"{out / 'results.csv'} (run the same command to go on)", file=sys.stderr)
        return interrupted()
    return stdout(lambda: print(f"k37 sweep: {len(study.runs)} runs of {study.name} "
                                 f"({study.design}) in {path} and "
                                 f"{path.with_suffix('.parquet')}"))


def _cmd_effects(args: argparse.Namespace) -> int:
    import csv

    from k37.sim.files import atomic_open, atomic_path, why
    from k37.sim.study.analysis import (
        AnalysisError,
        effects_figure,
        main_effects,
        response_surface,
        surface_needs,
    )

    table = Path(args.dir) / "results.csv"
    figure = Path(args.dir) / f"effects_{args.metric}.png"
    if not table.is_file():
        what = "no such folder" if not Path(args.dir).is_dir() else "no results.csv in it"
        print(f"k37: error: {args.dir}: not a study ({what}; `k37 sweep STUDY --out "
              f"{args.dir}` makes one)", file=sys.stderr)
        return 2
    page = Path(args.dir) / f"effects_{args.metric}.html"
    if not check([("", figure), ("--html", page if args.html else None)], inputs=[table]):
        return 2
    try:
        with open(table, newline="") as f:
            reader = csv.DictReader(f)
            header = list(reader.fieldnames or [])
            every = list(reader)
            rows = [r for r in every if r.get("status") == "ok"]
        if "status" not in header or header[:1] != ["run"]:
            raise ValueError("no run and status columns")
    except (OSError, ValueError, csv.Error) as e:
        print(f"k37: error: {table}: not a results table ({why(e)})", file=sys.stderr)
        return 2
    study_factors = header[1:header.index("status")]
    metrics = [c for c in header[header.index("status") + 1:] if c != "reason"]
    if args.metric not in metrics:
        print(f"k37: error: --metric {args.metric}: not a metric of {table}; its metrics are "
              f"{', '.join(metrics)}", file=sys.stderr)
        return 2
    factors = args.factors.split(",") if args.factors else study_factors
    unknown = [f for f in factors if f not in study_factors]
    if unknown:
        print(f"k37: error: --factors {unknown[0]}: not a factor of {table}; its factors are "
              f"{', '.join(study_factors)}", file=sys.stderr)
        return 2
    try:
        effects = main_effects(rows, factors, args.metric)
        needs = surface_needs(rows, factors)
        surface = response_surface(rows, factors, args.metric) if needs is None else None
    except AnalysisError as e:
        print(f"k37: error: {table}: {e}", file=sys.stderr)
        return 2

    def lines() -> None:
        print(f"main effects on {args.metric} ({len(rows)} runs with status ok):")
        for factor, points in effects.items():
            print(f"  {factor}: " + ", ".join(f"{lv:g} -> {m:.4g}" for lv, m in points))
        if surface is None:
            print(f"no response surface: {needs}")
            return
        print(f"second-order response surface (the motion-errors paper's eq (19), "
              f"coded factors), "
              f"R^2 = {surface.r_squared:.4f}:")
        for term, beta in zip(surface.terms, surface.coefficients, strict=True):
            print(f"  {term:>30s}  {beta:+.5g}")
        if surface.stationary is not None:
            print("  stationary point (eq (20)): " + ", ".join(
                f"{f} = {v:.4g}" for f, v in zip(surface.factors, surface.stationary,
                                                  strict=True)))

    if stdout(lines):
        return EXIT_OUTPUT
    try:
        with atomic_path(figure) as tmp:
            effects_figure(effects, args.metric, f"{table}: main effects").savefig(tmp,
                                                                                   dpi=110)
    except OSError as e:
        print(f"k37: error: {figure}: not written: {why(e)}", file=sys.stderr)
        return EXIT_OUTPUT
    written = [figure]
    if args.html:
        from k37.sim.study.html_report import study_page

        try:
            text = study_page(Path(args.dir), header, every, args.metric, effects, surface,
                              needs)
            with atomic_open(page, "w", encoding="utf-8") as f:
                f.write(text)
        except OSError as e:
            print(f"k37: error: {page}: not written: {why(e)}", file=sys.stderr)
            return EXIT_OUTPUT
        written.append(page)
    return stdout(lambda: print(f"k37 effects: wrote {' and '.join(map(str, written))}"))


def add_commands(sub: argparse._SubParsersAction) -> None:
    """Add ``sweep``, ``effects`` and ``reproduce`` to the command line."""
    p = sub.add_parser("sweep", help="run a study (a base job, factors, a design) into one "
                                     "results table")
    p.add_argument("study", help="study file (.toml)")
    p.add_argument("--out", required=True, metavar="DIR",
                   help="folder for results.csv and results.parquet (runs already there are "
                        "skipped, but for those that failed outside their job)")
    p.add_argument("--retry-errors", action="store_true",
                   help="run again every run whose row in DIR has status error")
    p.add_argument("-j", "--jobs", type=positive_int, default=os.cpu_count() or 1,
                   help="local worker processes (default: one per core)")
    p.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                   help="run on this Dask distributed scheduler instead of local processes")
    p.add_argument("--html", action="store_true",
                   help="also write each run's interactive report, DIR/runs/RUN.html (`k37 "
                        "effects DIR --html` links them)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
    p.set_defaults(func=_cmd_sweep)
    p = sub.add_parser("effects", help="main effects and a second-order response surface of "
                                       "a metric over a sweep's factors")
    p.add_argument("dir", help="a sweep's folder (its results.csv)")
    p.add_argument("--metric", required=True, help="a column of results.csv")
    p.add_argument("--factors", help="comma-separated factors (default: all of the study's)")
    p.add_argument("--html", action="store_true",
                   help="also write DIR/effects_METRIC.html: the runs (linked to DIR/runs/"
                        "RUN.html where it exists), the main effects and the response surface, "
                        "interactive, in one self-contained page")
    p.set_defaults(func=_cmd_effects)
    p = sub.add_parser("reproduce", help="run the paper's experiments; write figures and "
                                         "report.md (paper vs emulator, pass/fail per row)")
    p.add_argument("--out", required=True, metavar="DIR",
                   help="folder for report.md and the PNG figures (the manual's are in "
                        "docs/reproduce)")
    p.add_argument("--quick", action="store_true",
                   help="smaller runs (the scale CI checks); the report says what shrank")
    p.add_argument("--update-cycles", type=update_cycles, default=1, metavar="N",
                   help="the first-order plants' update period in every closed-loop run (the "
                        "servo key update_cycles; default 1, the papers' plant): which rows "
                        "hold at a faster plant")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
    p.set_defaults(func=_cmd_reproduce)
