"""Reproducing the paper's experiments on the emulator: ``k37 reproduce``.

Each experiment of the paper (section 3 and its photos, the maximum step rates, Table 1, and
the FP-budget warning) is run on the emulated machine with the compiled backend, and each
observation becomes a row of ``report.md``: the paper's figure, the emulator's, the tolerance
and pass or fail. The comparisons are computed here, against the paper's numbers or against
the physics that explains them (a first-order lag for the accel/decel circuit, the servo's
closed-loop transfer ``G(s) = Kp / (s (1 + s Tm) + Kp)``), never written in.

The closed-loop runs are independent, so they run in worker processes (two by default, one
per core); every run on a given accel placement shares one compiled model. :data:`FULL` is
the scale of the committed figures; :data:`QUICK` shrinks the long runs for CI. The report
says what each scale shrank.
"""

from __future__ import annotations

import math
import multiprocessing
import os
import time
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from firmware_model.firmware import FEED_BITS, feed_word, rm_clock_hz
from firmware_model.gcode import Arc, Line, parse
from firmware_model.host import Host8085
from firmware_model.job import AXES, Job, MachineConfig, ServoConfig
from hdl.decel_control import DECEL_MAP
from hdl.divider_model import frequency_of, increment_for
from hdl.feed_rate import DIVIDER_WIDTH, FEED_MAP
from hdl.k3701 import block_registers
from hdl.k3701_model import Block, make_path, walk
from sim.backends.contract import Backend
from sim.machine.plant import DAC_VOLTS
from sim.run.link import SimulatedLink
from sim.run.runner import RunOptions, build_backend, run_job
from sim.run.sampler import TRACE_COLUMNS

__all__ = ["FEED_HIGH", "FEED_LOW", "FULL", "MACHINE", "QUICK", "Reproduction", "Row", "RunData",
           "RunSpec", "Scale", "analyse", "feed_for_word", "fp_rate", "hardware_tau",
           "ideal_command", "lag", "quarter_counts", "report_markdown", "reproduce", "run_all",
           "run_specs", "servo", "servo_radius_loss", "table1", "table_markdown"]

COL = {name: k for k, name in enumerate(TRACE_COLUMNS)}

#: The feed words of the paper's path-error photos 3 and 4 (0xF0FF and 0x00FF).
FEED_HIGH, FEED_LOW = 61695, 255
#: The paper's accel/decel time constant, 2^15 / 109.227 kHz.
PAPER_TAU_S = 0.300
#: The paper's maximum feed (step) rates at CP = 1 MHz (section 2 (1)).
PAPER_RATE_LINEAR, PAPER_RATE_CIRCULAR = 90.0e3, 47.6e3
#: 1 - 1/e: the fraction of the final value a first-order lag reaches after one tau.
E63 = 1 - math.exp(-1)


def table1(r: float, theta: float, sqrt2: bool) -> float:
    """The corrected Table 1 of the SPEC: FP for an arc from the x axis through ``theta``."""
    deg = math.degrees(theta)
    s2 = math.sqrt(2)
    if math.isclose(deg, 45):
        return r * (0.5 + s2 / 4) if sqrt2 else r * s2 / 2
    if math.isclose(deg, 90):
        return r * (1 + s2 / 2) if sqrt2 else r * s2
    if deg < 45:
        return r * (math.sin(theta) + (1 - math.cos(theta)) / 2) if sqrt2 else r * math.sin(theta)
    if sqrt2:
        return r * (0.5 + s2 / 2 + math.sin(theta) / 2 - math.cos(theta))
    return r * (s2 - math.cos(theta))


def servo_radius_loss(radius: float, speed: float, kp: float, tm: float) -> float:
    """Steady-state radius loss R (1 - |G(jw)|) of a circle followed at ``speed`` (LSB/s).

    ``G(s) = Kp / (s (1 + s Tm) + Kp)`` is one axis's closed position loop, ``w = v / R``.
    """
    w = speed / radius
    return radius * (1 - kp / abs(complex(kp - w * w * tm, w)))


# -- scale ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class Scale:
    """The sizes of the runs (LSB = 1 um); the paper gives no sizes, only feeds and tau."""

    name: str
    #: Experiments 1 and 5: the line (X, Y) at the high feed; its FP budget sets how long the
    #: feed stays on (25000 FP at 21.4 kFP/s: 1.17 s, 3.9 tau).
    line: tuple[int, int]
    #: Experiments 4 and 5: radius of the full circles at the high feed.
    radius: int
    #: Experiment 4: radius of the low-feed arc and its sweep (degrees, CCW from the x axis).
    low_radius: int
    low_sweep: int
    #: Experiment 6: length of the X line and its feed (FP/s).
    hazard_steps: int
    hazard_fp_s: float
    #: Experiment 2: steps counted at the maximum rate, per interpolation type.
    rate_steps: int
    #: Sampling period of the closed-loop runs (cycles).
    sample_every: int = 1000


FULL = Scale("full", line=(20_000, 10_000), radius=3000, low_radius=150, low_sweep=90,
             hazard_steps=300, hazard_fp_s=1000.0, rate_steps=20_000)
QUICK = Scale("quick", line=(10_000, 5000), radius=3000, low_radius=100, low_sweep=45,
              hazard_steps=100, hazard_fp_s=1000.0, rate_steps=5000)


# -- the machine and its hardware rates ----------------------------------------------------


MACHINE = {accel: MachineConfig(accel=accel) for accel in ("pre", "post")}
SERVO = ServoConfig()


def feed_for_word(machine: MachineConfig, word: int) -> float:
    """The G-code feed (mm/min) whose rate-multiplier word is ``word`` (inverts feed_word)."""
    feed = word / (1 << FEED_BITS) * rm_clock_hz(machine) * 60 * machine.lsb_mm
    if feed_word(machine, feed) != word:
        raise ValueError(f"no feed gives the rate-multiplier word {word}")
    return feed


def fp_rate(machine: MachineConfig, word: int) -> float:
    """The mean FP rate of a feed word on the hardware (its dividers' exact increments)."""
    inc = increment_for(rm_clock_hz(machine), width=DIVIDER_WIDTH, f_clk=machine.clock_hz)
    f_in = frequency_of(inc, width=DIVIDER_WIDTH, f_clk=machine.clock_hz)
    return f_in * word / (1 << FEED_BITS)


def hardware_tau(machine: MachineConfig) -> float:
    """The accel/decel time constant 2^n / fa with the fa divider's exact increment."""
    inc = increment_for(machine.accel_fa_hz, width=DIVIDER_WIDTH, f_clk=machine.clock_hz)
    return 2**machine.accel_bits / frequency_of(inc, width=DIVIDER_WIDTH, f_clk=machine.clock_hz)


def _mm(lsb: int, machine: MachineConfig) -> str:
    return f"{lsb * machine.lsb_mm:.3f}"


# -- runs (executed in worker processes) ----------------------------------------------------


