"""A servo drive with a velocity loop, motor torque, load inertia and friction (seed 003).

The drive of seed 003 (its eqs. (9)-(16)): the position loop's velocity command vc (with the
feedforward of :class:`sim.machine.plant.ServoPlant`) drives a PI velocity loop of gain Vg
(A s/rad) and integral time Ti; the motor's torque Kt i (N m) turns the load inertia Ja
(kg m^2) against viscous friction D (N m s/rad), Coulomb friction Fc (N m) and a disturbance
torque (N m, the load). Per cycle, in the plant's fixed point (velocity in counts/cycle):

    ev = vc - v
    I += ev * ki                              ki = (Kt Vg / Ja) dt^2 / Ti   (0: no integral)
    v1 = v + round((ev * alpha - v * beta) / 2^24) + I - load
                                              alpha = (Kt Vg / Ja) dt,  beta = (D / Ja) dt
    v  = v1 - clamp(v1, -fc, fc)              fc = Coulomb torque / Ja as counts/cycle^2

Coulomb friction takes up to ``fc`` from the speed each cycle and never reverses it, so an
axis whose drive torque is below it stays at rest (stiction). With Ti = 0 the steady velocity
at a command vc is vc / (1 + D / (Vg Kt)): seed 003's eq. (9) following error
``(D / (Vg Kt) + 1 - Kf) F / Kp``; an integral term removes the D part.

A load step (a fault) adds ``load_step`` to the disturbance from cycle ``load_after`` on; the
cycle counter runs only until then. The drive declares no native update for idle skipping:
while it moves, its registers change and every cycle is evaluated; at rest it is static.
"""

import math
from dataclasses import dataclass

from amaranth.hdl import Module, Mux, Signal, signed
from amaranth.lib.wiring import In

from hdl.limits import Limit
from hdl.observation import FreeRunning
from sim.machine.plant import ALPHA_BITS, FRAC_BITS, VC_BITS, ServoPlant

__all__ = ["ACCEL_BITS", "AFTER_BITS", "KI_BITS", "KI_FRAC", "TorqueDrive", "TorqueParams"]

#: Fraction bits of ki (a velocity-loop integral gain per cycle^2 is tiny: 1e-8 and below).
KI_FRAC = 40
KI_BITS = 32
#: Width of the friction and load ports: counts/cycle^2 << FRAC_BITS.
ACCEL_BITS = 40
#: Width of the load step's cycle count.
AFTER_BITS = 48
#: Fraction bits of the integrator (velocity << FRAC_BITS << KI_FRAC).
_INTEGRAL_BITS = VC_BITS + 2 + KI_FRAC + 8


@dataclass(frozen=True)
class TorqueParams:
    """The drive's physical values (see the module) and their fixed point at ``clock_hz``;
    ``counts_per_rev``: encoder counts (LSB) per motor revolution, which turns torques into
    accelerations in counts."""

    kt: float = 0.5
    ja: float = 1e-3
    vg: float = 0.2
    ti: float = 0.0
    d: float = 0.0
    fc: float = 0.0
    load: float = 0.0
    counts_per_rev: float = 10_000.0
    clock_hz: float = 1e6

    @staticmethod
    def limits() -> dict[str, Limit]:
        positive = Limit(0, low_open=True)
        return {"kt": positive.scaled(1, "N m/A"), "ja": positive.scaled(1, "kg m^2"),
                "vg": positive.scaled(1, "A s/rad"), "ti": Limit(0, unit="s"),
                "d": Limit(0, unit="N m s/rad"), "fc": Limit(0, unit="N m"),
                "load": Limit(unit="N m"), "counts_per_rev": positive.scaled(1, "counts")}

    def __post_init__(self) -> None:
        for name, limit in self.limits().items():
            limit.check(name, getattr(self, name))
        for name, rate in (("kt * vg / ja", self.rate), ("d / ja", self.d / self.ja)):
            if rate / self.clock_hz * (1 << ALPHA_BITS) >= (1 << ALPHA_BITS) - 0.5:
                raise ValueError(f"{name} = {rate:g} 1/s must be below clock_hz (the torque "
                                 f"drive's {ALPHA_BITS}-bit coefficients)")
        if self.ki >= 1 << KI_BITS:
            raise ValueError("ti is too short for the clock (ki must fit in 32 bits)")
        if self.fc_word >= 1 << ACCEL_BITS or abs(self.torque_word(self.load)) >= 1 << (
                ACCEL_BITS - 1):
            raise ValueError("fc and load must be below the drive's torque range")

    @property
    def rate(self) -> float:
        """Kt Vg / Ja (1/s): the inverse of the velocity loop's time constant (P part)."""
        return self.kt * self.vg / self.ja

    @property
    def alpha(self) -> int:
        return round(self.rate / self.clock_hz * (1 << ALPHA_BITS))

    @property
    def beta(self) -> int:
        return round(self.d / self.ja / self.clock_hz * (1 << ALPHA_BITS))

    @property
    def ki(self) -> int:
        if self.ti == 0:
            return 0
        return round(self.rate / self.clock_hz ** 2 / self.ti * (1 << KI_FRAC))

    def torque_word(self, torque: float) -> int:
        """A torque (N m) as the velocity change it makes per cycle, counts/cycle << FRAC_BITS."""
        per_s2 = torque / self.ja * self.counts_per_rev / (2 * math.pi)  # counts/s^2
        return round(per_s2 / self.clock_hz ** 2 * (1 << FRAC_BITS))

    @property
    def fc_word(self) -> int:
        return self.torque_word(self.fc)


