"""Reference model of :class:`k37.sim.machine.two_mass.TwoMassDrive`: its fixed-point update, and
the drive's parameters and their fixed-point encoding (:class:`TwoMassParams`).

The feed drive of the profile-error paper's Fig. 1 as two masses: the motor's side (rotor,
coupling and ball screw, inertia J = ``ja``) and the table (mass M), joined by the ball screw's
axial stiffness Ks and damping c through the lead p (R = p / 2 pi). Seen along the feed, the motor's
side is the mass M' = J / R^2. Both are counted in encoder counts: the table's position in the
counts the motor turns to reach it (``counts_per_rev`` per lead), the spring's deflection s as
the motor's position less the table's. Per cycle, after the torque drive's velocity loop
(:class:`k37.sim.machine.torque_drive_model.TorqueDriveModel`: vm' = vm + loop torque - D term):

    fm = round((s * ks_m + (vm - vt) * cs_m) / 2^SPRING_FRAC)     ks_m = Ks / M' dt^2
    ft = round((s * ks_t + (vm - vt) * cs_t) / 2^SPRING_FRAC)     ks_t = Ks / M  dt^2
    vm = vm' - fm                                              cs_m, cs_t: c / M', c / M dt
    vt = coulomb(vt + ft - load - load step, fc)               on the table
    s += vm - vt;  motor position += vm

(semi-implicit Euler: the spring acts on the old deflection, the positions take the new
velocities, so an undamped spring keeps its energy). Coulomb friction, the load and a load
step act on the table (given as torques at the motor, N m, as on the torque drive); viscous
friction D on the motor. The encoder reads the motor, or with ``scale`` a linear scale on the
table (the motor's position less s).

Free (the motor's side unheld) the spring rings at omega^2 = Ks (1/M + 1/M') = Ks / M_eq with
M_eq = M M' / (M + M'); the profile-error paper's eq. (1) without the screw's own mass. With the
motor held, at omega^2 = Ks / M, its eq. (3).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from k37.hdl.common.params import Limit
from k37.sim.machine.plant_model import COUNT_BITS, FRAC_BITS, POSITION_BITS, VC_BITS, wrap
from k37.sim.machine.torque_drive_model import (
    DEFAULT_SERVO,
    TorqueDriveModel,
    TorqueParams,
    coulomb,
)

__all__ = ["SPRING_BITS", "SPRING_FRAC", "TwoMassDriveModel", "TwoMassParams"]

#: Fraction bits of the spring and damping coefficients (Ks / M dt^2 is about 1e-6 and below).
SPRING_FRAC = 48
#: Width of the coefficient ports: each below 2^-8 per cycle (a natural frequency below
#: clock / 100).
SPRING_BITS = 40


@dataclass(frozen=True)
class TwoMassParams(TorqueParams):
    """The two-mass drive's physical values: the torque drive's (``ja``: the motor's side only,
    rotor, coupling and screw; ``fc`` and ``load`` act on the table, as torques at the motor)
    and ``mass`` (the table M, kg), ``ks`` (axial stiffness, N/m), ``cs`` (its damping, N s/m),
    ``lead`` (m per revolution) and ``scale`` (the encoder reads the table)."""

    mass: float = DEFAULT_SERVO.mass
    ks: float = DEFAULT_SERVO.ks
    cs: float = DEFAULT_SERVO.cs
    lead: float = DEFAULT_SERVO.lead
    scale: bool = DEFAULT_SERVO.scale

    @staticmethod
    def limits() -> dict[str, Limit]:
        positive = Limit(0, low_open=True)
        return {**TorqueParams.limits(), "mass": positive.scaled(1, "kg"),
                "ks": positive.scaled(1, "N/m"), "cs": Limit(0, unit="N s/m"),
                "lead": positive.scaled(1, "m")}

    def __post_init__(self) -> None:
        for name in ("mass", "ks", "cs", "lead"):
            self.limits()[name].check(name, getattr(self, name))
        super().__post_init__()
        for name, word in (("ks / mass", self.ks_t), ("ks / (ja / R^2)", self.ks_m),
                           ("cs / mass", self.cs_t), ("cs / (ja / R^2)", self.cs_m)):
            if word >= 1 << SPRING_BITS:
                raise ValueError(f"{name} is too large for the clock (the two-mass drive's "
                                 f"natural frequency must stay below clock_hz / 100)")

    @property
    def radius(self) -> float:
        """R = lead / 2 pi (m/rad)."""
        return self.lead / (2 * math.pi)

    @property
    def motor_mass(self) -> float:
        """M' = J / R^2: the motor's side as a mass along the feed (kg)."""
        return self.ja / self.radius ** 2

    @property
    def reduced_mass(self) -> float:
        """M_eq = M M' / (M + M') (kg)."""
        return self.mass * self.motor_mass / (self.mass + self.motor_mass)

    @property
    def free_hz(self) -> float:
        """The natural frequency with the motor's side free: sqrt(Ks / M_eq) / 2 pi (Hz)."""
        return math.sqrt(self.ks / self.reduced_mass) / (2 * math.pi)

    @property
    def held_hz(self) -> float:
        """The natural frequency with the motor held: sqrt(Ks / M) / 2 pi (Hz)."""
        return math.sqrt(self.ks / self.mass) / (2 * math.pi)

    def _word(self, per_cycle: float) -> int:
        return round(per_cycle * (1 << SPRING_FRAC))

    @property
    def ks_m(self) -> int:
        return self._word(self.ks / self.motor_mass / self.clock_hz ** 2)

    @property
    def ks_t(self) -> int:
        return self._word(self.ks / self.mass / self.clock_hz ** 2)

    @property
    def cs_m(self) -> int:
        return self._word(self.cs / self.motor_mass / self.clock_hz)

    @property
    def cs_t(self) -> int:
        return self._word(self.cs / self.mass / self.clock_hz)

    def disturbance_word(self, torque: float) -> int:
        """A torque at the motor (N m) as the force torque / R on the table, in the table's
        velocity change per cycle, counts/cycle << FRAC_BITS."""
        per_s2 = torque / self.radius / self.mass * self.counts_per_rev / self.lead
        return round(per_s2 / self.clock_hz ** 2 * (1 << FRAC_BITS))

    def ports(self) -> dict[str, int]:
        """The drive's parameter inputs, by port name: the torque drive's and the spring's
        (:class:`k37.sim.machine.two_mass.TwoMassDrive`)."""
        return {**super().ports(), "ks_m": self.ks_m, "ks_t": self.ks_t, "cs_m": self.cs_m,
                "cs_t": self.cs_t, "scale": int(self.scale)}


