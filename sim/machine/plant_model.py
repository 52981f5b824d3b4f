"""Reference model of :class:`sim.machine.plant.ServoPlant`: its fixed-point update, in Python."""

from __future__ import annotations

from dataclasses import dataclass

from sim.machine.plant import (
    ALPHA_BITS,
    COUNT_BITS,
    FRAC_BITS,
    POSITION_BITS,
    PRODUCT_BITS,
    VC_BITS,
    VC_MAX,
    dac_zero,
)

__all__ = ["ServoPlantModel", "wrap"]


def wrap(value: int, bits: int) -> int:
    """``value`` as a two's complement number of ``bits`` bits."""
    value &= (1 << bits) - 1
    return value - (1 << bits) if value >> (bits - 1) else value


@dataclass
class ServoPlantModel:
    """One axis, advanced one cycle per :meth:`cycle` call; fields are the registered outputs."""

    gain: int
    alpha: int
    vmax: int = 0
    dac_bits: int = 12
    kf: int = 0
    position: int = 0
    velocity: int = 0

    @property
    def count(self) -> int:
        return wrap(self.position >> FRAC_BITS, COUNT_BITS)

    def quadrature(self) -> tuple[int, int]:
        """(A, B) of the current count."""
        c = self.count
        return (c ^ (c >> 1)) & 1, (c >> 1) & 1

    def command(self, dac: int, com: int) -> int:
        """The velocity command vc for D/A code ``dac`` and net command pulse ``com``."""
        err = dac - dac_zero(self.dac_bits)
        vmax = VC_MAX if not self.vmax or self.vmax > VC_MAX else self.vmax
        return max(-vmax, min(vmax, err * self.gain + com * self.kf))

    def cycle(self, dac: int, stall: bool = False, com: int = 0) -> None:
        """One cycle with D/A code ``dac``, the stall fault and net command pulse ``com``."""
        vc = self.command(dac, com)
        delta = wrap((vc - self.velocity) * self.alpha + (1 << (ALPHA_BITS - 1)),
                      PRODUCT_BITS)
        step = delta >> ALPHA_BITS
        if stall:
            self.velocity = 0
        elif step == 0:  # closer to vc than one update resolves: there
            self.velocity = vc
        else:
            self.velocity = wrap(self.velocity + step, VC_BITS + 1)
        self.position = wrap(self.position + self.velocity, POSITION_BITS)
