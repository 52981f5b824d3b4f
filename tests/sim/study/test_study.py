"""Studies: the designs are orthogonal arrays, a study file names its problems, a sweep
writes one row per run and resumes, and the ballbar figures follow the physics of a gain
mismatch (the ellipse of the motion-errors paper's Fig. 8)."""

from __future__ import annotations

import csv
import itertools
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from k37.sim.run.ballbar import FIGURES, BallbarError, ballbar
from k37.sim.run.jobfile import JobError, load_job
from k37.sim.run.runner import RunOptions, run_job
from k37.sim.study.analysis import AnalysisError, main_effects, response_surface
from k37.sim.study.design import DesignError, design, orthogonal_array
from k37.sim.study.studyfile import load_study
from k37.sim.study.sweep import SweepError, sweep
from tests.paths import ROOT


@pytest.mark.parametrize(("name", "q", "factors"), [
    ("L4", 2, 3), ("L8", 2, 7), ("L9", 3, 4), ("L16", 4, 5), ("L16", 2, 15), ("L27", 3, 13)])
def test_orthogonal_arrays_balance_every_pair_of_columns(name, q, factors):
    runs = design(name, [q] * factors)
    assert len(runs) == int(name[1:]) and len(set(runs)) == len(runs)
    for i, j in itertools.combinations(range(factors), 2):
        pairs = [(r[i], r[j]) for r in runs]
        assert all(pairs.count(p) == len(runs) // q**2
                   for p in itertools.product(range(q), repeat=2)), (i, j)


def test_gf4_array_is_linear_over_gf4():
    # two runs' sum (XOR in GF(4)) is a run: the array is a linear code
    rows = set(orthogonal_array(4, 2))
    assert all(tuple(a ^ b for a, b in zip(r, s, strict=True)) in rows for r in rows for s in rows)


def test_grid_and_random_designs():
    assert design("grid", [2, 3]) == list(itertools.product(range(2), range(3)))
    runs = design("random", [4, 4], runs=50, seed=3)
    assert len(runs) == 50 and runs == design("random", [4, 4], runs=50, seed=3)
    assert {r[0] for r in runs} == {0, 1, 2, 3}


@pytest.mark.parametrize(("name", "levels", "message"), [
    ("L9", [2, 2], "design L9 needs every factor to have 3 levels"),
    ("L4", [2, 2, 2, 2], "design L4 (2 levels) has 3 columns: too few for 4 factors"),
    ("random", [2], "needs runs = N"),
    ("L5", [2], "unknown design 'L5'"),
])
def test_a_design_that_cannot_hold_the_factors_says_why(name, levels, message):
    with pytest.raises(DesignError, match=message.replace("(", r"\(").replace(")", r"\)")):
        design(name, levels)


BASE = '''
[machine]
accel = "none"
[servo]
tm = 0.01
[program]
gcode = """
G21 G90 F{feed}
G03 X0 Y0 I-{radius} J0
G03 X0 Y0 I-{radius} J0
M30
"""
'''


def write_study(folder: Path, body: str, base: str = BASE) -> Path:
    (folder / "base.toml").write_text(base)
    path = folder / "study.toml"
    path.write_text('base = "base.toml"\n' + body)
    return path


@pytest.mark.parametrize(("body", "message"), [
    ('design = "grid"\nbogus = 1\n[factors]\nfeed = [600]\nradius = [5]',
     "unknown key bogus"),
    ('[factors]\nfeed = [600]', "the base job's G-code uses {radius}, which no factor gives"),
    ('[factors]\nfeed = [600]\nradius = [5]\nangle = [1]',
     "factor angle is neither a dotted job key nor a {name}"),
    ('design = "L9"\n[factors]\nfeed = [600, 900]\nradius = [5, 6]',
     "design L9 needs every factor to have 3 levels"),
    ('max_cycles = 0\n[factors]\nfeed = [600]\nradius = [5]',
     "max_cycles must be a positive integer"),
    ('[factors]\nfeed = []\nradius = [5]', "factors.feed must be a non-empty list"),
])
def test_a_bad_study_file_is_one_error_naming_it(tmp_path, body, message):
    with pytest.raises(JobError, match=r"study\.toml: .*" + message.replace("{", r"\{")
                       .replace("}", r"\}").replace("(", r"\(").replace(")", r"\)")):
        load_study(write_study(tmp_path, body))


def test_the_example_study_loads_and_each_run_is_a_job():
    study = load_study(ROOT / "examples" / "study_kp.toml")
    assert study.design == "L4" and len(study.runs) == 4
    jobs = [study.job(run) for run in study.runs]
    assert {job.servo["x"].kp for job in jobs} == {20.0, 40.0}
    assert {job.program.items[0].radius for job in jobs} == {5000.0, 10000.0}