@dataclass(frozen=True)
class RunSpec:
    """One closed-loop run of a G-code program on the machine with ``accel``."""

    key: str
    accel: str
    gcode: str
    sample_every: int
    max_cycles: int = 10**9
    budget_offset: int = 0
    #: After the run, keep stepping until the accel/decel circuit is empty (at most this
    #: many cycles), to see where its last pulses go.
    drain_cycles: int = 0

    def job(self) -> Job:
        machine = MACHINE[self.accel]
        program = parse(self.gcode, source=f"<{self.key}>", lsb_mm=machine.lsb_mm,
                        sqrt2=machine.sqrt2)
        return Job(self.key, machine, dict.fromkeys(AXES, SERVO), program)


@dataclass(frozen=True)
class RateSpec:
    """Experiment 2: K3701 blocks run with FP offered every cycle (the post machine)."""

    key: str
    #: (name, block, port counting one pulse per step, steps to count)
    blocks: tuple[tuple[str, Block, str, int], ...]
    accel: str = "post"


@dataclass
class RunData:
    """What a worker sends back: the report and samples of a run, probes, wall time."""

    key: str
    report: dict
    samples: np.ndarray
    probes: dict[str, int]
    seconds: float


_BACKENDS: dict[str, Backend] = {}


def _backend(accel: str) -> Backend:
    """This process's compiled machine for ``accel``, reset to cycle 0."""
    backend = _BACKENDS.get(accel)
    if backend is None:
        job = RunSpec("build", accel, "M30", 1).job()
        backend = _BACKENDS[accel] = build_backend(job, "cxxrtl")
    else:
        backend.reset()
    return backend


def _build(accel: str) -> RunData:
    start = time.perf_counter()
    _backend(accel)
    return RunData(f"build {accel}", {}, np.zeros(0), {}, time.perf_counter() - start)


def _run(spec: RunSpec) -> RunData:
    start = time.perf_counter()
    backend = _backend(spec.accel)
    job = spec.job()
    result = run_job(job, RunOptions(backend="cxxrtl", sample_every=spec.sample_every,
                                     max_cycles=spec.max_cycles,
                                     budget_offset=spec.budget_offset), backend)
    probes = {"busy": backend.probe("chipset.k3701.busy"),
              "remaining_x": Host8085(SimulatedLink(backend)).read("K3701", "X")}
    if spec.drain_cycles:
        limit = backend.cycle + spec.drain_cycles
        while not backend.probe("chipset.accel.idle") and backend.cycle < limit:
            backend.step(1000)
        probes["drained_cycle"] = backend.cycle
    probes["fp_total"] = backend.get("fp_total")
    for axis in AXES:
        probes[f"{axis}_command"] = backend.get(f"{axis}__command")
        probes[f"{axis}_steps"] = (backend.get(f"{axis}__pulses_pos")
                                   - backend.get(f"{axis}__pulses_neg"))
    return RunData(spec.key, result.report, result.samples, probes,
                   time.perf_counter() - start)


def _max_rates(spec: RateSpec) -> RunData:
    """Step rates of the K3701 gateware with FP offered every cycle (SPEC section 3)."""
    start = time.perf_counter()
    probes: dict[str, int] = {}
    cycles = 0
    for name, block, counter, steps in spec.blocks:
        backend = _backend(spec.accel)
        host = Host8085(SimulatedLink(backend))
        host.command("K3701", ack=1, clear=1)
        for register, value in block_registers(block).items():
            host.write("K3701", register, value)
        host.command("K3701", start=1, ack=1)
        # The feed path wide open: the rate multiplier's input clock at every cycle and its
        # word at the maximum, the budget at the maximum: FP in all but 1 of 2^18 cycles.
        for chip, regmap, register in (("FEED", FEED_MAP, "RM_INC"), ("FEED", FEED_MAP, "FEED"),
                                       ("DECEL", DECEL_MAP, "BUDGET")):
            host.write(chip, register, regmap[register].bounds[1])
        backend.step(1000)  # past the start and the circle's radius check
        c0, n0 = backend.cycle, backend.get(counter)
        backend.step(steps * block.latency)
        probes[f"{name}_cycles"] = backend.cycle - c0
        probes[f"{name}_steps"] = backend.get(counter) - n0
        probes[f"{name}_busy"] = backend.probe("chipset.k3701.busy")
        probes[f"{name}_overrun"] = backend.probe("chipset.k3701.overrun")
        cycles += backend.cycle
    return RunData(spec.key, {"cycles": cycles}, np.zeros(0), probes,
                   time.perf_counter() - start)


def _execute(task: RunSpec | RateSpec | str) -> RunData:
    if isinstance(task, str):
        return _build(task)
    if isinstance(task, RateSpec):
        return _max_rates(task)
    return _run(task)


# -- the experiments' runs ------------------------------------------------------------------


#: Dwell (s) after the last move: three times 1 / Kp, so the servo has made its last count.
REST_S = 0.1


def _arc_end(radius: int, sweep_deg: int) -> tuple[int, int]:
    """End of a CCW arc from the x axis through ``sweep_deg``, relative to its start."""
    a = math.radians(sweep_deg)
    return round(radius * math.cos(a)) - radius, round(radius * math.sin(a))


def run_specs(scale: Scale) -> dict[str, RunSpec | RateSpec]:
    """Every run of the experiments at ``scale`` (the budget-too-low run comes later)."""
    pre = MACHINE["pre"]
    high, low = feed_for_word(pre, FEED_HIGH), feed_for_word(pre, FEED_LOW)
    every = scale.sample_every
    x, y = scale.line
    r = scale.radius
    ex, ey = _arc_end(scale.low_radius, scale.low_sweep)
    # A dwell at the end lets the servo finish its last count before the firmware's settle
    # check (which is satisfied inside the position zone).
    rest = f"G04 P{REST_S}\nM30"
    circle = f"G17 G21 G91\nG03 I-{_mm(r, pre)} J0 F{high:.6f}\n{rest}"
    hazard = (f"G17 G21 G91\nG01 X{_mm(scale.hazard_steps, pre)} "
              f"F{scale.hazard_fp_s * 60 * pre.lsb_mm:.6f}\n{rest}")
    tau_cycles = round(hardware_tau(pre) * pre.clock_hz)
    big = 100_000  # a radius whose first octant holds the whole circular count
    return {
        "hazard_exact": RunSpec("hazard_exact", "pre", hazard, every),
        "line": RunSpec("line", "pre",
                        f"G17 G21 G91\nG01 X{_mm(x, pre)} Y{_mm(y, pre)} F{high:.6f}\n{rest}",
                        every),
        "pre_circle": RunSpec("pre_circle", "pre", circle, every),
        "hazard_plus": RunSpec("hazard_plus", "pre", hazard, every, budget_offset=1,
                               drain_cycles=3 * tau_cycles),
        "post_low": RunSpec("post_low", "post",
                            f"G17 G21 G91\nG03 X{_mm(ex, pre)} Y{_mm(ey, pre)} "
                            f"I-{_mm(scale.low_radius, pre)} J0 F{low:.6f}\nM30", every),
        "post_high": RunSpec("post_high", "post", circle, every),
        "rates": RateSpec("rates", (
            ("linear", Block.line(scale.rate_steps + 1000, 0), "x__pulses_pos",
             scale.rate_steps),
            ("circular", Block.arc(0, 0, -big, 0), "y__pulses_pos", scale.rate_steps),
        )),
    }


