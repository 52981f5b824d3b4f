"""The companion papers' physics on the whole machine (compiled backend): the radius loss of
a circle under post-interpolation accel/decel (the motion-errors paper), the ellipse of a gain or
time-constant mismatch between the axes (the motion-errors and profile-error papers), and the
profile-error paper's eq. (9) following error with velocity feedforward and viscous friction, and
the ringing of its two-mass feed drive. Each measured figure is compared with its formula."""

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from k37.sim.machine.servo import load_step_fault, torque_params
from k37.sim.reproduce.theory import (
    accel_gain,
    following_error,
    hardware_tau,
    mismatch_amplitude,
    servo_gain,
)
from k37.sim.run.ballbar import ballbar
from k37.sim.run.jobfile import load_job
from k37.sim.run.runner import RunOptions, run_job
from k37.sim.run.sampler import TRACE_COLUMNS

pytestmark = pytest.mark.slow


def run_toml(tmp_path: Path, text: str):
    path = tmp_path / "job.toml"
    path.write_text(text)
    result = run_job(load_job(path), RunOptions(backend="cxxrtl", sample_every=500))
    assert result.report["status"] == "ok", result.report["reason"]
    return result


def circles(tmp_path: Path, machine: str, servo: str, radius_mm: float, feed: float,
            turns: int, settle_s: float):
    """``turns`` CCW circles from (0, 0) about (-R, 0); returns, over one revolution of the
    actual position from ``settle_s`` into the second circle: the angle (rad, unwrapped), the
    radial deviation from R (LSB) and the measured angular speed w (rad/s)."""
    program = f"G21 G91 F{feed:g}\n" + f"G03 I{-radius_mm:g} J0\n" * turns + "M30"
    result = run_toml(tmp_path, f'[machine]\nalarm_limit = 60000\n{machine}\n'
                                f'[servo]\n{servo}\n[program]\ngcode = """\n{program}\n"""\n')
    t = result.traces
    clock = result.report["clock_hz"]
    radius = radius_mm * 1000
    x, y = t["x_actual"] + radius, t["y_actual"]
    angle = np.unwrap(np.arctan2(y, x))
    seconds = t["cycle"] / clock
    start = result.report["blocks"][1]["start_cycle"] / clock + settle_s
    begin = int(np.searchsorted(seconds, start))
    window = (seconds >= start) & (angle < angle[begin] + 2 * math.pi)
    assert angle[-1] > angle[begin] + 2 * math.pi, "the run must hold a whole revolution"
    measured_w = np.polyfit(seconds[window], angle[window], 1)[0]
    return angle[window], np.hypot(x, y)[window] - radius, measured_w


@pytest.mark.parametrize(("shape", "tau"), [("exponential", 0.075), ("linear", 0.15)])
def test_radius_loss_under_post_accel_decel_is_r_times_the_gains_product_minus_1(tmp_path,
                                                                                  shape, tau):
    # R 5 mm at F2000 (w = 6.67 rad/s): w tau = 0.5 (exponential), w T / 2 = 0.5 (linear).
    kp, tm = 100.0, 0.001
    _, deviation, w = circles(tmp_path, f'accel = "post"\naccel_shape = "{shape}"\n'
                                        f'accel_fa_hz = {2**15 / tau}', f"kp = {kp}\ntm = {tm}",
                              5.0, 2000.0, 4, 6 * tau)
    measured = -deviation.mean()
    expected = 5000 * (1 - accel_gain(shape, w, tau) * servo_gain(w, kp, tm))
    print(f"{shape}: radius loss {measured:.1f} LSB, formula {expected:.1f} LSB (w {w:.3f})")
    assert measured == pytest.approx(expected, rel=0.02)
    if shape == "linear":
        # The motion-errors paper's eq. (10)'s accel/decel term T^2 V^2 / (24 R) (its "2A" read as
        # 24) is the moving average's loss to second order; the filters paper's eq. (39) read as a
        # first-order recursion would lose tau^2 V^2 / (2 R), 12 times as much.
        speed = w * 5000
        accel_part = measured - 5000 * (1 - servo_gain(w, kp, tm))
        print(f"linear: accel/decel part {accel_part:.1f} LSB, T^2 V^2 / (24 R) "
              f"{tau**2 * speed**2 / (24 * 5000):.1f} LSB, tau^2 V^2 / (2 R) "
              f"{tau**2 * speed**2 / (2 * 5000):.1f} LSB")
        assert accel_part == pytest.approx(tau**2 * speed**2 / (24 * 5000), rel=0.03)