def test_a_bad_level_is_a_row_with_status_error_naming_the_key(tmp_path):
    study = load_study(write_study(tmp_path, '[factors]\nfeed = [600]\nradius = [5]\n'
                                             '"servo.kp" = [-3.0]'))
    from k37.sim.study.sweep import run_one

    row = run_one(study, study.runs[0])
    assert row["status"] == "error" and "servo.kp" in row["reason"]


def test_a_cluster_sweep_without_dask_names_the_extra_and_runs_nothing(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)  # as on the default install
    study = load_study(write_study(tmp_path, '[factors]\nfeed = [600]\nradius = [5]\n'))
    with pytest.raises(SweepError, match=r"--scheduler needs Dask's distributed package.*"
                                         r"k37\[cluster\]"):
        sweep(study, tmp_path / "out", scheduler="tcp://127.0.0.1:1")
    table = tmp_path / "out" / "results.csv"
    assert not table.exists() or len(table.read_text().splitlines()) <= 1


def test_gain_mismatch_makes_the_2_theta_ellipse_of_the_theory(job_file):
    # Kp 20 / 40 1/s, no accel/decel, about F600 on R 10 mm: w = 1 rad/s << Kp, so each axis
    # lags by V/Kp and the difference is an ellipse of amplitude (V/2)|1/Kpx - 1/Kpy| with its
    # long axis on a diagonal; V is the command's path speed, measured over the second circle
    # (the K3701's sqrt(2) control averages about 9% under the programmed feed on a circle)
    job = load_job(job_file("G21 G90 F600\nG03 X0 Y0 I-10 J0\nG03 X0 Y0 I-10 J0\nM30",
                            machine='accel = "none"',
                            servo="[servo.x]\nkp = 20.0\n[servo.y]\nkp = 40.0"))
    result = run_job(job, RunOptions(sample_every=200))
    b = ballbar(result, settle_deg=360)
    second = result.report["blocks"][1]
    v = 2 * math.pi * 10_000 / ((second["end_cycle"] - second["start_cycle"]) / 1e6)
    assert 0.85 * 10_000 < v < 10_000 and b.path_speed == pytest.approx(v, rel=0.01)
    expected = v / 2 * abs(1 / 20 - 1 / 40)
    assert b.two_theta_amplitude == pytest.approx(expected, rel=0.05)
    assert min(abs(b.two_theta_angle - 45), abs(b.two_theta_angle - 135)) < 3
    assert 355 < b.sweep < 361 and b.samples > 1000
    # the circle itself: a mean radius loss but a small centre offset
    assert b.centre_offset < 0.1 * expected


def test_ballbar_refuses_a_program_without_a_circle(make_job):
    result = run_job(make_job("G21 G90 F600\nG01 X1\nM30"), RunOptions())
    with pytest.raises(BallbarError, match="no arc"):
        ballbar(result)


@pytest.mark.slow
def test_a_sweep_writes_one_row_per_run_and_resumes_where_it_stopped(tmp_path):
    study = load_study(write_study(
        tmp_path, 'design = "L4"\nmax_cycles = 30_000_000\nsample_every = 500\n'
                  'ballbar_settle_deg = 360\n[factors]\n"servo.kp" = [20.0, 40.0]\n'
                  'radius = [5, 10]\nfeed = [600, 1200]'))
    out = tmp_path / "out"
    path = sweep(study, out, jobs=2)
    with open(path) as f:
        rows = list(csv.DictReader(f))
    assert [int(r["run"]) for r in rows] == [0, 1, 2, 3]
    assert all(r["status"] == "ok" and r["end_reached"] == "True" for r in rows)
    assert {r["backend"] for r in rows} == {"engine"}  # auto's pick, as k37 run's
    # each run's radius loss is the servo's frequency response at w = V/R: R (|G(jw)| - 1),
    # G(s) = Kp / (Tm s^2 + s + Kp) for the position loop around the velocity lag Tm
    for r in rows:
        v, radius, kp = float(r["path_speed"]), float(r["radius"]) / 0.001, float(r["servo.kp"])
        assert 0.85 < v / (float(r["feed"]) / 60 / 0.001) < 1
        w = v / radius
        loss = radius * (kp / math.hypot(kp - w * w * 0.01, w) - 1)
        assert float(r["mean_radius_deviation"]) == pytest.approx(loss, rel=0.05, abs=1.5)
    assert (out / "results.parquet").exists()
    # a second call runs nothing; a different study in the same folder is refused
    lines = path.read_text()
    assert sweep(study, out, jobs=2) == path and path.read_text() == lines
    other = load_study(write_study(tmp_path, '[factors]\nfeed = [600]\nradius = [5]'))
    with pytest.raises(SweepError, match="columns are not this study's"):
        sweep(other, out)
    assert math.isfinite(float(rows[0]["circularity"]))


