"""Reference model of :class:`k37.sim.machine.plant.ServoPlant`: its fixed-point update, in Python,
and the plant's parameters and their fixed-point encoding (:class:`PlantParams`), which the
gateware and a run share without importing Amaranth."""

from __future__ import annotations

from dataclasses import dataclass

from k37.hdl.common.constants import CHIP_HZ
from k37.hdl.common.params import Limit

__all__ = ["ALPHA_BITS", "COUNT_BITS", "DAC_VOLTS", "FF_BITS", "FRAC_BITS", "GAIN_BITS", "KF_BITS",
           "KF_LIMIT", "PERIOD_BITS", "POSITION_BITS", "PRODUCT_BITS", "UPDATE_CYCLES_LIMIT",
           "VC_BITS", "VC_MAX", "VMAX_BITS", "PlantParams", "ServoPlantModel", "dac_zero", "wrap"]

#: Fraction bits of position and velocity.
FRAC_BITS = 32
#: Fraction bits of the velocity-lag coefficient alpha = dt / Tm (alpha < 2^ALPHA_BITS).
ALPHA_BITS = 24
#: Velocity bound: 2^37 = 32 counts per cycle (keeps every product within PRODUCT_BITS).
VC_BITS = 37
VC_MAX = (1 << VC_BITS) - 1
#: Width of the gain port (velocity command per count of error, FRAC_BITS fraction bits).
GAIN_BITS = 32
#: Width of the speed-limit port (counts per cycle, FRAC_BITS fraction bits).
VMAX_BITS = 48
#: Width of the encoder count, the integer part of the position.
COUNT_BITS = 32
POSITION_BITS = COUNT_BITS + FRAC_BITS
#: Width of the velocity update's product: two machine words of a compiled simulator.
PRODUCT_BITS = 64
#: Width of the feedforward port: Kf counts/cycle per command pulse, FRAC_BITS fraction bits.
KF_BITS = FRAC_BITS + 2
#: Velocity feedforward gain Kf (a fraction of the command pulse rate).
KF_LIMIT = Limit(0, 2, unit="", note="fraction of the command rate")
#: Width of the update period port (cycles from one velocity update to the next).
PERIOD_BITS = 13
#: The update period's range: every cycle (the plant of the papers) to 4,096 cycles.
UPDATE_CYCLES_LIMIT = Limit(1, 1 << (PERIOD_BITS - 1), integer=True, unit="cycles")
#: Width of the feedforward summed between updates: at most one command pulse a cycle, each
#: at most kf per update, so at most 2^KF_BITS either way.
FF_BITS = KF_BITS + 2
#: Full-scale D/A voltage.
DAC_VOLTS = 10.0


def dac_zero(dac_bits: int) -> int:
    """The D/A code of 0 V for an N-bit offset-binary converter: 2^(N-1)."""
    return 1 << (dac_bits - 1)


def _saturate(value: float, bits: int) -> int:
    """``value`` rounded to an integer, at most the largest of ``bits`` bits (a value in the
    last half LSB below a port's full scale takes its top code)."""
    return min(round(value), (1 << bits) - 1)


