"""The KM3701's registers as the host sees them, and the register values that load a block
(:class:`k37.hdl.k3701.chip.K3701` implements them; :mod:`k37.hdl.k3701.model.chip` states the
behaviour)."""

from __future__ import annotations

from dataclasses import replace

from k37.hdl.bus.registers import Access, Field, Register, RegisterMap
from k37.hdl.k3701.block import Block, Kind

__all__ = ["K3701_MAP", "K3701_MAP_3", "block_registers", "k3701_map"]

_COORD = "24-bit two's complement, -(2^23-1)..2^23-1 LSB"

K3701_MAP = RegisterMap("K3701", 1, (
    Register("X", 0x00, 24, Access.RW,
             f"write: end point Xe relative to the start; read: remaining distance Xm "
             f"({_COORD})", signed=True),
    Register("Y", 0x03, 24, Access.RW,
             f"write: end point Ye relative to the start; read: remaining distance Ym "
             f"({_COORD})", signed=True),
    Register("I", 0x06, 24, Access.W,
             f"circular: centre X relative to the start; parabolic: X of the point whose "
             f"tangent is parallel to the chord, relative to the start ({_COORD}); "
             f"exponential: |k| >= 2, k the curve's constant (LSB of the abscissa; CTRL.cw: "
             f"k < 0)", signed=True),
    Register("J", 0x09, 24, Access.W,
             f"circular: centre Y relative to the start; parabolic: Y of that point "
             f"({_COORD}); exponential: the integer part of the curve's offset c, >= 0",
             signed=True),
    Register("CTRL", 0x0C, 8, Access.RW, "control word of the next block (reads back)", fields=(
        Field("circular", 0, 1, "interpolation type: 0 linear, 1 circular"),
        Field("cw", 1, 1, "circular direction: 0 CCW, 1 CW; exponential: the curve's constant "
                          "k is negative (it flattens towards the end)"),
        Field("sqrt2", 2, 1, "sqrt(2) control: a diagonal step costs 1.5 FP"),
        Field("quadrant", 3, 2, "circular end-point quadrant minus 1 (0..3 = quadrant 1..4)"),
        Field("parabolic", 5, 1, "interpolation type parabolic (``circular`` is then ignored)"),
        Field("swap", 6, 1, "parabolic: the abscissa is Y, the parabola's axis parallel to X "
                            "(else the abscissa is X, the axis parallel to Y); exponential: "
                            "the abscissa is Y (logarithmic interpolation), else X"),
        Field("exponential", 7, 1, "interpolation type exponential (``circular`` and "
                                   "``parabolic`` are then ignored)"),
    )),
    Register("CMD", 0x0D, 8, Access.W, "commands, acted on in the cycle after the write",
             fields=(
                 Field("start", 0, 1, "start the block held in X, Y, I, J, CTRL "
                                      "(refused with ERROR while BUSY)"),
                 Field("ack", 1, 1, "acknowledge (clear) the data-request interrupt"),
                 Field("clear", 2, 1, "clear the ERROR and OVERRUN status bits"),
             )),
    Register("STATUS", 0x0E, 8, Access.R, "status", after_reset=0, fields=(
        Field("busy", 0, 1, "a block is running"),
        Field("irq", 1, 1, "data request: the block ended (held until CMD.ack)"),
        Field("error", 2, 1, "invalid block data, an arc that left its end quadrant, a "
                             "parabola or exponential that passed its end, or START while BUSY "
                             "(sticky until CMD.clear)"),
        Field("overrun", 3, 1, "an FP arrived while one was already held and was lost "
                               "(sticky until CMD.clear)"),
    )),
    Register("E", 0x16, 24, Access.W,
             "exponential: the fraction of the curve's offset c = J - E / k, -1 < E / k <= 0 "
             "(not checked)", signed=True),
), doc="Interpolator: linear, circular, parabolic and exponential (logarithmic) interpolation "
       "of one block, step pulses out.")