def _minus_spec(exact: RunData, spec: RunSpec) -> RunSpec:
    """The budget-too-low run: stopped 3 tau after the exact run's block ended."""
    tau_cycles = round(hardware_tau(MACHINE["pre"]) * MACHINE["pre"].clock_hz)
    end = exact.report["blocks"][0]["end_cycle"]
    return RunSpec("hazard_minus", spec.accel, spec.gcode, spec.sample_every,
                   max_cycles=end + 3 * tau_cycles, budget_offset=-1)


def run_all(scale: Scale, jobs: int = 2,
            progress: Callable[[str], None] | None = None) -> dict[str, RunData]:
    """Run every experiment's runs in ``jobs`` worker processes; results by key.

    Each accel placement's model is built once first (two builds in parallel); a placement's
    runs are queued as soon as its model is in the cache, so no model is compiled twice.
    """
    say = progress or (lambda _: None)
    specs = run_specs(scale)
    by_accel: dict[str, list[RunSpec | RateSpec]] = {"pre": [], "post": []}
    for spec in specs.values():
        by_accel[spec.accel].append(spec)
    results: dict[str, RunData] = {}
    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max(1, jobs), mp_context=context) as pool:
        pending: dict[Future, str] = {pool.submit(_execute, accel): accel
                                      for accel in by_accel}
        while pending:
            done, _ = wait(pending, return_when=FIRST_COMPLETED)
            for future in done:
                key = pending.pop(future)
                data = future.result()
                results[data.key] = data
                cycles = data.report.get("cycles")
                what = f", {cycles / 1e6:.1f} M cycles" if cycles else ""
                say(f"{data.key}: {data.seconds:.1f} s{what}")
                if key in by_accel:
                    pending.update({pool.submit(_execute, spec): spec.key
                                    for spec in by_accel[key]})
                elif key == "hazard_exact":
                    minus = _minus_spec(data, specs["hazard_exact"])  # type: ignore[arg-type]
                    pending[pool.submit(_execute, minus)] = minus.key
    return results


# -- theory: the linear models the runs are compared with ------------------------------------


def _expm(m: np.ndarray) -> np.ndarray:
    """Matrix exponential (scaling and squaring of a Taylor series; small matrices)."""
    squarings = max(0, math.ceil(math.log2(max(np.abs(m).sum(axis=1).max(), 1e-300))) + 1)
    a = m / 2.0**squarings
    result = term = np.eye(len(m))
    for k in range(1, 16):
        term = term @ a / k
        result = result + term
    for _ in range(squarings):
        result = result @ result
    return result


def lag(t: np.ndarray, signal: np.ndarray, tau: float) -> np.ndarray:
    """``signal`` (sampled at the uniform times ``t``) through 1 / (1 + s tau), from rest.

    Exact for a signal that is linear between samples.
    """
    dt = t[1] - t[0]
    a = math.exp(-dt / tau)
    b = 1 - tau / dt * (1 - a)
    out = np.empty(len(signal))
    y = out[0] = signal[0]
    for k in range(len(signal) - 1):
        y = a * y + (1 - a) * signal[k] + b * (signal[k + 1] - signal[k])
        out[k + 1] = y
    return out


def servo(t: np.ndarray, command: np.ndarray, kp: float, tm: float,
          substeps: int = 10) -> np.ndarray:
    """The actual position of one axis following ``command``: G(s) = Kp / (s (1 + s Tm) + Kp).

    The plant of SPEC section 9 (velocity command Kp x error, first-order velocity lag Tm),
    from rest at ``command[0]``; the command is taken as linear between the samples.
    """
    h = (t[1] - t[0]) / substeps
    # State (position, velocity) with the command as a held input over each substep.
    system = np.array([[0.0, 1.0, 0.0], [-kp / tm, -1 / tm, kp / tm], [0.0, 0.0, 0.0]])
    step = _expm(system * h)
    (p11, p12, g1), (p21, p22, g2) = step[0], step[1]
    out = np.empty(len(command))
    p, v = float(command[0]), 0.0
    out[0] = p
    for k in range(len(command) - 1):
        c0, dc = command[k], (command[k + 1] - command[k]) / substeps
        for j in range(substeps):
            c = c0 + (j + 0.5) * dc
            p, v = p11 * p + p12 * v + g1 * c, p21 * p + p22 * v + g2 * c
        out[k + 1] = p
    return out


def ideal_command(block: Block, fp_per_s: float, t: np.ndarray) -> tuple[np.ndarray, ...]:
    """Where the K3701 has commanded each axis at times ``t`` (s after its FP start).

    FP arrive at the constant rate ``fp_per_s``; each step of the reference model's path
    costs 2 half-FP (3 for a diagonal with sqrt(2) control), and happens with the FP that
    completes its credit.
    """
    steps = [(s.dx, s.dy) for s in walk(block)]
    d = np.array(steps, dtype=float).reshape(-1, 2)
    cost = np.where((d[:, 0] != 0) & (d[:, 1] != 0) & block.sqrt2, 3, 2)
    fp_of_step = np.ceil(np.cumsum(cost) / 2)
    done = np.searchsorted(fp_of_step / fp_per_s, t, side="right")
    pos = np.vstack([np.zeros((1, 2)), np.cumsum(d, axis=0)])
    return pos[done, 0], pos[done, 1]



# -- rows, sections and the report ------------------------------------------------------------


@dataclass
class Row:
    """One line of the report's table: an observation of the paper and the emulator's."""

    what: str
    paper: str
    emulator: str
    tolerance: str
    passed: bool


@dataclass
class Section:
    """One experiment: its rows, what the paper and the emulator show, its figure."""

    number: int
    title: str
    runs: tuple[str, ...]
    rows: list[Row] = field(default_factory=list)
    text: list[str] = field(default_factory=list)
    figure: str | None = None


@dataclass
class Reproduction:
    """The outcome of :func:`reproduce`."""

    scale: Scale
    sections: list[Section]
    runs: dict[str, RunData]
    seconds: float
    model_seconds: float

    @property
    def rows(self) -> list[Row]:
        return [row for section in self.sections for row in section.rows]

    @property
    def passed(self) -> bool:
        return all(row.passed for row in self.rows)


def _row(section: Section, what: str, paper: str, emulator: str, tolerance: str,
         passed: bool | np.bool_) -> None:
    section.rows.append(Row(what, paper, emulator, tolerance, bool(passed)))


class _Run:
    """A closed-loop run's samples as seconds since its first block started, and columns."""

    def __init__(self, data: RunData, clock_hz: float):
        self.data = data
        self.block = data.report["blocks"][0]
        s = data.samples
        self.t = (s[:, COL["cycle"]] - self.block["start_cycle"]) / clock_hz
        self.cols = {name: s[:, k] for name, k in COL.items()}
        self.clock_hz = clock_hz

    def __getitem__(self, name: str) -> np.ndarray:
        return self.cols[name]

    def seconds(self, cycle: int) -> float:
        return (cycle - self.block["start_cycle"]) / self.clock_hz

    def rate(self, name: str, window_s: float) -> tuple[np.ndarray, np.ndarray]:
        """Mid-window times and the rate of column ``name`` over windows of ``window_s``."""
        w = max(1, round(window_s / (self.t[1] - self.t[0])))
        v = self[name]
        return (self.t[w:] + self.t[:-w]) / 2, (v[w:] - v[:-w]) / (self.t[w:] - self.t[:-w])