@dataclass(frozen=True)
class PlantParams:
    """One axis's servo drive, in physical units, and its fixed-point encoding.

    ``kp``: position-loop gain (1/s); the amplifier's Kv = kp * 2^(N-1) / 10 V follows
    from it (``docs/decisions.md``, servo plant). ``tm``: velocity-loop time constant (s, 0 for
    none). ``max_speed``: speed limit (counts/s, None for none). ``kf``: velocity feedforward, the
    fraction of the command pulse rate the drive adds to its velocity command.
    ``update_cycles``: cycles from one velocity update to the next (1: every cycle); the
    velocity is held between updates while the position moves by it every cycle.
    ``clock_hz``: system clock. Each must be in its :meth:`limits`.
    """

    kp: float
    tm: float
    max_speed: float | None = None
    clock_hz: float = CHIP_HZ
    kf: float = 0.0
    update_cycles: int = 1

    def __post_init__(self) -> None:
        Limit(0, low_open=True, unit="Hz").check("clock_hz", self.clock_hz)
        limits = self.limits(self.clock_hz)
        for name in ("kp", "tm", "max_speed", "kf", "update_cycles"):
            value = getattr(self, name)
            if value is not None:
                limits[name].check(name, value)

    @staticmethod
    def limits(clock_hz: float) -> dict[str, Limit]:
        """The range of ``kp``, ``tm`` and ``max_speed`` at ``clock_hz``: what the fixed point
        carries. The gain and the speed limit, per cycle with FRAC_BITS fraction bits, must
        stay below their ports' full scale; alpha must not round to 0 (which would end the
        lag at once), so Tm is at most 2^ALPHA_BITS cycles."""
        per_lsb = clock_hz / (1 << FRAC_BITS)  # 1/s of kp, counts/s of max_speed, per LSB
        return {
            "kp": Limit(0, (1 << GAIN_BITS) * per_lsb, low_open=True, high_open=True,
                        unit="1/s", note=f"{GAIN_BITS}-bit gain at clock_hz"),
            "tm": Limit(0, (1 << ALPHA_BITS) / clock_hz, unit="s",
                        note=f"{ALPHA_BITS}-bit alpha at clock_hz"),
            "max_speed": Limit(0, (1 << VMAX_BITS) * per_lsb, low_open=True, high_open=True,
                               unit="counts/s", note=f"{VMAX_BITS}-bit speed limit at clock_hz"),
            "kf": KF_LIMIT,
            "update_cycles": UPDATE_CYCLES_LIMIT,
        }

    @property
    def gain(self) -> int:
        """Velocity command per count of error, in counts/cycle << FRAC_BITS."""
        return _saturate(self.kp / self.clock_hz * (1 << FRAC_BITS), GAIN_BITS)

    @property
    def alpha(self) -> int:
        """dt / Tm << ALPHA_BITS per update (dt: ``update_cycles`` cycles), at most
        2^ALPHA_BITS - 1.

        A Tm of an update period or less gives the largest alpha, 1 - 2^-24: the velocity then
        follows the command within one update, short of it by a 2^-24 fraction of the step.
        """
        updates = self.tm * self.clock_hz / self.update_cycles  # updates per Tm
        if updates <= 1:
            return (1 << ALPHA_BITS) - 1
        return _saturate((1 << ALPHA_BITS) / updates, ALPHA_BITS)

    @property
    def kf_word(self) -> int:
        """Kf in counts/cycle << FRAC_BITS per update: what one command pulse adds to the
        velocity command of its update (a rate of one count per cycle, times Kf, over
        ``update_cycles`` cycles)."""
        return round(self.kf * (1 << FRAC_BITS) / self.update_cycles)

    @property
    def vmax(self) -> int:
        """Speed limit in counts/cycle << FRAC_BITS (0: none)."""
        if self.max_speed is None:
            return 0
        return max(1, _saturate(self.max_speed / self.clock_hz * (1 << FRAC_BITS), VMAX_BITS))

    def ports(self) -> dict[str, int]:
        """The plant's parameter inputs, by port name
        (:class:`k37.sim.machine.plant.ServoPlant`)."""
        return {"gain": self.gain, "alpha": self.alpha, "vmax": self.vmax, "kf": self.kf_word,
                "period": self.update_cycles}

    def kv(self, dac_bits: int) -> float:
        """The amplifier's velocity gain, counts/s per volt."""
        return self.kp * dac_zero(dac_bits) / DAC_VOLTS


def wrap(value: int, bits: int) -> int:
    """``value`` as a two's complement number of ``bits`` bits."""
    value &= (1 << bits) - 1
    return value - (1 << bits) if value >> (bits - 1) else value


@dataclass
class ServoPlantModel:
    """One axis, advanced one cycle per :meth:`cycle` call; fields are the registers (``phase``:
    cycles since the last velocity update, ``ff``: the feedforward summed since it)."""

    gain: int
    alpha: int
    vmax: int = 0
    dac_bits: int = 12
    kf: int = 0
    period: int = 1
    position: int = 0
    velocity: int = 0
    phase: int = 0
    ff: int = 0

    @property
    def count(self) -> int:
        return wrap(self.position >> FRAC_BITS, COUNT_BITS)

    def quadrature(self) -> tuple[int, int]:
        """(A, B) of the current count."""
        c = self.count
        return (c ^ (c >> 1)) & 1, (c >> 1) & 1

    def command(self, dac: int, feedforward: int) -> int:
        """The velocity command vc for D/A code ``dac`` and the summed ``feedforward``."""
        err = dac - dac_zero(self.dac_bits)
        vmax = VC_MAX if not self.vmax or self.vmax > VC_MAX else self.vmax
        return max(-vmax, min(vmax, err * self.gain + feedforward))

    def cycle(self, dac: int, stall: bool = False, com: int = 0) -> None:
        """One cycle with D/A code ``dac``, the stall fault and net command pulse ``com``."""
        feedforward = self.ff + com * self.kf
        update = self.phase == 0
        self.phase = 0 if self.phase + 1 >= self.period else self.phase + 1
        self.ff = 0 if update else feedforward
        if update:
            self.velocity = self._updated(self.command(dac, feedforward), stall)
        self.position = wrap(self.position + self.velocity, POSITION_BITS)

    def _updated(self, vc: int, stall: bool) -> int:
        """The velocity after an update towards ``vc``."""
        delta = wrap((vc - self.velocity) * self.alpha + (1 << (ALPHA_BITS - 1)),
                      PRODUCT_BITS)
        step = delta >> ALPHA_BITS
        if stall:
            return 0
        if step == 0:  # closer to vc than one update resolves: there
            return vc
        return wrap(self.velocity + step, VC_BITS + 1)
