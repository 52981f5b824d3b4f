"""The simulated machine: the chipset, one servo plant per axis, and observation counters.

This is the design every simulation backend runs. The chipset is the synthesisable part;
the plants and counters are simulation models. Plant parameters and fault injections are
input ports, so one compiled model serves every job.
"""

from amaranth.hdl import Module, Mux, signed
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from k37.hdl.bus.hostbus import HostBus
from k37.hdl.chipset.chip import Chipset
from k37.hdl.chipset.map import Accel, AccelShape, axis_names
from k37.hdl.common.observation import FreeRunning, Observed
from k37.hdl.k3702.map import COUNTER_WIDTH
from k37.sim.machine.plant import ServoPlant
from k37.sim.machine.plant_model import (
    ALPHA_BITS,
    COUNT_BITS,
    GAIN_BITS,
    KF_BITS,
    PERIOD_BITS,
    VMAX_BITS,
)
from k37.sim.machine.torque_drive import TorqueDrive
from k37.sim.machine.torque_drive_model import ACCEL_BITS, AFTER_BITS, KI_BITS
from k37.sim.machine.two_mass import TwoMassDrive
from k37.sim.machine.two_mass_model import SPRING_BITS

#: The servo drive of each ``drive`` name: the first-order plant, the torque drive, or the
#: two-mass drive.
DRIVES: dict[str, type[ServoPlant]] = {"first_order": ServoPlant, "torque": TorqueDrive,
                                       "two_mass": TwoMassDrive}
#: The torque drive's own inputs (zero and unused on a first-order axis).
TORQUE_INPUTS = ("beta", "ki", "fc", "load", "load_step", "load_after")
#: The two-mass drive's own inputs beyond those (unused on the other drives).
TWO_MASS_INPUTS = ("ks_m", "ks_t", "cs_m", "cs_t", "scale")

__all__ = ["DRIVES", "TORQUE_INPUTS", "TWO_MASS_INPUTS", "AxisProbe", "System"]


class AxisProbe(wiring.Signature):
    """One axis's plant settings, fault inputs and observations (the system's view).

    Members
    -------
    gain, alpha, vmax, kf, period, dac_zero : In
        Plant parameters (:class:`k37.sim.machine.plant.PlantParams`; ``dac_zero`` from
        :func:`k37.sim.machine.plant.dac_zero` of the K3702's DAC_BITS).
    beta, ki, fc, load, load_step, load_after : In
        The torque drive's parameters (:class:`k37.sim.machine.torque_drive.TorqueDrive`); not
        connected on a first-order axis.
    ks_m, ks_t, cs_m, cs_t, scale : In
        The two-mass drive's (:class:`k37.sim.machine.two_mass.TwoMassDrive`); connected on a
        two-mass axis only.
    stall, glitch_a, glitch_b, break_a : In(1)
        Fault injection (see :class:`k37.sim.machine.plant.ServoPlant`).
    command, error : Out(signed(COUNTER_WIDTH))
        The K3702's counters.
    count : Out(signed(COUNT_BITS))
        The plant's encoder count (the true position in LSB).
    dac : Out(16)
        The D/A word.
    max_abs_error : Out(COUNTER_WIDTH)
        The largest |error| seen since reset, updated every cycle.
    pulses_pos, pulses_neg : Out(32)
        K3701 step pulses on this axis since reset.
    alarm_n : Out(1)
        The K3702's ALARM pin.
    """

    def __init__(self):
        super().__init__({
            "gain": In(GAIN_BITS), "alpha": In(ALPHA_BITS), "vmax": In(VMAX_BITS),
            "kf": In(KF_BITS), "period": In(PERIOD_BITS), "dac_zero": In(16),
            "beta": In(ALPHA_BITS), "ki": In(KI_BITS), "fc": In(ACCEL_BITS),
            "load": In(signed(ACCEL_BITS)), "load_step": In(signed(ACCEL_BITS)),
            "load_after": In(AFTER_BITS),
            **{name: In(SPRING_BITS) for name in TWO_MASS_INPUTS[:-1]}, "scale": In(1),
            "stall": In(1), "glitch_a": In(1), "glitch_b": In(1), "break_a": In(1),
            "command": Out(signed(COUNTER_WIDTH)), "error": Out(signed(COUNTER_WIDTH)),
            "count": Out(signed(COUNT_BITS)), "dac": Out(16), "max_abs_error": Out(COUNTER_WIDTH),
            "pulses_pos": Out(32), "pulses_neg": Out(32), "alarm_n": Out(1),
        })