def _crossing(t: np.ndarray, v: np.ndarray, level: float) -> float:
    """The first time ``v`` reaches ``level`` (linear interpolation between samples)."""
    k = int(np.argmax(v >= level))
    if v[k] < level or k == 0:
        return math.nan
    return float(t[k - 1] + (level - v[k - 1]) * (t[k] - t[k - 1]) / (v[k] - v[k - 1]))


def _pct(value: float) -> str:
    return f"{100 * value:.1f}%"


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig, out: Path, name: str) -> str:
    fig.tight_layout()
    fig.savefig(out / name, dpi=80)
    _plt().close(fig)
    return name


# -- experiment 1: the exponential accel/decel curve (photos 1 and 2) ------------------------


def _accel(runs: dict[str, RunData], specs: dict, out: Path) -> Section:
    sec = Section(1, "Exponential acceleration (Photos 1 and 2)", ("line",))
    machine = MACHINE["pre"]
    run = _Run(runs["line"], machine.clock_hz)
    item = specs["line"].job().program.items[0]
    fi, tau = fp_rate(machine, FEED_HIGH), hardware_tau(machine)
    # Theory: the circuit is a first-order lag of the FP count (SPEC section 5); the gate
    # passes the block's budget at the rate fi; the long axis takes Xe / FP steps per FP.
    fed = fi * np.clip(run.t, 0, item.plan.fp / fi)
    delivered = lag(run.t, fed, tau)
    tm, rate = run.rate("fp_total", 0.02)
    rate_model = np.interp(tm, run.t, (fed - delivered) / tau)
    t63 = _crossing(tm, rate, E63 * fi)
    _row(sec, "accel/decel output reaches 63% of its final rate (Photo 1)",
         f"about 300 ms (tau = 2^15 / 109.227 kHz = {1e3 * PAPER_TAU_S:.0f} ms)",
         f"{1e3 * t63:.1f} ms at fi = {fi:.0f} FP/s (feed word {FEED_HIGH})",
         "within 3% of 300 ms", abs(t63 - PAPER_TAU_S) <= 0.03 * PAPER_TAU_S)
    deviation = np.abs(rate - rate_model).max() / fi
    _row(sec, "output rate follows fi (1 - exp(-t/tau)) up and the exponential decay down",
         "equation (1), an exponential curve",
         f"largest deviation {_pct(deviation)} of fi (20 ms windows)",
         "within 3% of fi at every sample", deviation <= 0.03)

    scale_v = DAC_VOLTS / (1 << (machine.dac_bits - 1))
    half = 1 << (machine.dac_bits - 1)
    volts = {}
    for axis, share in zip(AXES, (item.block.xe, item.block.ye), strict=True):
        command = delivered * share / item.plan.fp
        error = command - servo(run.t, command, SERVO.kp, SERVO.tm)
        volts[axis] = np.clip(np.round(error), -half, half - 1) * scale_v
    steady = fi * item.block.xe / item.plan.fp / SERVO.kp * scale_v
    measured = run["x_dac_volts"]
    dac63 = _crossing(run.t, measured, E63 * steady)
    dac_dev = np.abs(measured - volts["x"]).max() / steady
    _row(sec, "closed-loop D/A voltage follows the accel/decel curve (Photo 2)",
         "the accel/decel curve seen at the D/A with the encoder feedback on",
         f"X: peak {measured.max():.3f} V (model {volts['x'].max():.3f} V; v / Kp at the full "
         f"feed {steady:.3f} V), 63% of that at {1e3 * dac63:.0f} ms; largest deviation from "
         f"the model {_pct(dac_dev)}",
         "within 5% of the steady voltage at every sample", dac_dev <= 0.05)

    sec.text += [
        f"The paper ran the accel/decel circuit with n = 15 and fa = 109.227 kHz and read the "
        f"time constant off the D/A output: 63% of the steady state at about 300 ms (Photo 1, "
        f"the feedback disconnected), and showed the accel/decel curve again with the encoder "
        f"feedback on (Photo 2). The emulator runs a line of ({item.block.xe}, "
        f"{item.block.ye}) LSB under FP control at the feed word {FEED_HIGH} "
        f"(F{feed_for_word(machine, FEED_HIGH):.2f} mm/min, {fi:.0f} FP/s); its budget of "
        f"{item.plan.fp} FP keeps the feed on for {item.plan.fp / fi:.2f} s, then the "
        f"circuit drains. Photo 1 is read as the circuit's output rate (the FP rate into the "
        f"K3701, counted on the gateware); without feedback the D/A of a K3702 would show the "
        f"accumulated command, not a rate. Photo 2 is the X axis's D/A voltage in the closed "
        f"loop, which is the following error: speed / Kp.",
        "The model curves (dashed) are a first-order lag of the FP count with tau = 2^15 / fa "
        "and the servo's G(s) = Kp / (s (1 + s Tm) + Kp), computed independently of the run.",
    ]
    plt = _plt()
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.8))
    a.plot(tm, rate / 1e3, lw=1, label="emulator (FP into the K3701)")
    a.plot(tm, rate_model / 1e3, "k--", lw=0.8, label="fi (1 - exp(-t/tau)), then decay")
    a.axhline(E63 * fi / 1e3, color="C3", lw=0.6)
    a.axvline(PAPER_TAU_S, color="C3", lw=0.6)
    a.annotate(f"63% at {1e3 * t63:.0f} ms", (t63, E63 * fi / 1e3), xytext=(0.45, 0.35 * fi / 1e3),
               arrowprops={"arrowstyle": "->"})
    a.set(title="Photo 1: accel/decel output rate", xlabel="time (s)", ylabel="kFP/s")
    a.legend(fontsize=8)
    for axis, colour in zip(AXES, ("C0", "C1"), strict=True):
        b.plot(run.t, run[f"{axis}_dac_volts"], color=colour, lw=1, label=f"{axis} (emulator)")
        b.plot(run.t, volts[axis], "k--", lw=0.8)
    b.set(title="Photo 2: D/A voltage, closed loop (dashed: model)", xlabel="time (s)",
          ylabel="volts")
    b.legend(fontsize=8)
    sec.figure = _save(fig, out, "accel.png")
    return sec


# -- experiment 2: maximum step rates ---------------------------------------------------------


