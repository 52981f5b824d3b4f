"""The chipset as the host and a job see it: chip selects and ports, axes, accel/decel placement
and shape (:class:`k37.hdl.chipset.chip.Chipset` builds the gateware from them)."""

from __future__ import annotations

import enum

from k37.hdl.bus.registers import Register, RegisterMap
from k37.hdl.common.constants import ALL_AXES
from k37.hdl.common.params import Limit
from k37.hdl.encoder.map import ENCODER_MAP
from k37.hdl.feed.map.decel_control import DECEL_MAP
from k37.hdl.feed.map.feed_rate import FEED_MAP, FEED_MAP_AXIS_FA
from k37.hdl.k3701.map import K3701_MAP, K3701_MAP_3
from k37.hdl.k3702.map import K3702_MAP

__all__ = ["ACCEL_BITS", "ALL_AXES", "AXES", "CHIP_SELECTS", "MACHINE_AXES", "REG_BITS",
           "SUB_WINDOWS", "Z_CHIPS", "Accel", "AccelShape", "axis_names", "chip_register",
           "chip_selects", "port"]

#: Address bits of a register inside a chip; the chip select is above them.
REG_BITS = 5
#: The axis counts a chipset is built with (the job key ``machine.axes``).
MACHINE_AXES = Limit(2, 3, integer=True)


def axis_names(axes: int) -> tuple[str, ...]:
    """The axes of an ``axes``-axis chipset (``("x", "y")`` or ``("x", "y", "z")``)."""
    return ALL_AXES[:MACHINE_AXES.check("axes", axes)]


#: The paper's two axes (the default machine's).
AXES = axis_names(2)


class Accel(enum.Enum):
    """Where the accel/decel circuit sits."""

    #: Before the interpolator, on FP ("FP control", the paper's choice).
    PRE = "pre"
    #: After the interpolator, one per axis between the K3701 and the K3702.
    POST = "post"
    #: No accel/decel circuit.
    NONE = "none"


class AccelShape(enum.Enum):
    """Which accel/decel circuit: the velocity profile a step of the input rate takes."""

    #: The paper's up/down counter + accumulator, fo = fi (1 - exp(-t / tau)).
    EXPONENTIAL = "exponential"
    #: A moving average over T = 2^n / fa (:class:`k37.hdl.accel.linear.AccelLinear`): a ramp.
    LINEAR = "linear"
    #: The moving average, then the exponential circuit (:class:`k37.hdl.accel.bell.AccelBell`).
    BELL = "bell"


#: The accumulator widths n the chipset's accel/decel circuits are built with.
ACCEL_BITS = Limit(4, 24, integer=True)


#: Chip select of each chip instance of the two-axis chipset, and the register map it
#: answers with.
CHIP_SELECTS: dict[str, tuple[int, RegisterMap]] = {
    "K3701": (0, K3701_MAP),
    "K3702_X": (1, K3702_MAP),
    "K3702_Y": (2, K3702_MAP),
    "ENCODER_X": (3, ENCODER_MAP),
    "ENCODER_Y": (4, ENCODER_MAP),
    "FEED": (5, FEED_MAP),
    "DECEL": (6, DECEL_MAP),
}
#: The third axis's chips, both on select 7 (A4 tells them apart: :data:`SUB_WINDOWS`).
Z_CHIPS: dict[str, tuple[int, RegisterMap]] = {"K3702_Z": (7, K3702_MAP),
                                                 "ENCODER_Z": (7, ENCODER_MAP)}
#: Register address offset of a chip sharing its select (its window inside the select's 32
#: ports); every other chip's is 0.
SUB_WINDOWS = {"ENCODER_Z": 0x10}


def chip_selects(axes: int = 2) -> dict[str, tuple[int, RegisterMap]]:
    """Chip select and register map of each chip of an ``axes``-axis chipset."""
    if MACHINE_AXES.check("axes", axes) == 2:
        return CHIP_SELECTS
    return {**CHIP_SELECTS, "K3701": (0, K3701_MAP_3), **Z_CHIPS}


#: What the host addresses: every chip of the largest chipset (the two-axis K3701's registers
#: are at the same ports in the three-axis map; the FEED chip's per-axis fa build, a superset
#: of the plain chip's map).
_HOST_CHIPS = {**chip_selects(3), "FEED": (CHIP_SELECTS["FEED"][0], FEED_MAP_AXIS_FA)}


def _chip(chip: str) -> tuple[int, RegisterMap]:
    try:
        return _HOST_CHIPS[chip]
    except KeyError:
        raise KeyError(f"no chip {chip!r}; chips are {', '.join(_HOST_CHIPS)}") from None


def chip_register(chip: str, name: str) -> Register:
    """Register ``name`` of ``chip`` (KeyError naming what is unknown)."""
    return _chip(chip)[1][name]


def port(chip: str, register: str, byte: int = 0) -> int:
    """The 8085 I/O port address of byte ``byte`` of ``register`` of ``chip``."""
    cs, regmap = _chip(chip)
    reg = regmap[register]
    if not 0 <= byte < reg.nbytes:
        raise ValueError(f"{chip} {register} has {reg.nbytes} byte(s), not byte {byte}")
    return cs << REG_BITS | (SUB_WINDOWS.get(chip, 0) + reg.addr + byte)