class System(Observed, wiring.Component):
    """Chipset + plants. See :class:`k37.hdl.chipset.chip.Chipset` for ``accel``, ``accel_bits``,
    ``axes`` (one plant per axis), ``accel_shape``, ``axis_accel`` and ``axis_fa``; ``drives``:
    per axis, the servo drive's name in :data:`DRIVES` (default ``"first_order"``).

    Members
    -------
    bus : In(HostBus(8))
        The 8085's I/O bus.
    irq : Out(1)
        Any interrupt (data request or alarm).
    irq_interp, irq_alarm : Out(1)
        The two interrupt lines.
    fp_total : Out(32)
        Feed pulses the K3701 received since reset.
    quiet : Out(1)
        The chipset's ``quiet``: its free-running state and the plants may run on alone.
    x, y : Out(AxisProbe())
        Per-axis plant settings, faults and observations (and ``z`` on three axes).

    ``free_running`` (:mod:`k37.hdl.common.observation`) is what runs on while the machine stands
    still: the chipset's (the feed-rate generator's dividers and rate multiplier, the accel/decel
    accumulators, the K3701's step latency count) and the plants while they move within one encoder
    count. That is a dwell, the host busy, the axes settling, and, at a low feed, most of every
    move: the compiled backend's idle skipping advances them up to the next event. """

    def __init__(self, *, accel: Accel | str = Accel.PRE, accel_bits: int = 15, axes: int = 2,
                 accel_shape: AccelShape | str = AccelShape.EXPONENTIAL,
                 axis_accel: dict[str, tuple[AccelShape | str, int]] | None = None,
                 axis_fa: tuple[str, ...] = (), drives: dict[str, str] | None = None):
        drives = drives or {}
        for axis, drive in drives.items():
            if axis not in axis_names(axes) or drive not in DRIVES:
                raise ValueError(f"drives: {axis!r}: {drive!r} is not an axis's drive "
                                 f"({', '.join(DRIVES)})")
        self.chipset = Chipset(accel=accel, accel_bits=accel_bits, axes=axes,
                               accel_shape=accel_shape, axis_accel=axis_accel, axis_fa=axis_fa)
        self.axes = self.chipset.axes
        self.drives = {axis: DRIVES[drives.get(axis, "first_order")] for axis in self.axes}
        super().__init__({
            "bus": In(HostBus(8)), "irq": Out(1), "irq_interp": Out(1), "irq_alarm": Out(1),
            "fp_total": Out(32), "quiet": Out(1),
            **{axis: Out(AxisProbe()) for axis in self.axes},
        })

    @property
    def free_running(self) -> FreeRunning:
        """See the class docstring."""
        return self.chipset.free_running.under("chipset").merge(
            *(self.drives[axis].declare().under(f"plant_{axis}") for axis in self.axes),
            quiet="quiet")

    def elaborate(self, platform) -> Module:
        m = Module()
        m.submodules.chipset = chip = self.chipset
        wiring.connect(m, wiring.flipped(self.bus), chip.bus)
        m.d.comb += [
            self.irq_interp.eq(chip.irq_interp), self.irq_alarm.eq(chip.irq_alarm),
            self.irq.eq(chip.irq_interp | chip.irq_alarm),
            self.quiet.eq(chip.quiet),
        ]
        with m.If(chip.fp):
            m.d.sync += self.fp_total.eq(self.fp_total + 1)
        for axis in self.axes:
            probe, pins = getattr(self, axis), getattr(chip, axis)
            plant = m.submodules[f"plant_{axis}"] = self.drives[axis]()
            if isinstance(plant, TorqueDrive):
                m.d.comb += [getattr(plant, name).eq(getattr(probe, name))
                             for name in TORQUE_INPUTS]
            if isinstance(plant, TwoMassDrive):
                m.d.comb += [getattr(plant, name).eq(getattr(probe, name))
                             for name in TWO_MASS_INPUTS]
            m.d.comb += [
                plant.dac.eq(pins.dac), plant.dac_zero.eq(probe.dac_zero),
                plant.gain.eq(probe.gain), plant.alpha.eq(probe.alpha),
                plant.vmax.eq(probe.vmax), plant.stall.eq(probe.stall),
                plant.kf.eq(probe.kf), plant.period.eq(probe.period),
                plant.com_pos.eq(pins.com_pos),
                plant.com_neg.eq(pins.com_neg),
                plant.glitch_a.eq(probe.glitch_a), plant.glitch_b.eq(probe.glitch_b),
                plant.break_a.eq(probe.break_a),
                pins.a.eq(plant.a), pins.a_n.eq(plant.a_n),
                pins.b.eq(plant.b), pins.b_n.eq(plant.b_n),
                probe.command.eq(pins.command), probe.error.eq(pins.error),
                probe.count.eq(plant.count), probe.dac.eq(pins.dac),
                probe.alarm_n.eq(pins.alarm_n),
            ]
            magnitude = Mux(pins.error < 0, -pins.error, pins.error)
            with m.If(magnitude > probe.max_abs_error):
                m.d.sync += probe.max_abs_error.eq(magnitude)
            step_pos = getattr(chip, f"step_{axis}_pos")
            step_neg = getattr(chip, f"step_{axis}_neg")
            with m.If(step_pos):
                m.d.sync += probe.pulses_pos.eq(probe.pulses_pos + 1)
            with m.If(step_neg):
                m.d.sync += probe.pulses_neg.eq(probe.pulses_neg + 1)
        return m