def _rates(runs: dict[str, RunData], specs: dict) -> Section:
    sec = Section(2, "Maximum step rates at a 1 MHz clock", ("rates",))
    probes = runs["rates"].probes
    clock = MACHINE["post"].clock_hz
    blocks = {name: block for name, block, _, _ in specs["rates"].blocks}
    for name, paper, tolerance in (("linear", PAPER_RATE_LINEAR, 0.015),
                                   ("circular", PAPER_RATE_CIRCULAR, 0.005)):
        rate = probes[f"{name}_steps"] / probes[f"{name}_cycles"] * clock
        running = probes[f"{name}_busy"] and probes[f"{name}_overrun"]
        _row(sec, f"{name} interpolation, FP offered every cycle",
             f"{paper / 1e3:.1f} K/sec",
             f"{rate / 1e3:.2f} k steps/s ({probes[f'{name}_steps']} steps in "
             f"{probes[f'{name}_cycles']} cycles; one step per {blocks[name].latency} cycles)",
             f"within {100 * tolerance:g}%; K3701 busy and FP in surplus (OVERRUN set)",
             abs(rate - paper) <= tolerance * paper and running)
    sec.text += [
        "The paper gives the K3701's maximum feed-pulse rates at CP = 1 MHz: 90.0 K/sec for "
        "linear and 47.6 K/sec for circular interpolation. The emulator measures them on the "
        "gateware inside the simulated machine (the post-interpolation build, whose K3701 "
        "takes FP straight from the rate multiplier): the feed path is opened completely "
        "(rate-multiplier clock at every cycle, word and budget at their maximum), so an FP "
        "is offered in all but one of 2^18 cycles, and the steps are counted on the K3701's "
        "step outputs over a window inside a long X line and inside the first octant of a "
        "circle of radius 100000 LSB, sqrt(2) control off.",
        "The SPEC reads the paper's figures as one step per 11 cycles (linear, 90.9 k/s; the "
        "paper prints 90.0) and per 21 cycles (circular, 47.6 k/s); the surplus FP are lost "
        "and flagged by the OVERRUN status bit, never silently.",
    ]
    return sec


# -- experiment 3: FP counts of arcs (Table 1) -----------------------------------------------

#: Radii of the Table 1 check: every step of a quarter circle is compared.
TABLE1_RADII = (100, 1000, 10_000)


def quarter_counts(radius: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Angle (rad) after each step of a CCW quarter circle from the x axis, and the exact FP
    counts to that point with sqrt(2) control off and on (the reference model's path)."""
    path = make_path(Block.arc(0, 0, -radius, 0))
    angles, n, diag = [], [], []
    steps = diagonal = 0
    while path.x > 0:
        step, _, _ = path.advance()
        steps += 1
        diagonal += step.dx != 0 and step.dy != 0
        angles.append(math.atan2(path.y, path.x))
        n.append(steps)
        diag.append(diagonal)
    n_arr, d_arr = np.array(n), np.array(diag)
    return np.array(angles), n_arr, n_arr + (d_arr + 1) // 2


def _table1(runs: dict[str, RunData], out: Path) -> Section:
    sec = Section(3, "FP counts of arcs from 0 to 90 degrees (Table 1)", ("pre_circle", "line"))
    plt = _plt()
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.8))
    worst = {False: 0.0, True: 0.0}
    for radius in TABLE1_RADII:
        angles, off, on = quarter_counts(radius)
        for sqrt2, counts in ((False, off), (True, on)):
            formula = np.array([table1(radius, a, sqrt2) for a in angles])
            worst[sqrt2] = max(worst[sqrt2], float(np.abs(counts - formula).max()))
            label = f"sqrt(2) {'on' if sqrt2 else 'off'}"
            if radius == TABLE1_RADII[1]:
                a.plot(np.degrees(angles), counts, lw=2, alpha=0.5, label=f"{label}: exact")
                a.plot(np.degrees(angles), formula, "k--", lw=0.8)
            if radius == TABLE1_RADII[-1]:
                b.plot(np.degrees(angles), counts - formula, lw=0.6, label=label)
    a.set(title=f"FP to reach theta, R = {TABLE1_RADII[1]} (dashed: Table 1)",
          xlabel="theta (deg)", ylabel="FP")
    a.legend(fontsize=8)
    b.axhline(1, color="C3", lw=0.6)
    b.axhline(-1, color="C3", lw=0.6)
    b.set(title=f"exact - Table 1, R = {TABLE1_RADII[-1]}", xlabel="theta (deg)", ylabel="FP")
    b.legend(fontsize=8)
    sec.figure = _save(fig, out, "fp_counts.png")
    big = TABLE1_RADII[-1]
    _, off, on = quarter_counts(big)
    for sqrt2, label, at90, counts in ((False, "off", "sqrt(2) R", off),
                                       (True, "on", "(1 + sqrt(2)/2) R", on)):
        _row(sec, f"sqrt(2) control {label}: exact count vs corrected Table 1, every step",
             f"Table 1 (90 deg: {at90} = {table1(big, math.pi / 2, sqrt2):.1f} at "
             f"R = {big})",
             f"largest difference {worst[sqrt2]:.2f} FP over R = "
             f"{', '.join(map(str, TABLE1_RADII))}; {counts[-1]} FP at 90 deg, R = {big}",
             "within 1 FP", worst[sqrt2] <= 1.0)
    used = [(key, runs[key].report["blocks"][0]) for key in ("pre_circle", "line")]
    exact = all(b["fp_pulses"] == b["fp_budget"] and runs[k].report["status"] == "ok"
                for k, b in used)
    _row(sec, "the gateware K3701 ends its block on exactly the counted FP",
         "the host must compute the exact count (section 2 (2))",
         "; ".join(f"{k}: budget {b['fp_budget']}, received {b['fp_pulses']}, ended"
                   for k, b in used),
         "exact (0 FP)", exact)
    sec.text += [
        "Table 1 of the paper gives the FP a circular block needs from the x axis through "
        "theta; its printed formulas are garbled, and the SPEC's corrected Table 1 is checked "
        "here against the exact count of the K3701 reference model (N_long, plus "
        "ceil(N_diag / 2) with sqrt(2) control) at every step of a quarter circle. The "
        "reference model is proven equal to the gateware cycle by cycle in "
        "`tests/test_k3701.py`; the last row checks the gateware directly: under FP control "
        "the block ends only when the K3701 has received the count the firmware computed, "
        "so the full circle and the line of the closed-loop runs (experiments 4 and 5) "
        "ending with the budget exactly spent is the count confirmed on the chip.",
    ]
    return sec


# -- experiments 4 and 5: path error, and the paths under FP control -------------------------


@dataclass
class _Circle:
    """A circular run seen around its centre (the program starts at the origin, centre at
    (-R, 0)): unwrapped angle (deg), radial error (LSB), and a model's radial error."""

    run: _Run
    radius: int
    angle: np.ndarray
    radial: np.ndarray
    model: np.ndarray

    @property
    def worst(self) -> float:
        return float(np.abs(self.radial).max())

    def quadrant_worst(self) -> list[float | None]:
        """The largest |radial error| in each quadrant around the centre (None: not visited)."""
        q = (np.floor(np.mod(self.angle, 360) / 90)).astype(int)
        return [float(np.abs(self.radial[q == k]).max()) if (q == k).any() else None
                for k in range(4)]


