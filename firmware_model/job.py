"""The job the firmware runs: the machine, its two servos, the program and the run's options.

A job comes from a file (:mod:`k37.sim.run.jobfile`, which loads ``k37 run [JOB]``'s TOML or
G-code), or is built here: :func:`demo_job` (the paper's circle) and :func:`gcode_job` (a
program on the default machine).

Every :class:`MachineConfig` value is checked when it is built, against the limit of the block
that has it: the chipset's accel/decel widths and placements (:mod:`k37.hdl.chipset.chip`), the
feed-rate generator's divider (:func:`k37.hdl.feed.rates.rate_limit`), the chips' register
ranges (their register maps), the G-code front end's LSB length. A :class:`ServoConfig` holds
the simulated plants' settings, which the firmware never sees: the job holds them, so their
keys are declared here and only their types checked; their ranges, the plant's fixed point on
the machine's clock and LSB, and their conversion into the plant's ports are the simulated
machine's (:mod:`k37.sim.machine.servo`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, field, fields, replace
from typing import Any, Protocol

from k37.firmware_model.gcode.canon import FRONTENDS
from k37.firmware_model.gcode.parser import GcodeError, names_third_axis
from k37.firmware_model.gcode.units import LSB_MM_LIMIT
from k37.firmware_model.motion.program import Program
from k37.hdl.chipset.map import ACCEL_BITS, AXES, MACHINE_AXES, Accel, AccelShape, axis_names
from k37.hdl.common.constants import CHIP_HZ
from k37.hdl.common.params import Limit
from k37.hdl.encoder.map import ENCODER_MAP
from k37.hdl.feed.map.feed_rate import DIVIDER_WIDTH
from k37.hdl.feed.rates import rate_limit
from k37.hdl.k3702.map import K3702_MAP

__all__ = ["AXES", "CONTOUR_CONTROLLERS", "DEMO_GCODE", "AxisAccelConfig", "Boolean",
           "ContourConfig", "Job", "MachineConfig", "OneOf",
           "OrAbsent", "RunConfig", "ServoConfig", "Valid", "demo_job", "gcode_job", "moves_z",
           "parse_for_machine"]

#: The demo: the paper's circle (its photo 6, circular interpolation under FP control), as a
#: full CCW circle of radius 10 mm starting at its rightmost point, at 1200 mm/min (20 k
#: steps/s at 1 um, well inside the K3701's 47.6 k/s and the default servo's reach).
DEMO_GCODE = """\
(K37 demo: the paper's circle, a full circle of radius 10 mm)
G17 G21 G90
F1200
G03 I-10 J0
M30
"""


class Valid(Protocol):
    """The values a key takes (a :class:`k37.hdl.common.params.Limit`, or one of the classes
    below)."""

    def check(self, name: str, value: Any) -> Any:
        """``value``, normalised; raises TypeError or ValueError naming ``name``."""

    def describe(self) -> str:
        """The values in words."""


@dataclass(frozen=True)
class OneOf:
    """One of some strings."""

    options: tuple[str, ...]

    def check(self, name: str, value: Any) -> str:
        if value not in self.options:
            raise ValueError(f"{name} must be {self.describe()}, not {value!r}")
        return value

    def describe(self) -> str:
        return f"one of {', '.join(map(repr, self.options))}"


class Boolean:
    """True or false."""

    def check(self, name: str, value: Any) -> bool:
        if not isinstance(value, bool):
            raise TypeError(f"{name} must be {self.describe()}, not {value!r}")
        return value

    def describe(self) -> str:
        return "true or false"


@dataclass(frozen=True)
class OrAbsent:
    """Absent (None), or a value of ``valid``."""

    valid: Valid

    def check(self, name: str, value: Any) -> Any:
        return None if value is None else self.valid.check(name, value)

    def describe(self) -> str:
        return f"{self.valid.describe()}, or absent"


#: A key's values: fixed, or following from the keys declared before it.
KeyValues = Valid | Callable[[Any], Valid]


def _key(default: Any, valid: KeyValues, doc: str) -> Any:
    return field(default=default, metadata={"valid": valid, "doc": doc})


class _Checked:
    """Checks (and normalises) every field in ``__post_init__``, in declaration order."""

    def __post_init__(self) -> None:
        for f in fields(self):
            object.__setattr__(self, f.name, self.valid(f.name).check(f.name,
                                                                       getattr(self, f.name)))

    def valid(self, name: str) -> Valid:
        """The values key ``name`` takes (given the keys before it)."""
        valid = next(f for f in fields(self) if f.name == name).metadata["valid"]
        return valid(self) if callable(valid) else valid

    def to_dict(self) -> dict[str, Any]:
        """The JSON-able form: every key with its value."""
        return asdict(self)


@dataclass(frozen=True)
class MachineConfig(_Checked):
    """The chipset and its host-set values. Defaults are the paper's where it gives them."""

    clock_hz: int = _key(CHIP_HZ, Limit(1, 10**9, integer=True, unit="Hz"),
                         "system clock CP (Hz); paper: 1 MHz")
    lsb_mm: float = _key(0.001, LSB_MM_LIMIT, "axis travel of one LSB = one pulse (mm)")
    accel: str = _key(Accel.PRE.value, OneOf(tuple(a.value for a in Accel)),
                      "accel/decel placement: before the K3701 (FP control), per axis after "
                      "it, or none")
    accel_bits: int = _key(15, ACCEL_BITS, "accumulator width n of the accel/decel circuit; "
                                           "paper: 15")
    accel_fa_hz: float = _key(2**15 / 0.3,
                              lambda m: rate_limit(width=DIVIDER_WIDTH, f_clk=m.clock_hz),
                              "addition clock fa (Hz); paper: 109.227 kHz, tau = 2^n/fa = 300 ms")
    sqrt2: bool = _key(True, Boolean(), "K3701 sqrt(2) control (constant path speed)")
    dac_bits: int = _key(K3702_MAP["DAC_BITS"].init, K3702_MAP["DAC_BITS"].limit,
                         "K3702 D/A word width N")
    in_position: int = _key(10, K3702_MAP["POSITION_ZONE"].limit,
                            "K3702 position zone W (LSB): in position while abs(error) <= W")
    alarm_limit: int = _key(20_000, K3702_MAP["ALARM_ZONE"].limit,
                            "K3702 alarm zone A (LSB): alarm while abs(error) > A")
    encoder_filter: int = _key(ENCODER_MAP["FILTER"].init, ENCODER_MAP["FILTER"].limit,
                               "encoder glitch filter K (samples)")
    rapid_mm_min: float = _key(3000.0, Limit(0, low_open=True, unit="mm/min"),
                               "feed of G00 moves (mm/min); the default servo follows it with "
                               "a lag of 1667 LSB, inside a 12-bit D/A word's 2048")
    axes: int = _key(2, MACHINE_AXES,
                     "axes: 2 (X, Y: the paper's machine) or 3 (X, Y, Z: a third K3702, "
                     "encoder interface and servo; G18/G19 arcs and helices); absent from a "
                     "job: 3 if its program moves Z, else 2")
    accel_shape: str = _key(AccelShape.EXPONENTIAL.value,
                            OneOf(tuple(a.value for a in AccelShape)),
                            "accel/decel circuit: the paper's exponential one, a moving average "
                            "over T = 2^n/fa (linear: a ramp), or the moving average then the "
                            "exponential (bell)")

    @property
    def axis_names(self) -> tuple[str, ...]:
        """The machine's axes, in order (``("x", "y")`` or ``("x", "y", "z")``)."""
        return axis_names(self.axes)

    @property
    def tau_s(self) -> float:
        """The accel/decel time constant 2^n / fa (s)."""
        return 2**self.accel_bits / self.accel_fa_hz

    def lsb_per_s(self, mm_per_min: float) -> float:
        """A speed in mm/min as LSB (pulses, encoder counts) per second."""
        return mm_per_min / 60 / self.lsb_mm

    def mm_per_min(self, lsb_per_s: float) -> float:
        """A speed in LSB per second as mm/min (the inverse of :meth:`lsb_per_s`)."""
        return lsb_per_s * self.lsb_mm * 60


@dataclass(frozen=True)
class AxisAccelConfig(_Checked):
    """One axis's own accel/decel circuit (``[machine.x]``, ...; ``accel = "post"`` only):
    what is absent is the machine's. An ``accel_fa_hz`` gives the axis an addition clock of
    its own (the FEED chip's per-axis fa build), so its tau = 2^n / fa takes any value the
    machine's does; its range is the machine's (checked by :class:`Job`, which knows the
    clock)."""

    accel_shape: str | None = _key(None, OrAbsent(OneOf(tuple(a.value for a in AccelShape))),
                                   "this axis's accel/decel circuit; absent: machine.accel_shape")
    accel_bits: int | None = _key(None, OrAbsent(ACCEL_BITS),
                                  "this axis's accumulator width n (tau = 2^n/fa); absent: "
                                  "machine.accel_bits")
    accel_fa_hz: float | None = _key(None, OrAbsent(Limit(0, low_open=True, unit="Hz")),
                                     "this axis's own addition clock fa (Hz, in the range of "
                                     "machine.accel_fa_hz), so its tau = 2^n/fa is free; "
                                     "absent: machine.accel_fa_hz, shared")

    def circuit(self, machine: MachineConfig) -> tuple[str, int]:
        """(shape, bits) of the axis's circuit on ``machine``."""
        return (machine.accel_shape if self.accel_shape is None else self.accel_shape,
                machine.accel_bits if self.accel_bits is None else self.accel_bits)

    def fa_hz(self, machine: MachineConfig) -> float:
        """The addition clock (Hz) of the axis's circuit on ``machine``."""
        return machine.accel_fa_hz if self.accel_fa_hz is None else self.accel_fa_hz

    def tau_s(self, machine: MachineConfig) -> float:
        """The axis's accel/decel time constant 2^n / fa (s) on ``machine``."""
        return 2**self.circuit(machine)[1] / self.fa_hz(machine)


@dataclass(frozen=True)
class ServoConfig(_Checked):
    """One axis's servo drive and motor (the simulation plant).

    Only the values' types are checked here: their ranges are the plant's fixed point on the
    machine's clock and LSB (``k37.sim.machine.servo.servo_limits``).
    """

    kp: float = _key(30.0, Limit(), "position loop gain Kp (1/s)")
    tm: float = _key(0.01, Limit(), "velocity loop time constant Tm (s); 0: none")
    max_speed: float | None = _key(None, OrAbsent(Limit()),
                                   "motor speed limit (mm/min); absent: no limit")
    kf: float = _key(0.0, Limit(), "velocity feedforward Kf: the drive adds Kf times the "
                                   "command pulse rate to its velocity command (the "
                                   "profile-error paper)")
    update_cycles: int = _key(1, Limit(integer=True),
                              "first-order drive: cycles from one velocity update to the next; "
                              "1: every cycle (the papers' plant); more: the velocity held "
                              "between updates while the position moves by it every cycle, "
                              "which the event engine jumps over (faster runs; the papers' rows "
                              "that hold at each period are in the docs' decisions)")
    drive: str = _key("first_order", OneOf(("first_order", "torque", "two_mass")),
                      "servo drive model: a first-order velocity lag Tm, the torque drive "
                      "(velocity loop Vg/Ti, Kt, Ja, friction; tm then unused), or the two-mass "
                      "drive (the torque drive's motor driving a table through the ball screw's "
                      "stiffness)")
    kt: float = _key(0.5, Limit(), "torque drive: motor torque constant Kt (N m/A)")
    ja: float = _key(1e-3, Limit(), "torque drive: load inertia Ja at the motor (kg m^2)")
    vg: float = _key(0.2, Limit(), "torque drive: velocity loop gain Vg (A s/rad); the loop's "
                                   "lag is Ja/(Kt Vg), 10 ms by default")
    ti: float = _key(0.0, Limit(), "torque drive: velocity loop integral time Ti (s); 0: P only")
    d: float = _key(0.0, Limit(), "torque drive: viscous friction D at the motor (N m s/rad)")
    fc: float = _key(0.0, Limit(), "torque drive: Coulomb friction torque (N m)")
    load: float = _key(0.0, Limit(), "torque drive: constant disturbance torque (N m)")
    counts_per_rev: float = _key(10_000.0, Limit(),
                                 "torque drive: encoder counts (LSB) per motor revolution")
    mass: float = _key(200.0, Limit(), "two-mass drive: table mass M (kg); ja is then the motor's "
                                       "side alone (rotor, coupling, screw), and fc, load act on "
                                       "the table (as torques at the motor)")
    ks: float = _key(1e8, Limit(), "two-mass drive: axial stiffness Ks of screw and coupling "
                                   "between motor and table (N/m)")
    cs: float = _key(0.0, Limit(), "two-mass drive: damping of that stiffness (N s/m)")
    lead: float = _key(0.01, Limit(), "two-mass drive: ball screw lead (m per revolution)")
    scale: bool = _key(False, Boolean(), "two-mass drive: the encoder is a linear scale on the "
                                         "table; false: on the motor")


@dataclass(frozen=True)
class RunConfig(_Checked):
    """Options of the run itself."""

    max_time_s: float | None = _key(None, OrAbsent(Limit(0, low_open=True, unit="s")),
                                    "stop the run after this much simulated time (s); absent: "
                                    "the command line's limit")
    strict_feed: bool = _key(False, Boolean(),
                             "refuse a feed above the K3701's maximum; false: run it at the "
                             "maximum, as a controller clamps it, with one warning")


#: The host's contour controllers (``[contour] controller``): none, Koren's cross-coupled
#: controller, Koren and Lo's variable-gain one, the contour-error paper's CEC.
CONTOUR_CONTROLLERS = ("none", "ccc", "vgccc", "cec")


@dataclass(frozen=True)
class ContourConfig(_Checked):
    """The host's contour controller (``[contour]``): sampled every ``period_ms``, it reads the
    axes' positions over the bus and acts on them through each K3702's correction pulses
    (:mod:`k37.firmware_model.contour`)."""

    controller: str = _key("none", OneOf(CONTOUR_CONTROLLERS),
                           "contour controller: none, Koren's cross-coupled controller (ccc), "
                           "Koren and Lo's variable-gain one (vgccc), or the contour-error "
                           "paper's contour error controller (cec)")
    period_ms: float = _key(1.0, Limit(0.05, 100.0, unit="ms"),
                            "its sampling period (ms); the contour-error paper's: 1 ms")
    kcp: float = _key(7.0, Limit(0.0, 1000.0), "proportional gain of its PID on the contour "
                                               "error; the contour-error paper's: 7")
    kci: float = _key(50.0, Limit(0.0, 1e5, unit="1/s"),
                      "integral gain (1/s); the contour-error paper's: 50")
    kcd: float = _key(0.5, Limit(0.0, 10.0, unit="s"),
                      "derivative gain (s); the contour-error paper's: 0.5")

    @property
    def enabled(self) -> bool:
        return self.controller != "none"


@dataclass(frozen=True)
class Job:
    """A machine, its servos and a parsed program; ``axis_accel``: the axes that have their own
    accel/decel circuit (``[machine.x]``, ...)."""

    name: str
    machine: MachineConfig
    servo: dict[str, ServoConfig]
    program: Program
    run: RunConfig = field(default_factory=RunConfig)
    axis_accel: dict[str, AxisAccelConfig] = field(default_factory=dict)
    contour: ContourConfig = field(default_factory=ContourConfig)

    def __post_init__(self) -> None:
        if self.axis_accel and self.machine.accel != Accel.POST.value:
            raise ValueError(f"per-axis accel/decel ([machine.{next(iter(self.axis_accel))}]) "
                             f"needs machine.accel = \"post\", not {self.machine.accel!r}")
        fa = rate_limit(width=DIVIDER_WIDTH, f_clk=self.machine.clock_hz)
        for axis in self.fa_axes():
            fa.check(f"machine.{axis}.accel_fa_hz", self.axis_accel[axis].accel_fa_hz)

    def accel_circuits(self) -> dict[str, tuple[str, int]]:
        """Each axis's own accel/decel circuit as (shape, bits), for the chipset."""
        return {axis: config.circuit(self.machine) for axis, config in self.axis_accel.items()}

    def fa_axes(self) -> tuple[str, ...]:
        """The axes whose circuit has an addition clock of its own, in axis order."""
        return tuple(axis for axis in self.machine.axis_names
                     if axis in self.axis_accel and self.axis_accel[axis].accel_fa_hz is not None)

    def fa_hz(self, axis: str) -> float:
        """The addition clock (Hz) of axis ``axis``'s circuit: its own, else the machine's."""
        config = self.axis_accel.get(axis)
        return self.machine.accel_fa_hz if config is None else config.fa_hz(self.machine)

    def to_dict(self) -> dict[str, Any]:
        """The JSON-able form of the job's configuration (the program as a summary)."""
        machine = {**self.machine.to_dict(),
                   **{axis: config.to_dict() for axis, config in self.axis_accel.items()}}
        return {"name": self.name, "machine": machine,
                "servo": {axis: self.servo[axis].to_dict() for axis in self.machine.axis_names},
                "program": self.program.to_dict(), "run": self.run.to_dict(),
                "contour": self.contour.to_dict()}


def demo_job() -> Job:
    """The built-in demo (:data:`DEMO_GCODE`) on the default machine."""
    return gcode_job("demo", DEMO_GCODE, "<demo>")


def gcode_job(name: str, text: str, source: str, *, frontend: str = "builtin",
              arc_tolerance: float | None = None) -> Job:
    """G-code ``text`` (``source`` names it in errors) on the default machine and servos (three
    axes if the program moves Z: :func:`parse_for_machine`), read by the front end
    ``frontend`` (:data:`k37.firmware_model.gcode.canon.FRONTENDS`)."""
    machine, program = parse_for_machine(MachineConfig(), text, source=source,
                                         frontend=frontend, arc_tolerance=arc_tolerance)
    return Job(name, machine, dict.fromkeys(machine.axis_names, ServoConfig()), program)


def moves_z(program: Program) -> bool:
    """Whether a program parsed for three axes needs them: a move of Z, or an arc outside
    the XY plane."""
    return any(item.end[2] != item.start[2] or getattr(item, "plane", 17) != 17
               for item in program.moves)


def parse_for_machine(machine: MachineConfig, text: str, *, source: str, axes_given: bool = False,
                      frontend: str = "builtin", **options: Any
                      ) -> tuple[MachineConfig, Program]:
    """Parse ``text`` with the front end ``frontend`` for ``machine``; unless the job set
    ``machine.axes`` (``axes_given``), a program that moves Z gets the three-axis machine, any
    other the two-axis one."""
    def parsed(m: MachineConfig) -> Program:
        return FRONTENDS[frontend](text, source=source, lsb_mm=m.lsb_mm, sqrt2=m.sqrt2,
                                   axes=m.axes, **options)
    if not axes_given:
        if not names_third_axis(text):
            # Most programs: the two-axis machine's parse is the answer when it succeeds (a
            # program that moved Z would fail there), and the program is parsed once.
            try:
                return replace(machine, axes=2), parsed(replace(machine, axes=2))
            except GcodeError:
                pass
        try:
            program = parsed(replace(machine, axes=3))
        except GcodeError as error:
            # A program the three-axis machine refuses: the errors of the machine its words
            # ask for, three axes where they name Z (or a plane with Z), two otherwise, never
            # "two axes" hiding a real error.
            machine = replace(machine, axes=2)
            try:
                return machine, parsed(machine)
            except GcodeError as error2:
                raise (error if names_third_axis(text) else error2) from None
        if moves_z(program):
            return replace(machine, axes=3), program
        machine = replace(machine, axes=2)
    return machine, parsed(machine)