def two_theta(angle: np.ndarray, deviation: np.ndarray) -> tuple[float, float]:
    """Amplitude (LSB) and the angle (deg, in [0, 180)) of the maximum of the radial
    deviation's 2-theta component, by least squares over whole revolutions."""
    basis = np.column_stack([np.cos(2 * angle), np.sin(2 * angle), np.ones_like(angle)])
    (a, b, _), *_ = np.linalg.lstsq(basis, deviation, rcond=None)
    return math.hypot(a, b), math.degrees(math.atan2(b, a)) / 2 % 180


@pytest.mark.parametrize(("machine", "servo", "lags", "peak"), [
    # Gain mismatch: Kpx 30/s, Kpy 40/s; X lags more: the circle bulges at 45/225 deg.
    ('accel = "none"', "tm = 0.001\n[servo.x]\nkp = 30.0\n[servo.y]\nkp = 40.0",
     (1 / 30, 1 / 40), 45),
    # Time-constant mismatch: Tx 10 ms, Ty 20 ms (n 13 and 14 at one fa, 819.2 kHz): 135/315
    # deg.
    ('accel = "post"\naccel_fa_hz = 819200.0\n[machine.x]\naccel_bits = 13\n'
     '[machine.y]\naccel_bits = 14', "kp = 100.0\ntm = 0.001", (2**13 / 819200, 2**14 / 819200),
     135),
    # The profile-error paper's Table 10: Tx 26 ms, Ty 28 ms, not a power of 2 apart: n 14 on
    # both, each axis on an addition clock of its own.
    ('accel = "post"\naccel_bits = 14\n[machine.x]\naccel_fa_hz = 630153.8461538461\n'
     '[machine.y]\naccel_fa_hz = 585142.8571428572', "kp = 100.0\ntm = 0.001", (0.026, 0.028),
     135)])
def test_axis_mismatch_makes_an_ellipse_of_amplitude_v_over_2_times_the_lag_difference(
        tmp_path, machine, servo, lags, peak):
    angle, deviation, w = circles(tmp_path, machine, servo, 10.0, 1200.0, 3, 0.3)
    amplitude, at = two_theta(angle, deviation)
    expected = mismatch_amplitude(w * 10_000, *lags)
    print(f"mismatch {lags}: 2-theta amplitude {amplitude:.2f} LSB at {at:.1f} deg, formula "
          f"{expected:.2f} LSB at {peak} deg")
    assert amplitude == pytest.approx(expected, rel=0.05)
    assert abs(at - peak) < 5


def test_time_constants_of_26_and_28_ms_give_the_ballbar_ellipse_of_their_difference(tmp_path):
    # The ballbar analysis of a run (k37 run --ballbar, k37 reproduce) on two turns of R 10 mm
    # at F1200: X's exponential circuit at 2^14 / 630.15 kHz = 26 ms, Y's at 2^14 / 585.14 kHz
    # = 28 ms, the servos alike.
    program = "G21 G91 F1200\n" + "G03 I-10 J0\n" * 2 + "M30"
    result = run_toml(tmp_path, '[machine]\naccel = "post"\naccel_bits = 14\n'
                                '[machine.x]\naccel_fa_hz = 630153.8461538461\n'
                                '[machine.y]\naccel_fa_hz = 585142.8571428572\n'
                                f'[servo]\nkp = 30.0\n[program]\ngcode = """\n{program}\n"""\n')
    taus = [hardware_tau(replace(result.job.machine, accel_fa_hz=result.job.fa_hz(axis)))
            for axis in ("x", "y")]
    assert taus == pytest.approx([0.026, 0.028], abs=1e-8)
    b = ballbar(result, settle_deg=90)
    expected = mismatch_amplitude(b.path_speed, *taus)
    print(f"2-theta amplitude {b.two_theta_amplitude:.3f} LSB at {b.two_theta_angle:.1f} deg, "
          f"(V / 2) |Tx - Ty| {expected:.3f} LSB (V {b.path_speed:.0f} LSB/s)")
    assert b.two_theta_amplitude == pytest.approx(expected, rel=0.05)
    assert abs(b.two_theta_angle - 135) < 5