def _around(radius: int, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    angle = np.degrees(np.unwrap(np.arctan2(y, x + radius)))
    return angle, np.hypot(x + radius, y) - radius


def _lagged_circle(run: _Run, spec: RunSpec, machine: MachineConfig) -> _Circle:
    """A post-interpolation run with its model: the K3701's ideal command at the feed's FP
    rate, each axis through its own first-order lag (tau) and then its servo."""
    item = _arc_of(spec)
    radius = -item.i
    cx, cy = ideal_command(item.block, fp_rate(machine, run.block["feed_word"]), run.t)
    tau = hardware_tau(machine)
    px = servo(run.t, lag(run.t, cx, tau), SERVO.kp, SERVO.tm)
    py = servo(run.t, lag(run.t, cy, tau), SERVO.kp, SERVO.tm)
    angle, radial = _around(radius, run["x_actual"], run["y_actual"])
    return _Circle(run, radius, angle, radial, _around(radius, px, py)[1])


def _servo_circle(run: _Run, radius: int) -> _Circle:
    """An FP-control run with the servo's steady-state radius loss at the measured speed."""
    w = max(1, round(0.005 / (run.t[1] - run.t[0])))
    x, y = run["x_actual"], run["y_actual"]
    speed = np.zeros(len(x))
    speed[w:-w] = np.hypot(x[2 * w:] - x[:-2 * w], y[2 * w:] - y[:-2 * w]) / (
        run.t[2 * w:] - run.t[:-2 * w])
    model = -np.array([servo_radius_loss(radius, v, SERVO.kp, SERVO.tm) for v in speed])
    angle, radial = _around(radius, x, y)
    return _Circle(run, radius, angle, radial, model)


def _circles(runs: dict[str, RunData], specs: dict) -> dict[str, _Circle]:
    clock = MACHINE["pre"].clock_hz
    return {
        "post_high": _lagged_circle(_Run(runs["post_high"], clock), specs["post_high"],
                                    MACHINE["post"]),
        "post_low": _lagged_circle(_Run(runs["post_low"], clock), specs["post_low"],
                                   MACHINE["post"]),
        "pre_circle": _servo_circle(_Run(runs["pre_circle"], clock),
                                    -_arc_of(specs["pre_circle"]).i),
    }


def _arc_of(spec: RunSpec) -> Arc:
    item = spec.job().program.items[0]
    if not isinstance(item, Arc):
        raise TypeError(f"run {spec.key} is not an arc")
    return item


def _path_error(circles: dict[str, _Circle], scale: Scale, out: Path) -> Section:
    sec = Section(4, "Circular path error (Photos 3 and 4, and FP control)",
                  ("post_high", "post_low", "pre_circle"))
    high, low, pre = circles["post_high"], circles["post_low"], circles["pre_circle"]
    machine = MACHINE["post"]
    f_high, f_low = fp_rate(machine, FEED_HIGH), fp_rate(machine, FEED_LOW)
    worst_q = high.quadrant_worst()
    quads = ", ".join(f"Q{k + 1} {'-' if v is None else f'{v:.0f}'}"
                      for k, v in enumerate(worst_q))
    q2 = worst_q[1]
    second = ("the error-free second quadrant is not reproduced"
              if q2 is not None and q2 > 0.1 * high.worst else
              "the second quadrant shows little error, as in the paper")
    _row(sec, f"post-interpolation accel/decel, feed word {FEED_HIGH} (Photo 3)",
         "path error in quadrants 1, 3 and 4 (not 2); in quadrant 1 the curve runs past the "
         "quadrant",
         f"{high.worst:.0f} LSB = {_pct(high.worst / high.radius)} of R = {high.radius} "
         f"(worst per quadrant: {quads} LSB): {second}",
         f"more than 10x the FP-control error ({pre.worst:.1f} LSB)",
         high.worst > 10 * pre.worst)
    model_worst = float(np.abs(high.model).max())
    _row(sec, "... which is each axis's own exponential lag",
         "a race between the accel/decel input and the position controller's input when the "
         "long axis changes (the paper's explanation)",
         f"{high.worst:.0f} LSB vs {model_worst:.0f} LSB for two independent first-order lags "
         f"(tau) plus the servo, fed the K3701's ideal steps",
         "within 5%", abs(high.worst - model_worst) <= 0.05 * model_worst)
    rel_high, rel_low = high.worst / high.radius, low.worst / low.radius
    _row(sec, f"post-interpolation accel/decel, feed word {FEED_LOW} (Photo 4)",
         "far less path error at the low feed",
         f"{low.worst:.1f} LSB = {_pct(rel_low)} of R = {low.radius} (model "
         f"{np.abs(low.model).max():.1f} LSB)",
         f"relative error below 1/10 of the high feed's ({_pct(rel_high)})",
         rel_low < 0.1 * rel_high)
    peak = float(np.abs(pre.model).max())
    misfit = float(np.abs(pre.radial - pre.model).max())
    _row(sec, f"pre-interpolation accel/decel (FP control), feed word {FEED_HIGH}",
         "no path error",
         f"{pre.worst:.1f} LSB inward at the top speed = the servo's steady-state loss "
         f"R (1 - |G(jw)|) = {peak:.1f} LSB; every sample within {misfit:.1f} LSB of it",
         f"every sample within 10% of {peak:.1f} LSB + 1.5 LSB (encoder count) of "
         f"R (1 - |G(jw)|) at its speed", misfit <= 0.1 * peak + 1.5)
    sec.text += [
        f"The paper ran the same circle with the accel/decel circuit after the interpolator "
        f"(one per axis) at the feeds {FEED_HIGH} and {FEED_LOW} (Photos 3 and 4): at the high "
        f"feed the path error was plain in every quadrant but the second, and in the first "
        f"quadrant the curve ran on past the quadrant; at the low feed the error was far "
        f"smaller; with the circuit before the interpolator (FP control) there was none.",
        f"The emulator runs a full CCW circle of R = {high.radius} LSB at the feed word "
        f"{FEED_HIGH} ({f_high:.0f} FP/s) on the post- and the pre-interpolation machines, and "
        f"a {scale.low_sweep} degree arc of R = {low.radius} LSB at the word {FEED_LOW} "
        f"({f_low:.1f} FP/s) on the post machine: a full circle of R = {high.radius} at "
        f"{f_low:.0f} FP/s would take {high.run.block['fp_budget'] / f_low:.0f} s of machine "
        f"time. The "
        f"small radius makes the low feed's error larger, not smaller (the lag's radius loss "
        f"grows as (v tau / R)^2), so the small arc is the harder test of the paper's claim.",
        f"What the emulator shows: the post-interpolation error is large and systematic. The "
        f"K3701 commands a perfect circle; each axis's circuit delays its own coordinate by a "
        f"first-order lag of tau = 300 ms, far longer than the {high.radius / f_high:.2f} s a "
        f"radian takes, so the commanded path cuts inside, spirals in and, after the K3701 has "
        f"finished, closes on the end point from below the x axis. The error is that of two "
        f"independent lags to within a fraction of a percent (row 4b), with no race between "
        f"pulses: the circuit's input separation never loses or doubles a pulse (SPEC section "
        f"5). A lag's error is tied to the start point, not to fixed quadrants: it builds up "
        f"from zero where the circle starts, and the path closes on the end point from the "
        f"quadrant before it. This circle starts on the positive x axis, so {second}. The "
        f"paper does not say where its circle started or how large it was; one started at the "
        f"top, and large against v tau = {f_high * hardware_tau(machine):.0f} LSB, would show "
        f"the least error in the second quadrant and close on its end through the first, "
        f"which may be what Photo 3 shows; the emulator cannot confirm it.",
        "Under FP control the path keeps its shape: what remains is the servo's own radius "
        "loss R (1 - |G(jw)|), w = v / R, inward and growing with the square of the speed, the "
        "same on every backend of this emulator and on any real machine with this servo.",
    ]
    plt = _plt()
    fig, axes = plt.subplots(2, 3, figsize=(12, 7.5))
    titles = {"post_high": f"Photo 3: post, word {FEED_HIGH}",
              "post_low": f"Photo 4: post, word {FEED_LOW}",
              "pre_circle": f"FP control, word {FEED_HIGH}"}
    limit = 100 * max(abs(c.radial / c.radius).max() for c in circles.values()) * 1.1
    for col, (key, c) in enumerate(circles.items()):
        a = axes[0][col]
        t = np.linspace(0, math.radians(360 if key != "post_low" else scale.low_sweep), 400)
        a.plot(c.radius * np.cos(t) - c.radius, c.radius * np.sin(t), color="0.7", lw=3)
        a.plot(c.run["x_actual"], c.run["y_actual"], lw=1)
        a.set(title=titles[key], xlabel="x (LSB)", ylabel="y (LSB)")
        a.set_aspect("equal", adjustable="datalim")
        b = axes[1][col]
        b.plot(c.angle, 100 * c.radial / c.radius, lw=1, label="emulator")
        b.plot(c.angle, 100 * c.model / c.radius, "k--", lw=0.8,
               label="model" if key != "pre_circle" else "R (1 - |G(jw)|)")
        b.set(ylim=(-limit, limit / 4), xlabel="angle around the centre (deg)",
              ylabel="radial error (% of R)")
        b.legend(fontsize=8)
    fig.suptitle("Actual path (grey: programmed) and radial error on one scale")
    sec.figure = _save(fig, out, "path_error.png")
    return sec


def _fp_control(runs: dict[str, RunData], circles: dict[str, _Circle], specs: dict,
                out: Path) -> Section:
    sec = Section(5, "Linear and circular paths under FP control (Photos 5 and 6)",
                  ("line", "pre_circle"))
    run = _Run(runs["line"], MACHINE["pre"].clock_hz)
    item = specs["line"].job().program.items[0]
    assert isinstance(item, Line)
    xe, ye = item.end
    x, y = run["x_actual"], run["y_actual"]
    along = (x * xe + y * ye) / math.hypot(xe, ye)
    off = (x * ye - y * xe) / math.hypot(xe, ye)
    final = runs["line"].report["axes"]
    at_end = [final[a]["actual"] for a in AXES] == [xe, ye]
    _row(sec, "linear interpolation (Photo 5)", "a straight line",
         f"largest distance from the programmed line {np.abs(off).max():.2f} LSB; ends at "
         f"({final['x']['actual']}, {final['y']['actual']})",
         f"within 2 LSB (0.5 LSB of the steps' staircase + 1 encoder count); ends at "
         f"({xe}, {ye}) exactly", np.abs(off).max() <= 2 and at_end)
    circle = circles["pre_circle"]
    axes = runs["pre_circle"].report["axes"]
    closed = all(axes[a][k] == 0 for a in AXES for k in ("command", "actual", "error"))
    ends = ", ".join(f"{a}: command {axes[a]['command']}, actual {axes[a]['actual']}, error "
                     f"{axes[a]['error']}" for a in AXES)
    _row(sec, "circular interpolation (Photo 6)", "a circle",
         f"ends {ends}; radial error only the servo's ({circle.worst:.1f} LSB, row 4d)",
         "closes exactly at its start (0, 0)", closed)
    sec.text += [
        "Photos 5 and 6 show a line and a circle run under FP control. The emulator's are the "
        f"line of experiment 1 ({xe}, {ye}) LSB and the FP-control circle of experiment 4. "
        "Both axes have the same servo, so the lag of the servo runs along the line and "
        "takes nothing off it; the circle loses only the servo's steady-state radius (shown "
        "magnified here).",
    ]
    plt = _plt()
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.8))
    a.plot(along, off, lw=0.6)
    a.set(title=f"Photo 5: distance from the line to ({xe}, {ye})",
          xlabel="position along the line (LSB)", ylabel="LSB", ylim=(-2.5, 2.5))
    b.plot(circle.angle, circle.radial, lw=0.8, label="emulator")
    b.plot(circle.angle, circle.model, "k--", lw=0.8, label="R (1 - |G(jw)|) at its speed")
    b.set(title=f"Photo 6: radial error, R = {circle.radius}", xlabel="angle (deg)",
          ylabel="LSB")
    b.legend(fontsize=8)
    sec.figure = _save(fig, out, "fp_control.png")
    return sec