@dataclass
class TwoMassDriveModel(TorqueDriveModel):
    """The torque drive's model with the spring and the table; ``deflection`` (s) and
    ``table_velocity`` (vt) are its extra registers, ``velocity`` and ``position`` the
    motor's."""

    ks_m: int = 0
    ks_t: int = 0
    cs_m: int = 0
    cs_t: int = 0
    scale: int = 0
    deflection: int = 0
    table_velocity: int = 0

    @property
    def count(self) -> int:
        position = self.position - self.deflection if self.scale else self.position
        return wrap(wrap(position, POSITION_BITS) >> FRAC_BITS, COUNT_BITS)

    def cycle(self, dac: int, stall: bool = False, com: int = 0) -> None:
        s, vm, vt = self.deflection, self.velocity, self.table_velocity
        half = 1 << (SPRING_FRAC - 1)
        fm = (s * self.ks_m + (vm - vt) * self.cs_m + half) >> SPRING_FRAC
        ft = (s * self.ks_t + (vm - vt) * self.cs_t + half) >> SPRING_FRAC
        vm1 = wrap(self.loop_velocity(dac, com) - fm, VC_BITS + 4)
        vt1 = wrap(vt + ft - self.disturbance(), VC_BITS + 4)
        vt1 = coulomb(vt1, self.fc)
        self.velocity = 0 if stall else wrap(vm1, VC_BITS + 1)
        self.table_velocity = 0 if stall else wrap(vt1, VC_BITS + 1)
        self.deflection = wrap(s + self.velocity - self.table_velocity, POSITION_BITS)
        self.position = wrap(self.position + self.velocity, POSITION_BITS)
