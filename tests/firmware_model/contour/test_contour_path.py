"""The contour error against an independent brute-force reference: the report measures each
sample against the stretch of path the tool is on, exactly, on chains of lines, arcs and
curves with a tool lagging many blocks behind; and the cases where a window tied to the
interpolator's block went wrong (short chords, a steep curve, a path passing close to itself,
a contour controller at a corner)."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from k37.firmware_model.contour.path import REACH, Path
from k37.firmware_model.contour.tracker import BACK, Tracker
from k37.firmware_model.job import ContourConfig, Job, MachineConfig, ServoConfig, parse_for_machine
from k37.firmware_model.motion.program import Arc, Line
from k37.hdl.chipset.map import axis_names
from k37.sim.run.contour import contour_errors
from k37.sim.run.runner import RunOptions, run_job
from k37.sim.run.sampler import trace_columns

#: Points of the dense sampling of a curve in the reference (1/2000 of the curve apart); then,
#: :data:`ZOOMS` times, :data:`FINE` points between the nearest one's two neighbours (down
#: to 1/2000/10/10 of the curve apart).
DENSE = 2001
FINE = 21
ZOOMS = 2


def _curve_at(move, t: np.ndarray) -> np.ndarray:
    """Points of a move with no closed form (a curve, a spline's chord, a helix) at ``t`` in
    [0, 1]: a helix turns evenly about its centre as it rises evenly along its axis."""
    if isinstance(move, Arc):
        first, second, _ = move.plane_axes
        a0, sweep = move.span
        angle = a0 + (-sweep if move.cw else sweep) * t
        start, end = np.array(move.start, dtype=float), np.array(move.end, dtype=float)
        points = start + np.outer(t, end - start)
        points[:, first] = move.center[0] + move.radius * np.cos(angle)
        points[:, second] = move.center[1] + move.radius * np.sin(angle)
        return points
    if isinstance(move, Line):
        span = move.curve
        return span.curve.at(span.t0 + (span.t1 - span.t0) * t)
    return move.at(t * move.extent)


def _dense(move) -> np.ndarray:
    return _curve_at(move, np.linspace(0.0, 1.0, DENSE))


def _distances(move, p: np.ndarray, top: float = 1.0, dense: np.ndarray | None = None
               ) -> np.ndarray:
    """The exact distance of each row of ``p`` to a move (up to ``top`` of its parameter):
    closed form on a line and an arc (whose ends are on its circle), the nearest of dense
    points on a curve and on an arc in space (a helix) (``dense``: those points, if known)."""
    if isinstance(move, Arc) and p.shape[1] == 2:
        c = np.array(move.center, dtype=float)
        a0, full = move.span
        sweep = full * top
        a1 = a0 - sweep if move.cw else a0 + sweep
        ends = c + move.radius * np.array([[math.cos(a0), math.sin(a0)],
                                           [math.cos(a1), math.sin(a1)]])
        angle = np.arctan2(p[:, 1] - c[1], p[:, 0] - c[0])
        off = ((a0 - angle) if move.cw else (angle - a0)) % math.tau
        on_circle = np.abs(np.hypot(*(p - c).T) - move.radius)
        to_end = np.minimum(np.hypot(*(p - ends[0]).T), np.hypot(*(p - ends[1]).T))
        return np.where(off <= sweep, on_circle, to_end)
    if isinstance(move, Line) and move.curve is None:
        a, b = np.array(move.start, dtype=float), np.array(move.end, dtype=float)
        d = b - a
        t = np.zeros(len(p)) if not d @ d else np.clip((p - a) @ d / (d @ d), 0.0, top)
        return np.sqrt(((p - a - np.outer(t, d)) ** 2).sum(axis=1))
    everywhere = np.linspace(0.0, 1.0, DENSE)
    q = _dense(move) if dense is None else dense
    if top < 1.0:
        below = everywhere < top
        everywhere = np.append(everywhere[below], top)
        q = np.vstack([q[below], _curve_at(move, np.array([top]))])
    grid = np.broadcast_to(everywhere, (len(p), len(everywhere)))  # a row per point
    d = np.sqrt(((q[None] - p[:, None, :]) ** 2).sum(axis=2))
    for _ in range(ZOOMS):  # again between the nearest point's two neighbours
        k = np.argmin(d, axis=1)
        rows = np.arange(len(p))
        lo = grid[rows, np.maximum(k - 1, 0)]
        hi = grid[rows, np.minimum(k + 1, grid.shape[1] - 1)]
        grid = lo[:, None] + (hi - lo)[:, None] * np.linspace(0.0, 1.0, FINE)
        points = _curve_at(move, grid.ravel()).reshape(len(p), FINE, -1)
        d = np.sqrt(((points - p[:, None, :]) ** 2).sum(axis=2))
    return d.min(axis=1)


def _length(move) -> float:
    if isinstance(move, Arc):
        rise = move.end[2] - move.start[2] if len(move.start) == 3 else 0.0  # G17's
        return math.hypot(move.radius * move.span[1], rise)
    if isinstance(move, Line) and move.curve is None:
        return math.dist(move.start, move.end)
    q = _dense(move)
    return float(np.sqrt(((q[1:] - q[:-1]) ** 2).sum(axis=1)).sum())


def _foot(move, p: np.ndarray) -> tuple[float, np.ndarray]:
    """The parameter of a point's nearest point of a move, and the move's direction there:
    closed form on a line, the nearest of dense points (zoomed in on) elsewhere."""
    if isinstance(move, Line) and move.curve is None:
        a, b = np.array(move.start, dtype=float), np.array(move.end, dtype=float)
        d = b - a
        return (0.0 if not d @ d else float(np.clip((p - a) @ d / (d @ d), 0.0, 1.0))), d
    grid = np.linspace(0.0, 1.0, DENSE)
    for _ in range(ZOOMS + 1):
        k = int(np.argmin(((_curve_at(move, grid) - p) ** 2).sum(axis=1)))
        grid = np.linspace(grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)], FINE)
    u = float(grid[FINE // 2])
    if isinstance(move, Arc):  # the tangent: the rise, the plane's turn
        first, second, _ = move.plane_axes
        a0, sweep = move.span
        turn = -sweep if move.cw else sweep
        direction = np.array(move.end, dtype=float) - np.array(move.start, dtype=float)
        direction[first] = -turn * move.radius * math.sin(a0 + turn * u)
        direction[second] = turn * move.radius * math.cos(a0 + turn * u)
        return u, direction
    # a curve's chord across 1/256 of its parameter either side, as the tracker takes it
    ahead, behind = _curve_at(move, np.array([min(u + 1 / 256, 1.0), max(u - 1 / 256, 0.0)]))
    return u, ahead - behind


def reference_errors(moves, blocks, samples) -> np.ndarray:
    """The documented window rule, sample by sample: the exact distance to the path from the
    previous sample's move forward as far as the previous sample's distance, twice the tool's
    travel since then and REACH past the sample's nearest point of that move (where the
    sample moved back along that move, at least as far past its end as the sample is from
    that end), none past the move after the running block's; of equal distances, the
    furthest move."""
    lengths = [_length(m) for m in moves]
    ends = np.cumsum(lengths)
    starts = [start for _, start in blocks]
    n = len(moves[0].start)
    tool = samples[:, 1 + n:1 + 2 * n].astype(float)
    # Each move's dense points, where it has no closed form.
    whole = [None if (isinstance(m, Line) and m.curve is None) or (isinstance(m, Arc) and n == 2)
             else _dense(m) for m in moves]
    current, last, error, out = 0, None, 0.0, []
    for i, row in enumerate(samples):
        p = tool[i]
        running = int(np.searchsorted(starts, row[0], side="right")) - 1
        if running < 0:
            out.append(math.dist(p, moves[0].start))
            continue
        step = np.zeros(n) if last is None else p - last
        travel = float(np.sqrt(step @ step))
        u, direction = _foot(moves[current], p)
        reach = ends[current] - (1 - u) * lengths[current] + error + 2 * travel + REACH
        if step @ direction < -BACK * travel * float(np.sqrt(direction @ direction)):
            gone = math.dist(p, moves[current].end)
            reach = max(reach, ends[current] + gone + 2 * travel + REACH)
        top = min(running + 1, len(moves) - 1)
        best, k = None, current
        while k == current or (k <= top and ends[k - 1] < reach):
            # The moves after the previous sample's only as far along them as the reach.
            length = lengths[k]
            top_k = 1.0 if k == current or not length else min(
                1.0, (reach - ends[k - 1]) / length)
            d = float(_distances(moves[k], p[None], top_k, whole[k])[0])
            if best is None or d <= best + 1e-6:
                best, found = d, k
            k += 1
        current, last, error = found, p, best
        out.append(best)
    return np.array(out)


def _arc(draw, x: float, y: float) -> tuple[str, float, float, str]:
    """A drawn arc from (x, y) (radius 0.5-3 mm, sweep 0.3-5.5 rad, either way): its G word,
    its end point and its centre words."""
    r = draw(st.floats(0.5, 3))
    a0, sweep = draw(st.floats(0, math.tau)), draw(st.floats(0.3, 5.5))
    cw = draw(st.booleans())
    cx, cy = x - r * math.cos(a0), y - r * math.sin(a0)
    a1 = a0 - sweep if cw else a0 + sweep
    end = round(cx + r * math.cos(a1), 3), round(cy + r * math.sin(a1), 3)
    return "G02" if cw else "G03", *end, f"I{cx - x:.3f} J{cy - y:.3f}"


@st.composite
def chains(draw):
    """A program of 2 to 6 lines, arcs, parabolas, exponentials and G5 splines (mm) and a tool
    lagging it."""
    text, x, y = ["G21 G90 F600"], 0.0, 0.0
    for _ in range(draw(st.integers(2, 6))):
        kind = draw(st.sampled_from(["line", "arc", "parabola", "exponential", "spline"]))
        if kind == "line":
            x += draw(st.floats(-3, 3)).__round__(3)
            y += draw(st.floats(-3, 3)).__round__(3)
            text.append(f"G01 X{x:.3f} Y{y:.3f}")
        elif kind == "arc":
            word, x, y, centre = _arc(draw, x, y)
            text.append(f"{word} X{x:.3f} Y{y:.3f} {centre}")
        elif kind == "parabola":
            dx = 2 * draw(st.integers(500, 1500)) / 1000
            rise = draw(st.floats(-1, 1)).__round__(3)
            text.append(f"G06 X{x + dx:.3f} Y{y:.3f} I{dx / 2:.3f} J{rise:.3f}")
            x += dx
        elif kind == "exponential":
            dx, dy = (draw(st.sampled_from([-1, 1])) * draw(st.floats(0.5, 3)) for _ in "xy")
            k = draw(st.sampled_from([-1, 1])) * draw(st.floats(0.3, 3))
            x, y = round(x + dx, 3), round(y + dy, 3)
            text.append(f"{draw(st.sampled_from(['G06.1', 'G06.2']))} X{x:.3f} Y{y:.3f} "
                        f"K{k:.3f}")
        else:
            i, j, p, q = (draw(st.floats(-2, 2)) for _ in "ijpq")
            x += draw(st.floats(-3, 3)).__round__(3)
            y += draw(st.floats(-3, 3)).__round__(3)
            text.append(f"G05 X{x:.3f} Y{y:.3f} I{i:.3f} J{j:.3f} P{p:.3f} Q{q:.3f}")
    return "\n".join(text) + "\nM30\n", draw(st.integers(0, 3000)), draw(st.integers(0, 99))


@st.composite
def helical_chains(draw):
    """A three-axis program of 2 to 5 lines and helices (mm) and a tool lagging it."""
    text, x, y, z = ["G17 G21 G90 F600"], 0.0, 0.0, 0.0
    for _ in range(draw(st.integers(2, 5))):
        z = round(z + draw(st.floats(-2, 2)), 3)
        if draw(st.booleans()):
            x += draw(st.floats(-3, 3)).__round__(3)
            y += draw(st.floats(-3, 3)).__round__(3)
            text.append(f"G01 X{x:.3f} Y{y:.3f} Z{z:.3f}")
            continue
        word, x, y, centre = _arc(draw, x, y)
        text.append(f"{word} X{x:.3f} Y{y:.3f} Z{z:.3f} {centre}")
    return "\n".join(text) + "\nM30\n", draw(st.integers(0, 3000)), draw(st.integers(0, 99))


def _lagging_samples(moves, lag: float, seed: int, axes: int = 2) -> tuple[list, np.ndarray]:
    """Blocks started one cycle per LSB of path, and a tool ``lag`` LSB of path behind the
    interpolator, up to 40 LSB off it on every axis, sampled every 13 cycles."""
    path = Path(moves, axes)
    ends = path.ends
    blocks = [(m.index, int(s)) for m, s in zip(moves, np.concatenate([[0], ends[:-1]]),
                                                   strict=True)]
    cycles = np.arange(0, int(ends[-1] + lag), 13)
    along = np.clip(cycles - lag, 0, ends[-1] - 1e-9)
    k = np.searchsorted(ends, along, side="right")
    u = (along - (ends[k] - np.array([s.length for s in path.segments])[k])) / np.maximum(
        np.array([s.length for s in path.segments])[k], 1e-9)
    points = np.vstack([path.segments[kk].at(np.array([uu]))
                        for kk, uu in zip(k, u, strict=True)])
    rng = np.random.default_rng(seed)
    samples = np.zeros((len(cycles), len(trace_columns(axis_names(axes)))), dtype=np.int64)
    samples[:, 0] = cycles
    samples[:, 1 + axes:1 + 2 * axes] = np.rint(points + rng.uniform(-40, 40, points.shape))
    return blocks, samples


@settings(max_examples=15, deadline=None)
@given(st.one_of(chains(), helical_chains()))
def test_the_contour_error_of_a_lagging_tool_equals_the_brute_force_reference(case):
    gcode, lag, seed = case
    try:
        machine, program = parse_for_machine(MachineConfig(), gcode, source="<chain>")
    except ValueError:
        return  # a curve the K3701 refuses
    moves = program.moves
    assume(len(moves) and Path(moves, machine.axes).ends[-1] >= 1)
    job = Job("chain", machine, {}, program)
    blocks, samples = _lagging_samples(moves, lag, seed, machine.axes)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        errors = contour_errors(job, blocks, samples)
    assert errors == pytest.approx(reference_errors(moves, blocks, samples), abs=0.5)


def test_a_pass_close_to_an_earlier_one_is_measured_against_itself():
    # Out along X, 50 LSB up, back along X: the tool on the way back, 35 LSB below it, is 15
    # LSB from the way out, which it has left behind.
    _, program = parse_for_machine(MachineConfig(), "G21 G90 F600\nG01 X10\nG01 Y0.05\n"
                                   "G01 X0\nM30\n", source="<pocket>")
    path = Path(program.moves, 2)
    tracker = Tracker(path)
    tool = np.array([[5000.0, 0.0], [10000.0, 25.0], [9000.0, 15.0], [5000.0, 15.0]])
    found = tracker.track(tool, np.full(4, 2))
    assert list(found.segment) == [0, 1, 2, 2]
    assert found.distance[2:] == pytest.approx([35.0, 35.0])
    assert path.nearest(tool[3:], 0, 2).distance == pytest.approx([15.0])  # the wrong pass


#: The contour-error paper's Table 1 plant on a 5 um LSB, no accel/decel.
PLANT = MachineConfig(accel="none", lsb_mm=0.005)
TABLE1 = {"x": ServoConfig(kp=10.3, tm=0.035), "y": ServoConfig(kp=10.0, tm=0.030)}


def _run(gcode: str, controller: str = "none", machine=PLANT, servo=None):
    machine, program = parse_for_machine(machine, gcode, source="<t>")
    job = Job("c", machine, servo or TABLE1, program,
              contour=ContourConfig(controller=controller))
    return run_job(job, RunOptions(backend="cxxrtl"))


def test_a_tool_many_chords_behind_is_measured_against_its_own_chord():
    # 100 chords of 0.67 mm of one line at 60 mm/s on the Table 1 plant (Kp 10.3/s on X,
    # 10/s on Y): the tool trails the interpolator by 6 mm, nine chords, and the unequal lags
    # take it off the line by 17 LSB at most (equal gains would keep it on the line, within
    # a step).
    chords = "\n".join(f"G01 X{0.6 * k:.3f} Y{0.3 * k:.3f}" for k in range(1, 101))
    run = _run(f"G21 G90 F3600\n{chords}\nM30\n")
    actual = run.samples[:, 3:5].astype(float)
    d = np.array([12000.0, 6000.0])
    t = np.clip(actual @ d / (d @ d), 0, 1)
    exact = np.hypot(*(actual - np.outer(t, d)).T)  # the chords are one straight line
    assert 15 < exact.max() < 19
    assert run.report["path"]["max_contour_error"] == pytest.approx(exact.max(), abs=1)
    assert run.report["path"]["rms_contour_error"] == pytest.approx(
        math.sqrt(np.mean(exact**2)), abs=0.5)


@pytest.mark.parametrize("gcode", [
    # a long arc (R < 0) that leaves the line before it turning back along it
    "G21 G90 F600\nG01 X20 Y30\nG01 X10 Y30\nG02 X0 Y20 R-10\nM30\n",
    # a full circle from the end of a plunge, the retract from its start (a PCB pad)
    "G21 G90\nG00 Z1\nG01 Z-0.15 F300\nG02 X0 Y0 I1.143 J0 F600\nG00 Z1\nM30\n",
])
def test_a_path_that_turns_back_on_itself_is_measured_where_the_tool_is(gcode):
    machine, program = parse_for_machine(MachineConfig(), gcode, source="<t>")
    run = run_job(Job("c", machine, dict.fromkeys(machine.axis_names, ServoConfig()), program),
                  RunOptions(backend="engine"))
    n = machine.axes
    actual = np.unique(run.samples[:, 1 + n:1 + 2 * n], axis=0).astype(float)
    nearest = np.min([_distances(m, actual) for m in program.moves], axis=0)
    assert run.report["path"]["max_contour_error"] == pytest.approx(nearest.max(), abs=1)
    assert nearest.max() < 20


def test_a_steep_exponential_reports_its_true_error_and_no_warning(recwarn):
    run = _run("G21 G90\nG06.2 X-1.872 Y1.394 K-0.008 F600\nM30\n", machine=MachineConfig())
    move = run.job.program.moves[0]
    actual = np.unique(run.samples[:, 3:5], axis=0).astype(float)
    exact = _distances(move, actual)
    assert not [w for w in recwarn if issubclass(w.category, RuntimeWarning)]
    assert run.report["path"]["max_contour_error"] <= exact.max() + 1
    assert run.report["path"]["max_contour_error"] == pytest.approx(exact.max(), rel=0.05)


@pytest.mark.parametrize("controller", ["ccc", "vgccc", "cec"])
def test_a_controller_at_a_line_arc_corner_is_no_worse_than_no_controller(controller):
    gcode = "G17 G21 G90\nG01 X20 Y0 F3600\nG03 X0 Y20 I-20 J0\nM30\n"
    plain = _run(gcode).report["path"]["max_contour_error"]
    worst = _run(gcode, controller).report["path"]["max_contour_error"]
    assert worst <= 1.2 * plain, (worst, plain)


def _random_chain(seed: int, moves: int = 4) -> str:
    """A chain of lines of 3 to 10 mm and arcs of radius 10 to 30 mm in random directions
    (corners and smooth junctions alike) at the contour-error paper's 60 mm/s: the tool lags
    the reference by some 6 mm there, and no tighter arc (the CCC's tangent line, and the
    VGCCC's circle, at the reference stand for the path near the tool only while the lag is
    below the radius)."""
    rng = np.random.default_rng(seed)
    text, x, y = ["G17 G21 G90 F3600"], 0.0, 0.0
    for _ in range(moves):
        if rng.random() < 0.5:
            a, length = rng.uniform(0, math.tau), rng.uniform(3, 10)
            x, y = x + length * math.cos(a), y + length * math.sin(a)
            text.append(f"G01 X{x:.3f} Y{y:.3f}")
            continue
        r, a0, sweep = rng.uniform(10, 30), rng.uniform(0, math.tau), rng.uniform(0.5, 3)
        cw = bool(rng.integers(2))
        cx, cy = x - r * math.cos(a0), y - r * math.sin(a0)
        a1 = a0 - sweep if cw else a0 + sweep
        i, j = cx - x, cy - y
        x, y = cx + r * math.cos(a1), cy + r * math.sin(a1)
        text.append(f"{'G02' if cw else 'G03'} X{x:.3f} Y{y:.3f} I{i:.3f} J{j:.3f}")
    return "\n".join(text) + "\nM30\n"


#: How much larger than with no controller any controller's largest contour error may be on a
#: random chain.
WORSE_BY = 1.5


@pytest.mark.parametrize("seed", range(8))
def test_no_controller_makes_a_chain_of_lines_and_arcs_much_worse(seed):
    gcode = _random_chain(seed)
    plain = _run(gcode).report["path"]["max_contour_error"]
    for controller in ("ccc", "vgccc", "cec"):
        worst = _run(gcode, controller).report["path"]["max_contour_error"]
        assert worst <= WORSE_BY * plain, (controller, worst, plain)