@pytest.fixture
def dask_cluster():
    """A Dask scheduler and one worker (two processes) on 127.0.0.1, as on a cluster."""
    import shutil
    import socket
    import subprocess
    import time

    dask = shutil.which("dask")
    if dask is None:
        pytest.skip("the dask command (distributed) is not installed")
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    procs = [subprocess.Popen([dask, "scheduler", "--host", "127.0.0.1", "--port", str(port),
                               "--no-dashboard"], stderr=subprocess.DEVNULL)]
    procs.append(subprocess.Popen([dask, "worker", address, "--nworkers", "2",
                                   "--nthreads", "1", "--no-dashboard"],
                                  stderr=subprocess.DEVNULL))
    try:
        from distributed import Client

        with Client(address, timeout="30s") as client:
            client.wait_for_workers(2, timeout=60)
        yield address
    finally:
        for proc in reversed(procs):
            proc.terminate()
            proc.wait(timeout=30)
        time.sleep(0.1)


@pytest.mark.slow
def test_an_l16_study_on_a_dask_cluster_gives_the_local_table(tmp_path, dask_cluster):
    study = load_study(ROOT / "examples" / "study_l16.toml")
    tables = []
    for out, scheduler in ((tmp_path / "local", None), (tmp_path / "dask", dask_cluster)):
        with open(sweep(study, out, jobs=2, scheduler=scheduler)) as f:
            rows = list(csv.DictReader(f))
        tables.append([{k: v for k, v in r.items() if k != "wall_seconds"} for r in rows])
    assert len(tables[0]) == 16 and tables[0] == tables[1]
    assert all(r["status"] == "ok" and r["end_reached"] == "True" for r in tables[0])


def test_the_response_surface_recovers_a_quadratic_and_its_stationary_point():
    # y = 3 + (a - 2)^2 + 2 (b - 5)^2 + 0.5 (a - 2)(b - 5), on a 4 x 4 grid
    rows = [{"a": str(a), "b": str(b),
             "y": str(3 + (a - 2) ** 2 + 2 * (b - 5) ** 2 + 0.5 * (a - 2) * (b - 5))}
            for a, b in itertools.product((0, 1, 3, 4), (3, 4, 6, 8))]
    surface = response_surface(rows, ["a", "b"], "y")
    assert surface.r_squared == pytest.approx(1.0)
    assert surface.stationary == pytest.approx((2.0, 5.0))
    assert surface.predict((2.0, 5.0)) == pytest.approx(3.0)
    effects = main_effects(rows, ["a"], "y")["a"]
    assert [level for level, _ in effects] == [0, 1, 3, 4]
    assert effects[0][1] == pytest.approx(np.mean([float(r["y"]) for r in rows if r["a"] == "0"]))


def test_the_response_surface_says_when_the_runs_are_too_few():
    rows = [{"a": str(a), "b": str(b), "c": str(c), "y": "1"}
            for a, b, c in design("L4", [2, 2, 2])]
    with pytest.raises(AnalysisError, match="10 terms: 4 runs are too few"):
        response_surface(rows, ["a", "b", "c"], "y")


def test_k37_effects_prints_the_main_effects_and_the_surface(tmp_path, capsys):
    from k37.sim.cli import main

    with open(tmp_path / "results.csv", "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["run", "kp", "feed", "status", "circularity"])
        for n, (kp, feed) in enumerate(itertools.product((10, 20, 30), (500, 1000, 1500))):
            writer.writerow([n, kp, feed, "ok", feed / kp])
    assert main(["effects", str(tmp_path), "--metric", "circularity"]) == 0
    out = capsys.readouterr().out
    assert "kp: 10 -> 100, 20 -> 50, 30 -> 33.33" in out and "R^2 = " in out
    assert (tmp_path / "effects_circularity.png").exists()
    assert main(["effects", str(tmp_path / "nowhere"), "--metric", "x"]) == 2


def test_k37_run_ballbar_writes_the_polar_plot_and_the_figures(tmp_path, job_file):
    from k37.sim.cli import main

    circle = job_file("G21 G90 F1200\nG03 X0 Y0 I-5 J0\nM30", machine='accel = "none"')
    assert main(["run", str(circle), "--ballbar", str(tmp_path / "b.png"), "--json",
                 str(tmp_path / "r.json"), "-q", "--ballbar-settle", "90"]) == 0
    report = json.loads((tmp_path / "r.json").read_text())
    assert set(report["ballbar"]) == set(FIGURES) and (tmp_path / "b.png").stat().st_size
    assert 240 < report["ballbar"]["ballbar_sweep"] < 271  # the first 90 degrees left out
    line = job_file("G21 G90 F1200\nG01 X1\nM30")
    assert main(["run", str(line), "--ballbar", str(tmp_path / "c.png"), "--json",
                 str(tmp_path / "s.json"), "-q"]) == 0
    report = json.loads((tmp_path / "s.json").read_text())
    assert "ballbar" not in report and not (tmp_path / "c.png").exists()
    assert report["warnings"] == [f"--ballbar {tmp_path / 'c.png'}: the program has no arc: a "
                                  f"ballbar test runs a circle; no ballbar plot written"]
