"""A job's servo settings on the simulated machine: their ranges, their plant parameters and
the ports they set.

A job's servo keys (:class:`k37.firmware_model.job.ServoConfig`, one per axis) are physical
values; the plants (:mod:`k37.sim.machine.plant`, :mod:`k37.sim.machine.torque_drive`,
:mod:`k37.sim.machine.two_mass`) take fixed-point words on the machine's clock and LSB. This
module turns the one into the other: :func:`servo_limits` is each key's range on a machine,
:func:`check_servo` refuses a servo its plant cannot carry, and :func:`servo_ports` is what an
axis's plant inputs are set to, by port name (each parameter set names its own ports:
:meth:`~k37.sim.machine.plant_model.PlantParams.ports`,
:meth:`~k37.sim.machine.torque_drive_model.TorqueParams.ports`,
:meth:`~k37.sim.machine.two_mass_model.TwoMassParams.ports`).
"""

from __future__ import annotations

from k37.firmware_model.job import Job, MachineConfig, ServoConfig
from k37.hdl.common.params import Limit
from k37.sim.machine.plant_model import PlantParams, dac_zero
from k37.sim.machine.torque_drive_model import TorqueParams
from k37.sim.machine.two_mass_model import TwoMassParams

__all__ = ["TORQUE_DRIVES", "TORQUE_KEYS", "TWO_MASS_KEYS", "axis_port", "check_servo",
           "load_step_fault", "plant_params", "servo_limits", "servo_ports", "torque_params"]

#: The torque drive's keys (used only with ``drive = "torque"`` or ``"two_mass"``).
TORQUE_KEYS = tuple(TorqueParams.limits())
#: The two-mass drive's keys (used only with ``drive = "two_mass"``).
TWO_MASS_KEYS = (*TwoMassParams.limits(), "scale")
#: The drives with the torque drive's velocity loop.
TORQUE_DRIVES = ("torque", "two_mass")


def axis_port(axis: str, name: str) -> str:
    """The simulated machine's port ``name`` of axis ``axis``'s plant
    (:class:`k37.sim.machine.system.AxisProbe`): ``x__gain``."""
    return f"{axis}__{name}"


def servo_limits(machine: MachineConfig) -> dict[str, Limit]:
    """The range of each servo key on ``machine``: the plant's
    (:meth:`k37.sim.machine.plant_model.PlantParams.limits`), in the job's units."""
    limits = PlantParams.limits(machine.clock_hz)
    speed = limits["max_speed"]
    return {**limits, "max_speed": speed.scaled(machine.mm_per_min(1.0), "mm/min",
                                                f"{speed.note} and lsb_mm"),
            **TwoMassParams.limits()}


def plant_params(machine: MachineConfig, servo: ServoConfig) -> PlantParams:
    """The plant of one axis's ``servo`` on ``machine``.

    Raises
    ------
    ValueError
        A servo key is out of the plant's range (checked in the plant's units), naming the
        key, its value and its range in the job's units (:func:`servo_limits`).
    """
    values = {"kp": servo.kp, "tm": servo.tm, "kf": servo.kf, "update_cycles": servo.update_cycles,
              "max_speed": None if servo.max_speed is None else machine.lsb_per_s(servo.max_speed)}
    limits = PlantParams.limits(machine.clock_hz)
    for name, value in values.items():
        if value is not None and value not in limits[name]:
            raise ValueError(f"{name} must be {servo_limits(machine)[name].describe()}, "
                             f"not {getattr(servo, name)!r}")
    return PlantParams(clock_hz=machine.clock_hz, **values)


def torque_params(machine: MachineConfig, servo: ServoConfig) -> TorqueParams:
    """The torque drive of one axis's ``servo`` on ``machine``, or its two-mass drive
    (:class:`~k37.sim.machine.two_mass_model.TwoMassParams`); ValueError naming a bad key."""
    if servo.drive == "two_mass":
        return TwoMassParams(clock_hz=machine.clock_hz,
                             **{name: getattr(servo, name) for name in TWO_MASS_KEYS})
    return TorqueParams(clock_hz=machine.clock_hz,
                        **{name: getattr(servo, name) for name in TORQUE_KEYS})


def check_servo(machine: MachineConfig, servo: ServoConfig) -> None:
    """Refuse a ``servo`` the plant on ``machine`` cannot carry: a key out of its range, or a
    torque or two-mass drive beyond its fixed point (its keys are unused on the other drives,
    so only their ranges are checked there), or an update period on a drive that updates every
    cycle; TypeError or ValueError naming the key."""
    plant_params(machine, servo)
    if servo.drive in TORQUE_DRIVES and servo.update_cycles != 1:
        raise ValueError(f"update_cycles must be 1 on a {servo.drive} drive (it updates every "
                         f"cycle), not {servo.update_cycles!r}")
    for name, limit in TwoMassParams.limits().items():
        limit.check(name, getattr(servo, name))
    if servo.drive in TORQUE_DRIVES:
        torque_params(machine, servo)


def servo_ports(machine: MachineConfig, servo: ServoConfig) -> dict[str, int]:
    """What one axis's plant inputs are set to for ``servo`` on ``machine``, by port name: the
    plant's parameters, the torque drive's (whose ``alpha`` replaces the first-order lag's) on
    a torque or two-mass drive, and the D/A's zero."""
    ports = plant_params(machine, servo).ports()
    if servo.drive in TORQUE_DRIVES:
        ports.update(torque_params(machine, servo).ports())
    ports["dac_zero"] = dac_zero(machine.dac_bits)
    return ports


def load_step_fault(job: Job, axis: str, torque: float, at_s: float) -> dict[str, int]:
    """The plant inputs of a load step of ``torque`` (N m) on ``axis`` at ``at_s`` seconds
    (the axis must have the torque drive); ValueError naming what is wrong."""
    names = job.machine.axis_names
    if axis not in names:
        raise ValueError(f"no axis {axis!r}; the machine's axes are {', '.join(names)}")
    servo = job.servo[axis]
    if servo.drive not in TORQUE_DRIVES:
        raise ValueError(f"a load step needs servo.{axis}.drive = \"torque\" or "
                         f"\"two_mass\", not {servo.drive!r}")
    Limit(unit="N m").check("load step torque", torque)
    # the time must be a cycle the simulated clock can count (2^64 cycles)
    Limit(0, ((1 << 64) - 1) / job.machine.clock_hz, unit="s").check("load step time", at_s)
    params = torque_params(job.machine, servo)
    try:
        word = params.disturbance_word(torque)
    except OverflowError:  # beyond any float: beyond the range below too
        word = 1 << 39
    if word == 0 or abs(word) + abs(params.disturbance_word(params.load)) >= 1 << 39:
        raise ValueError(f"load step {torque!r} N m is 0 or beyond the drive's torque range")
    return {"load_step": word, "load_after": round(at_s * job.machine.clock_hz)}