# -- experiment 6: the FP-budget hazard ------------------------------------------------------


def _budget(runs: dict[str, RunData], specs: dict, scale: Scale, out: Path) -> Section:
    sec = Section(6, "The FP-budget hazard: a budget one too high and one too low",
                  ("hazard_exact", "hazard_plus", "hazard_minus"))
    machine = MACHINE["pre"]
    item = specs["hazard_exact"].job().program.items[0]
    need, end = item.plan.fp, item.end[0]
    tau, fa_per_x = hardware_tau(machine), 1 / hardware_tau(machine)
    exact, plus, minus = (runs[k] for k in sec.runs)
    eb, pb = (r.report["blocks"][0] for r in (exact, plus))
    clock = machine.clock_hz

    left_exact = eb["fp_budget"] - eb["fp_pulses"]
    _row(sec, f"exact budget ({need} FP, X line of {end} LSB)",
         "the host computes the interpolator's exact count",
         f"block ends with the circuit empty ({left_exact} FP left, output 0 FP/s); "
         f"{eb['fp_pulses']} FP received; X at {exact.report['axes']['x']['actual']}",
         "exact", left_exact == 0 and eb["fp_pulses"] == need
         and exact.report["axes"]["x"]["actual"] == end)

    left = pb["fp_budget"] - pb["fp_pulses"]
    early = (eb["end_cycle"] - pb["end_cycle"]) / clock
    late_fp = plus.probes["fp_total"] - pb["fp_pulses"]
    _row(sec, "budget one too high",
         "too many FP: the interpolator stops while the feed is still running",
         f"block ends {1e3 * early:.0f} ms earlier with {left} FP still in the circuit "
         f"(its output still {left * fa_per_x:.1f} FP/s, not 0); that FP reaches the idle "
         f"K3701 {1e3 * (plus.probes['drained_cycle'] - pb['end_cycle']) / clock:.0f} ms "
         f"later ({late_fp} FP) and is ignored: {plus.probes['x_steps']} steps, X command "
         f"{plus.probes['x_command']}",
         "exact counts", left == 1 and late_fp == 1 and plus.probes["x_steps"] == need
         and plus.report["status"] == "ok")

    waited = (minus.report["cycles"] - eb["end_cycle"]) / clock
    _row(sec, "budget one too low",
         "too few FP: the block never ends",
         f"{waited / tau:.1f} tau after the exact run's end: status {minus.report['status']}, "
         f"K3701 BUSY = {minus.probes['busy']}, remaining distance Xm = "
         f"{minus.probes['remaining_x']}, X command {minus.probes['x_command']} (one step short "
         f"of {end}); all {minus.probes['fp_total']} FP delivered",
         "exact counts", minus.report["status"] == "timeout" and minus.probes["busy"] == 1
         and minus.probes["remaining_x"] == 1 and minus.probes["x_command"] == end - 1
         and minus.probes["fp_total"] == need - 1)
    sec.text += [
        "The paper warns that under FP control the host's count of the FP a block needs must "
        "equal the interpolator's; the SPEC (section 7) spells out the two ways it goes wrong. "
        f"The emulator runs an X line of {end} LSB at F{scale.hazard_fp_s * 60 * machine.lsb_mm:g} "
        f"({fp_rate(machine, eb['feed_word']):.0f} FP/s) three times, with "
        f"the firmware's exact budget and with the budget one too high and one too low "
        f"(`RunOptions(budget_offset=+-1)`).",
        f"One FP too many: the K3701 ends its block when it has its {need} FP, while the "
        f"accel/decel circuit still holds one; at that point the circuit would still emit "
        f"x fa / 2^n = {fa_per_x:.1f} FP/s. The axis is already at its end point, so the harm "
        f"is the stray FP: it arrives later, when the K3701 is idle (ignored) or, in a "
        f"program, already running the next block, which then starts one FP early. With a "
        f"budget k too high the circuit holds k FP at the end and the rate is k / tau: the "
        f"'stops while the feed is still high' of the SPEC needs k comparable to fi tau "
        f"({fp_rate(machine, eb['feed_word']) * tau:.0f} FP here).",
        "One FP too few: the circuit drains completely and the K3701 waits for its last FP "
        "forever, BUSY, one step short of the end point; the firmware's interrupt never "
        "comes and the program hangs (the run stops at its cycle limit).",
    ]
    plt = _plt()
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.6), sharey=True)
    for a, (name, run) in zip(axes, (("exact", exact), ("+1", plus), ("-1", minus)),
                              strict=True):
        r = _Run(run, clock)
        budget = r.block["fp_budget"]
        a.plot(r.t, need - r["fp_total"], lw=1.2, label="FP the K3701 still needs")
        a.plot(r.t, budget - r["fp_total"], "--", lw=1.2,
               label="FP still to come (budget - delivered)")
        if r.block["end_cycle"] is not None:
            a.axvline(r.seconds(r.block["end_cycle"]), color="C3", lw=0.8)
        a.set_yscale("symlog", linthresh=1)
        a.set(title=f"budget {name}: {budget} FP ({r.data.report['status']})",
              xlabel="time (s)")
    axes[0].set_ylabel("FP")
    axes[0].legend(fontsize=8)
    fig.suptitle("FP left, as the accel/decel circuit drains (red: the block ends)")
    sec.figure = _save(fig, out, "budget.png")
    return sec