_CTRL = K3701_MAP["CTRL"]
#: The curve modes: the two-axis chip's CTRL.parabolic, swap and exponential, which the
#: three-axis chip keeps in MODE (its CTRL bits 5-6 are the plane).
_MODES = ("parabolic", "swap", "exponential")
#: The three-axis K3701 (``K3701(axes=3)``): the two-axis map, the third axis's Z, a helix's
#: step count H, CTRL.plane, and the curve modes in MODE (addresses from 0x10: the two-axis
#: chip's stay as they are, E too).
K3701_MAP_3 = RegisterMap("K3701", 1, (
    *(replace(r, fields=(*(f for f in r.fields if f.name not in _MODES), Field(
        "plane", 5, 2, "the block's axes on the machine's: 0 (X, Y, Z) G17, 1 (Z, X, Y) "
                       "G18, 2 (Y, Z, X) G19, 3 as 0; an arc, a parabola or an exponential "
                       "runs in the first two")))
      if r is _CTRL else r for r in K3701_MAP if r.name != "E"),
    Register("Z", 0x10, 24, Access.RW,
             f"three-axis chip: write: the third coordinate Ze of the end point (a line's, or "
             f"a helix's travel along the plane's normal; a parabola or an exponential is "
             f"refused unless it is 0); read: remaining distance Zm ({_COORD})", signed=True),
    Register("H", 0x13, 24, Access.W,
             "three-axis chip, helix: the arc's step count N, over which the third axis makes "
             "its Ze moves, abs(Ze) <= N (a DDA on the arc's steps: it ends with the arc)"),
    K3701_MAP["E"],
    Register("MODE", 0x19, 8, Access.RW,
             "three-axis chip: the next block's curve mode, beside CTRL (reads back; the host "
             "writes it for every block)", fields=(
                 Field("parabolic", 0, 1, "interpolation type parabolic (CTRL.circular is "
                                          "then ignored)"),
                 replace(_CTRL.field("swap"), offset=1),
                 Field("exponential", 2, 1, "interpolation type exponential (CTRL.circular "
                                            "and MODE.parabolic are then ignored)"))),
), doc="Interpolator: linear, circular, parabolic and exponential (logarithmic) interpolation "
       "of one block, step pulses out. The three-axis build adds Z, H, CTRL.plane and MODE "
       "(the curve modes of the two-axis CTRL).")


def k3701_map(axes: int) -> RegisterMap:
    """The register map of the K3701 of a chipset with ``axes`` axes (2 or 3)."""
    return K3701_MAP if axes == 2 else K3701_MAP_3


def block_registers(block: Block, axes: int = 2) -> dict[str, int]:
    """The registers that load ``block`` into the K3701 of an ``axes``-axis chipset, in the
    order the host writes them (CTRL last; the block then runs on CMD.start). Lines leave I
    and J as they are, and plain arcs H; the three-axis chip's MODE is written for every
    block."""
    values = {"X": block.xe, "Y": block.ye}
    if axes == 3:
        values["Z"] = block.ze
    if block.kind is not Kind.LINEAR:
        values |= {"I": block.i, "J": block.j}
        if block.ze:
            values["H"] = block.helix_steps
        if block.kind is Kind.EXPONENTIAL:
            values["E"] = block.frac
    modes = {"parabolic": int(block.kind is Kind.PARABOLIC), "swap": int(block.swap),
             "exponential": int(block.kind is Kind.EXPONENTIAL)}
    if axes == 3:
        values["MODE"] = K3701_MAP_3["MODE"].encode(**modes)
    fields = {"plane": block.plane} if axes == 3 else modes
    values["CTRL"] = k3701_map(axes)["CTRL"].encode(
        circular=int(block.kind is Kind.CIRCULAR), cw=int(block.cw), sqrt2=int(block.sqrt2),
        quadrant=block.quadrant - 1, **fields)
    return values