@pytest.mark.parametrize(("accel", "servo", "kf", "d_ratio", "ts"), [
    ('"none"', 'drive = "torque"\nkf = 0.5\nd = 0.025', 0.5, 0.25, 0.0),
    ('"none"', 'drive = "torque"\nd = 0.05', 0.0, 0.5, 0.0),
    ('"none"', "kf = 0.5\ntm = 0.005", 0.5, 0.0, 0.0),
    ('"post"\naccel_fa_hz = 436906.6666666667', 'drive = "torque"\nkf = 0.8\nd = 0.025', 0.8,
     0.25, 0.075)])
def test_steady_following_error_is_the_profile_papers_eq_9(tmp_path, accel, servo, kf, d_ratio, ts):
    # An X line at F1200 (20,000 LSB/s), Kp 30/s; D/(Vg Kt) with Vg Kt = 0.1 N m s/rad.
    result = run_toml(tmp_path, f"[machine]\naccel = {accel}\n[servo]\nkp = 30.0\n{servo}\n"
                                f'[program]\ngcode = "G21 G91 F1200\\nG01 X40\\nM30"\n')
    t = result.traces
    seconds = (t["cycle"] - result.report["blocks"][0]["start_cycle"]) / result.report["clock_hz"]
    window = (seconds > 1.0) & (seconds < 1.9)
    # The K3701's position is its FP count (one X step per FP on a pure X line).
    measured = float(np.mean(t["fp_total"][window] - t["x_actual"][window]))
    expected = following_error(20_000, 30.0, kf=kf, d_ratio=d_ratio, ts=ts)
    print(f"Kf {kf}, D/(Vg Kt) {d_ratio}, Ts {ts}: error {measured:.1f} LSB, eq. (9) "
          f"{expected:.1f} LSB")
    assert measured == pytest.approx(expected, rel=0.02)


def test_a_load_step_on_a_two_mass_table_rings_in_the_following_error_at_sqrt_ks_over_m(
        tmp_path):
    # The profile-error paper's Table 1 X axis (a 241 kg table at about 200 Hz, 1 count = 1 um)
    # with a stiff velocity loop holding the motor and a linear scale on the table: a load step
    # during a dwell sets the table ringing at eq. (3)'s sqrt(Ks / M), in the K3702's error.
    path = tmp_path / "ring.toml"
    path.write_text('[servo.x]\ndrive = "two_mass"\nkt = 0.5\nja = 0.00533\nvg = 189.0\n'
                    'mass = 241.0\nks = 3.79e8\nlead = 0.00778\ncounts_per_rev = 7780.0\n'
                    'scale = true\n[program]\ngcode = "G04 P0.2\\nM30"\n')
    job = load_job(path)
    drive = torque_params(job.machine, job.servo["x"])
    torque = 20.0
    result = run_job(job, RunOptions(backend="cxxrtl", sample_every=20, faults={
        "x": load_step_fault(job, "x", torque, 0.05)}))
    assert result.report["status"] == "ok"
    t = result.samples[:, TRACE_COLUMNS.index("cycle")] / job.machine.clock_hz
    error = result.samples[:, TRACE_COLUMNS.index("x_error")]
    assert not error[t < 0.05].any()
    ring = error[(t > 0.055) & (t < 0.15)]
    swing = ring - ring.mean()
    up = np.flatnonzero((swing[:-1] < 0) & (swing[1:] >= 0))
    hz = (len(up) - 1) / ((up[-1] - up[0]) * 20 / job.machine.clock_hz)
    assert abs(hz / drive.held_hz - 1) < 0.02
    static_counts = torque / drive.radius / drive.ks * drive.counts_per_rev / drive.lead
    assert ring.max() - ring.min() > static_counts