class TorqueDrive(ServoPlant):
    """:class:`sim.machine.plant.ServoPlant` with the velocity update of the module docstring.

    Members (beyond the plant's; ``alpha`` is here Kt Vg / Ja dt << 24)
    ---------------------------------------------------------------
    beta : In(ALPHA_BITS)
        D / Ja dt << 24.
    ki : In(KI_BITS)
        The velocity loop's integral gain per cycle^2, << KI_FRAC.
    fc : In(ACCEL_BITS)
        Coulomb friction, counts/cycle^2 << FRAC_BITS.
    load, load_step : In(signed(ACCEL_BITS))
        Disturbance, and the step added to it from cycle ``load_after`` on (counts/cycle^2).
    load_after : In(AFTER_BITS)
        The cycle of the load step (counted from reset; the count stops there).

    Every register updates at the clock edge; the outputs follow one cycle after the inputs,
    as the plant's.
    """

    beta: In(ALPHA_BITS)
    ki: In(KI_BITS)
    fc: In(ACCEL_BITS)
    load: In(signed(ACCEL_BITS))
    load_step: In(signed(ACCEL_BITS))
    load_after: In(AFTER_BITS)

    #: No native update: the drive is stepped (see the module docstring).
    FREE_RUNNING = FreeRunning()

    def next_velocity(self, m: Module, vc: Signal):
        v = self.velocity
        ev = Signal(signed(VC_BITS + 2))
        m.d.comb += ev.eq(vc - v)
        integral = Signal(signed(_INTEGRAL_BITS))
        integral_next = Signal(signed(_INTEGRAL_BITS))
        m.d.comb += integral_next.eq(integral + ev * self.ki)
        m.d.sync += integral.eq(integral_next)
        elapsed = Signal(AFTER_BITS)
        stepped = Signal()
        m.d.comb += stepped.eq((self.load_step != 0) & (elapsed >= self.load_after))
        with m.If((self.load_step != 0) & ~stepped):
            m.d.sync += elapsed.eq(elapsed + 1)
        drive = Signal(signed(VC_BITS + ALPHA_BITS + 4))
        m.d.comb += drive.eq((ev * self.alpha - v * self.beta + (1 << (ALPHA_BITS - 1)))
                             .shift_right(ALPHA_BITS))
        v1 = Signal(signed(VC_BITS + 4))
        m.d.comb += v1.eq(v + drive + integral_next.shift_right(KI_FRAC) - self.load
                          - Mux(stepped, self.load_step, 0))
        return Mux(self.stall, 0, Mux(v1 > self.fc, v1 - self.fc,
                                      Mux(v1 < -self.fc, v1 + self.fc, 0)))
