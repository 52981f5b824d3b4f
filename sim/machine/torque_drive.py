"""A servo drive with a velocity loop, motor torque, load inertia and friction (the profile-error
paper).

The drive of the profile-error paper (its eqs. (9)-(16)): the position loop's velocity command vc
(with the feedforward of :class:`k37.sim.machine.plant.ServoPlant`) drives a PI velocity loop of
gain Vg (A s/rad) and integral time Ti; the motor's torque Kt i (N m) turns the load inertia Ja (kg
m^2) against viscous friction D (N m s/rad), Coulomb friction Fc (N m) and a disturbance torque (N
m, the load). Per cycle, in the plant's fixed point (velocity in counts/cycle):

    ev = vc - v
    I += ev * ki                              ki = (Kt Vg / Ja) dt^2 / Ti   (0: no integral)
    v1 = v + round((ev * alpha - v * beta) / 2^24) + I - load
                                              alpha = (Kt Vg / Ja) dt,  beta = (D / Ja) dt
    v  = v1 - clamp(v1, -fc, fc)              fc = Coulomb torque / Ja as counts/cycle^2

Coulomb friction takes up to ``fc`` from the speed each cycle and never reverses it, so an
axis whose drive torque is below it stays at rest (stiction). With Ti = 0 the steady velocity
at a command vc is vc / (1 + D / (Vg Kt)): the profile-error paper's eq. (9) following error
``(D / (Vg Kt) + 1 - Kf) F / Kp``; an integral term removes the D part.

A load step (a fault) adds ``load_step`` to the disturbance from cycle ``load_after`` on; the
cycle counter runs only until then. The drive updates every cycle: its ``period`` input must be
0 or 1 (a job refuses another update period on it). The drive declares no native update for
idle skipping: while it moves, its registers change and every cycle is evaluated; at rest it is
static.
"""


from amaranth.hdl import Module, Mux, Signal, signed
from amaranth.lib.wiring import In

from k37.hdl.common.observation import FreeRunning
from k37.sim.machine.plant import ServoPlant
from k37.sim.machine.plant_model import ALPHA_BITS, VC_BITS
from k37.sim.machine.torque_drive_model import (
    ACCEL_BITS,
    AFTER_BITS,
    INTEGRAL_BITS,
    KI_BITS,
    KI_FRAC,
)

__all__ = ["TorqueDrive", "coulomb"]

class TorqueDrive(ServoPlant):
    """:class:`k37.sim.machine.plant.ServoPlant` with the velocity update of the module docstring.

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

    @staticmethod
    def declare() -> FreeRunning:
        """No native update: the drive is stepped (see the module docstring)."""
        return FreeRunning()

    def next_velocity(self, m: Module, vc: Signal):
        v1 = Signal(signed(VC_BITS + 4))
        m.d.comb += v1.eq(self.loop_velocity(m, vc) - self.disturbance(m))
        return Mux(self.stall, 0, coulomb(v1, self.fc))

    def loop_velocity(self, m: Module, vc: Signal):
        """The velocity after the loop's torque and the viscous friction (the model's
        ``loop_velocity``)."""
        v = self.velocity
        ev = Signal(signed(VC_BITS + 2))
        m.d.comb += ev.eq(vc - v)
        integral = Signal(signed(INTEGRAL_BITS))
        integral_next = Signal(signed(INTEGRAL_BITS))
        m.d.comb += integral_next.eq(integral + ev * self.ki)
        m.d.sync += integral.eq(integral_next)
        drive = Signal(signed(VC_BITS + ALPHA_BITS + 4))
        m.d.comb += drive.eq((ev * self.alpha - v * self.beta + (1 << (ALPHA_BITS - 1)))
                             .shift_right(ALPHA_BITS))
        return v + drive + integral_next.shift_right(KI_FRAC)

    def disturbance(self, m: Module):
        """The load and, from cycle ``load_after`` on, the load step."""
        elapsed = Signal(AFTER_BITS)
        stepped = Signal()
        m.d.comb += stepped.eq((self.load_step != 0) & (elapsed >= self.load_after))
        with m.If((self.load_step != 0) & ~stepped):
            m.d.sync += elapsed.eq(elapsed + 1)
        return self.load + Mux(stepped, self.load_step, 0)


def coulomb(velocity: Signal, fc: Signal):
    """``velocity`` less Coulomb friction ``fc``, which never reverses it (the model's
    :func:`~k37.sim.machine.torque_drive_model.coulomb`)."""
    return Mux(velocity > fc, velocity - fc, Mux(velocity < -fc, velocity + fc, 0))
