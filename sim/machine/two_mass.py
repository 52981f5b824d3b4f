"""A feed drive that resonates: the torque drive's motor joined to the table by the ball screw's
axial stiffness (the profile-error paper's Fig. 1 and eqs. (1)-(4)).

The update, its fixed point and the natural frequencies are in
:mod:`k37.sim.machine.two_mass_model`. The drive declares no native update for idle skipping: while
either mass moves or the spring rings, its registers change and every cycle is evaluated; once
both are at rest with the spring still, it is static and the rest of the machine may skip.
"""

from amaranth.hdl import Module, Mux, Signal, Value, signed
from amaranth.lib.wiring import In

from k37.sim.machine.plant_model import POSITION_BITS, VC_BITS
from k37.sim.machine.torque_drive import TorqueDrive, coulomb
from k37.sim.machine.two_mass_model import SPRING_BITS, SPRING_FRAC

__all__ = ["TwoMassDrive"]


class TwoMassDrive(TorqueDrive):
    """:class:`k37.sim.machine.torque_drive.TorqueDrive` whose motor drives a table through a spring
    (:class:`k37.sim.machine.two_mass_model.TwoMassDriveModel`).

    Members (beyond the torque drive's; ``fc``, ``load`` and ``load_step`` act on the table,
    ``velocity`` is the motor's)
    ---------------------------------------------------------------------------------------
    ks_m, ks_t : In(SPRING_BITS)
        Ks / M' dt^2 and Ks / M dt^2, << SPRING_FRAC.
    cs_m, cs_t : In(SPRING_BITS)
        c / M' dt and c / M dt, << SPRING_FRAC.
    scale : In(1)
        1: the encoder reads the table (a linear scale), 0: the motor.

    Every register updates at the clock edge; the outputs follow one cycle after the inputs,
    as the plant's.
    """

    ks_m: In(SPRING_BITS)
    ks_t: In(SPRING_BITS)
    cs_m: In(SPRING_BITS)
    cs_t: In(SPRING_BITS)
    scale: In(1)

    def next_velocity(self, m: Module, vc: Signal):
        # s = s_before + vm - vt is the deflection after the last update (each register's
        # next value one expression, as the plant's position).
        before = Signal(signed(POSITION_BITS))
        table = Signal(signed(VC_BITS + 1))
        self._deflection = Signal(signed(POSITION_BITS))
        m.d.comb += self._deflection.eq(before + self.velocity - table)
        slip = self.velocity - table
        half = 1 << (SPRING_FRAC - 1)
        wide = POSITION_BITS + SPRING_BITS + 4
        fm = Signal(signed(wide))
        ft = Signal(signed(wide))
        s = self._deflection
        m.d.comb += [fm.eq((s * self.ks_m + slip * self.cs_m + half).shift_right(SPRING_FRAC)),
                     ft.eq((s * self.ks_t + slip * self.cs_t + half).shift_right(SPRING_FRAC))]
        motor = Signal(signed(VC_BITS + 4))
        m.d.comb += motor.eq(self.loop_velocity(m, vc) - fm)
        table_next = Signal(signed(VC_BITS + 4))
        m.d.comb += table_next.eq(table + ft - self.disturbance(m))
        m.d.sync += [before.eq(self._deflection),
                     table.eq(Mux(self.stall, 0, coulomb(table_next, self.fc)))]
        return Mux(self.stall, 0, motor)

    def encoder_position(self, m: Module, motor: Value) -> Value:
        """The motor's position, or with ``scale`` the table's (the motor's less s)."""
        del m
        return Mux(self.scale, motor - self._deflection, motor)