# -- the whole reproduction -------------------------------------------------------------------

#: The experiment each run belongs to (its wall time is counted there).
RUN_USE = {"line": "1, 3, 5", "rates": "2", "pre_circle": "3, 4, 5", "post_high": "4",
           "post_low": "4", "hazard_exact": "6", "hazard_plus": "6", "hazard_minus": "6"}


def reproduce(out: Path, *, quick: bool = False, jobs: int = 2,
              progress: Callable[[str], None] | None = None) -> Reproduction:
    """Run every experiment, write the figures and ``report.md`` into ``out``.

    ``quick`` runs the smaller :data:`QUICK` scale (for CI); ``jobs`` is the number of worker
    processes for the closed-loop runs.
    """
    scale = QUICK if quick else FULL
    start = time.perf_counter()
    runs = run_all(scale, jobs, progress)
    return analyse(runs, scale, out, start)


def analyse(runs: dict[str, RunData], scale: Scale, out: Path,
            start: float | None = None) -> Reproduction:
    """The sections of the report from the runs of :func:`run_all`; writes ``out``.

    ``start``: the ``time.perf_counter()`` at which the runs began (for the run time).
    """
    out.mkdir(parents=True, exist_ok=True)
    specs = run_specs(scale)
    model_start = time.perf_counter()
    circles = _circles(runs, specs)
    sections = [_accel(runs, specs, out), _rates(runs, specs), _table1(runs, out),
                _path_error(circles, scale, out), _fp_control(runs, circles, specs, out),
                _budget(runs, specs, scale, out)]
    end = time.perf_counter()
    result = Reproduction(scale, sections, runs, end - (model_start if start is None else start),
                          end - model_start)
    (out / "report.md").write_text(report_markdown(result))
    return result


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def table_markdown(result: Reproduction) -> str:
    """The report's table: one row per observation, with its experiment and figure."""
    lines = ["| # | observation | paper | emulator | tolerance | pass |",
             "|---|---|---|---|---|---|"]
    for sec in result.sections:
        for k, row in enumerate(sec.rows):
            number = f"{sec.number}{'abcdefgh'[k]}"
            lines.append(f"| {number} | {_cell(row.what)} | {_cell(row.paper)} | "
                         f"{_cell(row.emulator)} | {_cell(row.tolerance)} | "
                         f"{'pass' if row.passed else '**FAIL**'} |")
    return "\n".join(lines) + "\n"


def _scaled_down(scale: Scale) -> list[str]:
    machine = MACHINE["pre"]
    specs = run_specs(scale)
    f_high, f_low = fp_rate(machine, FEED_HIGH), fp_rate(machine, FEED_LOW)
    line_fp = specs["line"].job().program.items[0].plan.fp
    low_fp = _arc_of(specs["post_low"]).plan.fp
    circle_fp = _arc_of(specs["post_high"]).plan.fp
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
        f"- experiment 2: {scale.rate_steps} steps counted per interpolation type.",
    ]


def report_markdown(result: Reproduction) -> str:
    """``report.md``: the table, then each experiment with its text and figure, then timing."""
    scale = result.scale
    lines = ["# Reproducing the paper on the emulator", "",
             f"Written by `k37 reproduce{' --quick' if scale is QUICK else ''}`: "
             f"{sum(r.passed for r in result.rows)} of {len(result.rows)} rows pass. Each row "
             f"compares an observation of the paper (its photos, section 2 and Table 1) with "
             f"what the emulator does, within the tolerance given; the experiments ran on the "
             f"compiled (CXXRTL) backend of the whole machine: chipset gateware, 8085 firmware "
             f"model and servo plants.", "", table_markdown(result)]
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
              f"time (builds: one per accel placement, compiled in parallel and cached under "
              f"`~/.cache/k37`; a cached build still converts the design, a few seconds). The "
              f"analysis and figures took {result.model_seconds:.0f} s.", "",
              "| run | experiments | machine cycles | wall (s) |", "|---|---|---|---|"]
    for key, data in result.runs.items():
        cycles = data.report.get("cycles")
        lines.append(f"| {key} | {RUN_USE.get(key, 'all')} | "
                     f"{f'{cycles:,}' if cycles else '-'} | {data.seconds:.1f} |")
    return "\n".join(lines) + "\n"
