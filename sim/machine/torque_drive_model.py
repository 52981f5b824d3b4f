"""Reference model of :class:`sim.machine.torque_drive.TorqueDrive`: its fixed-point update."""

from __future__ import annotations

from dataclasses import dataclass

from sim.machine.plant import ALPHA_BITS, POSITION_BITS, VC_BITS
from sim.machine.plant_model import ServoPlantModel, wrap
from sim.machine.torque_drive import KI_FRAC

__all__ = ["TorqueDriveModel"]


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

    def cycle(self, dac: int, stall: bool = False, com: int = 0) -> None:
        v = self.velocity
        ev = self.command(dac, com) - v
        self.integral += ev * self.ki
        stepped = self.load_step != 0 and self.elapsed >= self.load_after
        if self.load_step != 0 and not stepped:
            self.elapsed += 1
        drive = (ev * self.alpha - v * self.beta + (1 << (ALPHA_BITS - 1))) >> ALPHA_BITS
        v1 = v + drive + (self.integral >> KI_FRAC) - self.load - (self.load_step if stepped
                                                                   else 0)
        v1 = v1 - max(-self.fc, min(self.fc, v1))
        self.velocity = 0 if stall else wrap(v1, VC_BITS + 1)
        self.position = wrap(self.position + self.velocity, POSITION_BITS)
