"""Reference model of :class:`k37.sim.machine.torque_drive.TorqueDrive`: its fixed-point update, and
the drive's parameters and their fixed-point encoding (:class:`TorqueParams`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from k37.firmware_model.job import ServoConfig
from k37.hdl.common.constants import CHIP_HZ
from k37.hdl.common.params import Limit
from k37.sim.machine.plant_model import (
    ALPHA_BITS,
    FRAC_BITS,
    POSITION_BITS,
    VC_BITS,
    ServoPlantModel,
    wrap,
)

__all__ = ["ACCEL_BITS", "AFTER_BITS", "DEFAULT_SERVO", "INTEGRAL_BITS", "KI_BITS", "KI_FRAC",
           "TorqueDriveModel", "TorqueParams", "coulomb"]

#: The default servo: a job's, and the defaults of the drives' values.
DEFAULT_SERVO = ServoConfig()
#: Fraction bits of ki (a velocity-loop integral gain per cycle^2 is tiny: 1e-8 and below).
KI_FRAC = 40
KI_BITS = 32
#: Width of the friction and load ports: counts/cycle^2 << FRAC_BITS.
ACCEL_BITS = 40
#: Width of the load step's cycle count.
AFTER_BITS = 48
#: Fraction bits of the integrator (velocity << FRAC_BITS << KI_FRAC).
INTEGRAL_BITS = VC_BITS + 2 + KI_FRAC + 8


@dataclass(frozen=True)
class TorqueParams:
    """The drive's physical values (see the module) and their fixed point at ``clock_hz``;
    ``counts_per_rev``: encoder counts (LSB) per motor revolution, which turns torques into
    accelerations in counts. The defaults are the default servo's
    (:class:`k37.firmware_model.job.ServoConfig`)."""

    kt: float = DEFAULT_SERVO.kt
    ja: float = DEFAULT_SERVO.ja
    vg: float = DEFAULT_SERVO.vg
    ti: float = DEFAULT_SERVO.ti
    d: float = DEFAULT_SERVO.d
    fc: float = DEFAULT_SERVO.fc
    load: float = DEFAULT_SERVO.load
    counts_per_rev: float = DEFAULT_SERVO.counts_per_rev
    clock_hz: float = CHIP_HZ

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
        if self.fc_word >= 1 << ACCEL_BITS or abs(self.disturbance_word(self.load)) >= 1 << (
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

    def disturbance_word(self, torque: float) -> int:
        """A disturbance or friction torque (N m at the motor) as the drive's ``fc``, ``load``
        and ``load_step`` ports take it: here :meth:`torque_word`."""
        return self.torque_word(torque)

    @property
    def fc_word(self) -> int:
        return self.disturbance_word(self.fc)

    def ports(self) -> dict[str, int]:
        """The drive's parameter inputs, by port name
        (:class:`k37.sim.machine.torque_drive.TorqueDrive`; ``alpha`` is the plant's port)."""
        return {"alpha": self.alpha, "beta": self.beta, "ki": self.ki, "fc": self.fc_word,
                "load": self.disturbance_word(self.load)}


@dataclass
class TorqueDriveModel(ServoPlantModel):
    """The plant model with the torque drive's velocity update; ``integral`` and ``elapsed``
    are its extra registers."""

    beta: int = 0
    ki: int = 0
    fc: int = 0
    load: int = 0
    load_step: int = 0
    load_after: int = 0
    integral: int = 0
    elapsed: int = 0

    def loop_velocity(self, dac: int, com: int) -> int:
        """The velocity after the velocity loop's torque and the viscous friction, before the
        disturbance and Coulomb friction (advances the integral)."""
        v = self.velocity
        ev = self.command(dac, com * self.kf) - v
        self.integral += ev * self.ki
        drive = (ev * self.alpha - v * self.beta + (1 << (ALPHA_BITS - 1))) >> ALPHA_BITS
        return v + drive + (self.integral >> KI_FRAC)

    def disturbance(self) -> int:
        """The load and, from cycle ``load_after`` on, the load step (advances the count)."""
        stepped = self.load_step != 0 and self.elapsed >= self.load_after
        if self.load_step != 0 and not stepped:
            self.elapsed += 1
        return self.load + (self.load_step if stepped else 0)

    def cycle(self, dac: int, stall: bool = False, com: int = 0) -> None:
        v1 = self.loop_velocity(dac, com) - self.disturbance()
        v1 = coulomb(v1, self.fc)
        self.velocity = 0 if stall else wrap(v1, VC_BITS + 1)
        self.position = wrap(self.position + self.velocity, POSITION_BITS)


def coulomb(velocity: int, fc: int) -> int:
    """``velocity`` less Coulomb friction ``fc``, which never reverses it."""
    return velocity - max(-fc, min(fc, velocity))
