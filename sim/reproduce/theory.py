"""What the observations are compared with: the hardware's exact rates and the linear physics.

The accel/decel circuit is a first-order lag of the FP count (:func:`lag`, ``docs/chips/accel.md``);
each axis's closed position loop is ``G(s) = Kp / (s (1 + s Tm) + Kp)`` (:func:`servo`,
:func:`servo_radius_loss`); the K3701's commanded path and FP counts come from
its reference model (:func:`ideal_command`, :func:`quarter_counts`). Everything here is
computed independently of the emulator's runs.
"""

from __future__ import annotations

import math

import numpy as np

from k37.firmware_model.feeds import rm_clock_hz
from k37.firmware_model.job import MachineConfig
from k37.hdl.feed.map.feed_rate import DIVIDER_WIDTH, FEED_BITS
from k37.hdl.feed.rates import frequency_of, increment_for
from k37.hdl.k3701.block import Block
from k37.hdl.k3701.model.chip import make_path, walk

__all__ = ["E63", "accel_filter", "accel_gain", "following_error", "fp_rate", "hardware_tau",
           "ideal_command", "lag", "mismatch_amplitude", "moving_average", "quarter_counts",
           "servo", "servo_gain", "servo_radius_loss", "servo_response"]

#: 1 - 1/e: the fraction of the final value a first-order lag reaches after one tau.
E63 = 1 - math.exp(-1)


# -- the hardware's rates ---------------------------------------------------------------------


def fp_rate(machine: MachineConfig, word: int) -> float:
    """The mean FP rate of a feed word on the hardware (its dividers' exact increments)."""
    inc = increment_for(rm_clock_hz(machine), width=DIVIDER_WIDTH, f_clk=machine.clock_hz)
    f_in = frequency_of(inc, width=DIVIDER_WIDTH, f_clk=machine.clock_hz)
    return f_in * word / (1 << FEED_BITS)


def hardware_tau(machine: MachineConfig) -> float:
    """The accel/decel time constant 2^n / fa with the fa divider's exact increment."""
    inc = increment_for(machine.accel_fa_hz, width=DIVIDER_WIDTH, f_clk=machine.clock_hz)
    return 2**machine.accel_bits / frequency_of(inc, width=DIVIDER_WIDTH, f_clk=machine.clock_hz)


# -- the accel/decel circuit and the servo ------------------------------------------------------


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
          substeps: int = 10, kf: float = 0.0) -> np.ndarray:
    """The actual position of one axis following ``command``: G(s) = Kp / (s (1 + s Tm) + Kp).

    The servo plant (velocity command Kp x error + Kf x the command's rate,
    first-order velocity lag Tm), from rest at ``command[0]``; the command is taken as linear
    between the samples.
    """
    h = (t[1] - t[0]) / substeps
    # State (position, velocity), with the command and its rate as inputs held over each
    # substep (the last two, constant, states).
    system = np.array([[0.0, 1.0, 0.0, 0.0], [-kp / tm, -1 / tm, kp / tm, kf / tm],
                       [0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0]])
    step = _expm(system * h)
    (p11, p12, g1, r1), (p21, p22, g2, r2) = step[0], step[1]
    out = np.empty(len(command))
    p, v = float(command[0]), 0.0
    out[0] = p
    for k in range(len(command) - 1):
        c0, dc = command[k], (command[k + 1] - command[k]) / substeps
        rate = dc / h
        for j in range(substeps):
            c = c0 + (j + 0.5) * dc
            p, v = (p11 * p + p12 * v + g1 * c + r1 * rate,
                    p21 * p + p22 * v + g2 * c + r2 * rate)
        out[k + 1] = p
    return out


def moving_average(t: np.ndarray, signal: np.ndarray, window: float) -> np.ndarray:
    """``signal`` (sampled at the uniform times ``t``, linear between samples, at rest at
    ``signal[0]`` before ``t[0]``) averaged over the last ``window`` seconds: the linear
    accel/decel circuit's (moving average over T = 2^n / fa) effect on a position."""
    integral = np.concatenate(([0.0], np.cumsum((signal[1:] + signal[:-1]) / 2 * np.diff(t))))
    before = t - window
    earlier = np.where(before < t[0], (before - t[0]) * signal[0],
                       np.interp(before, t, integral))
    return (integral - earlier) / window


def accel_filter(shape: str, t: np.ndarray, signal: np.ndarray, tau: float) -> np.ndarray:
    """A position ``signal`` through a post-interpolation accel/decel circuit of ``shape``
    (exponential: :func:`lag`; linear: :func:`moving_average`; bell: both) and T = ``tau``."""
    if shape == "exponential":
        return lag(t, signal, tau)
    averaged = moving_average(t, signal, tau)
    return averaged if shape == "linear" else lag(t, averaged, tau)


def servo_response(w: float, kp: float, tm: float) -> complex:
    """G(jw) of one axis's closed position loop ``G(s) = Kp / (s (1 + s Tm) + Kp)``."""
    return kp / complex(kp - w * w * tm, w)


def servo_gain(w: float, kp: float, tm: float) -> float:
    """|G(jw)| of one axis's closed position loop (:func:`servo_response`)."""
    return abs(servo_response(w, kp, tm))


def servo_radius_loss(radius: float, speed: float, kp: float, tm: float) -> float:
    """Steady-state radius loss R (1 - |G(jw)|) of a circle followed at ``speed`` (LSB/s).

    ``G(s) = Kp / (s (1 + s Tm) + Kp)`` is one axis's closed position loop, ``w = v / R``.
    """
    return radius * (1 - servo_gain(speed / radius, kp, tm))


def accel_gain(shape: str, w: float, tau: float) -> float:
    """|G_acc(jw)| of a post-interpolation accel/decel circuit of time constant ``tau``
    (2^n / fa): the exponential's 1 / sqrt(1 + w^2 tau^2), the moving average's
    |sin(w T / 2) / (w T / 2)| (T = tau), and their product for the bell."""
    exponential = 1 / math.sqrt(1 + (w * tau) ** 2)
    linear = abs(float(np.sinc(w * tau / (2 * math.pi))))
    return {"exponential": exponential, "linear": linear, "bell": exponential * linear}[shape]


def mismatch_amplitude(speed: float, lag_x: float, lag_y: float) -> float:
    """The 2-theta amplitude of the radial deviation of a circle at ``speed`` whose axes lag
    their commands by ``lag_x`` and ``lag_y`` seconds (1/Kp of a position loop, T of an
    exponential accel/decel; the motion-errors paper): (V / 2) |lag_x - lag_y|, for small
    w * lag."""
    return speed / 2 * abs(lag_x - lag_y)


def following_error(feed: float, kp: float, *, kf: float = 0.0, d_ratio: float = 0.0,
                    ts: float = 0.0) -> float:
    """The profile-error paper's eq. (9): the steady following error (LSB) at ``feed`` (LSB/s),
    ``(D / (Vg Kt) + 1 - Kf) F / Kp + Ts F`` (``d_ratio`` = D / (Vg Kt); Ts the exponential
    accel/decel's time constant, post-interpolation)."""
    return (d_ratio + 1 - kf) * feed / kp + ts * feed


# -- the K3701's path (its reference model) -------------------------------------------------------


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
