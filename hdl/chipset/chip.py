"""The chipset (``docs/chips/chipset.md``): every chip on one 8-bit host bus; two axes (the paper's)
or three.

Signal flow, with the accel/decel circuit in one of three places::

    FEED (rate multiplier) -> DECEL (FP budget) -> [pre: ACCEL] -> FP -> K3701
    K3701 +-X -> [post: ACCEL] -> K3702 X -> DAC X      encoder X -> +-FB -> K3702 X
    K3701 +-Y -> [post: ACCEL] -> K3702 Y -> DAC Y      encoder Y -> +-FB -> K3702 Y
    K3701 +-Z -> [post: ACCEL] -> K3702 Z -> DAC Z      encoder Z -> +-FB -> K3702 Z
                                                        (three-axis chipset only)

where ACCEL is the accel/decel circuit of the chosen :class:`~k37.hdl.chipset.map.AccelShape` (per
axis in post). Every circuit adds at the FEED chip's addition clock fa, or, in post, at an axis's
own (``axis_fa``: the FEED chip's per-axis fa build, :func:`k37.hdl.feed.map.feed_rate.feed_map`).

Host bus: an 8085 I/O port address is ``chip select << 5 | register address``; the chip
selects are :data:`k37.hdl.chipset.map.CHIP_SELECTS`, the registers each chip's own map. The
three-axis chipset adds the Z axis's K3702 and encoder interface on the one select left, 7,
which decodes A4 as well: the K3702 at 0xe0 (A4 = 0), the encoder interface at 0xf0 (A4 = 1,
:data:`~k37.hdl.chipset.map.SUB_WINDOWS`), and its K3701 is the three-axis build
(:data:`k37.hdl.k3701.map.K3701_MAP_3`, a superset of the two-axis map).
:func:`k37.hdl.chipset.map.port` turns a (chip, register) pair into the port address, for the
firmware and the docs alike; that module holds everything the host and a job see of the
chipset, without Amaranth.
"""

import enum
import operator
from collections.abc import Iterable
from dataclasses import replace
from functools import reduce

from amaranth.hdl import Array, Cat, Module, Mux, Signal, signed
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from k37.hdl.accel.bell import AccelBell
from k37.hdl.accel.exponential import AccelDecel
from k37.hdl.accel.linear import AccelLinear
from k37.hdl.bus.hostbus import HostBus
from k37.hdl.chipset.map import (
    ACCEL_BITS,
    REG_BITS,
    SUB_WINDOWS,
    Z_CHIPS,
    Accel,
    AccelShape,
    axis_names,
    chip_selects,
)
from k37.hdl.common.observation import FreeRunning, Observed
from k37.hdl.encoder.chip import EncoderInterface
from k37.hdl.feed.decel_control import DecelControl
from k37.hdl.feed.feed_rate import FeedRate
from k37.hdl.feed.map.feed_rate import feed_map
from k37.hdl.k3701.chip import K3701
from k37.hdl.k3702.chip import K3702
from k37.hdl.k3702.map import COUNTER_WIDTH

__all__ = ["AxisPins", "Chipset"]

#: The circuit of each shape; each takes (n, counter_width, bidirectional).
_ACCEL_CIRCUITS = {AccelShape.EXPONENTIAL: AccelDecel, AccelShape.LINEAR: AccelLinear,
                   AccelShape.BELL: AccelBell}

def _enum(kind: type[enum.Enum], name: str, value: object) -> enum.Enum:
    try:
        return kind(value)
    except ValueError:
        raise ValueError(f"{name} must be one of {', '.join(k.value for k in kind)}, "
                         f"not {value!r}") from None


class AxisPins(wiring.Signature):
    """One axis's pins towards its servo drive and encoder (the chipset's view).

    Members
    -------
    dac : Out(16)
        D/A word (offset binary, N bits right-aligned).
    alarm_n : Out(1)
        ALARM, active low.
    a, a_n, b, b_n : In(1)
        Encoder lines.
    com_pos, com_neg, fb_pos, fb_neg : Out(1)
        Observation: the command and feedback pulses the K3702 counts.
    command, error : Out(signed(24))
        Observation: the K3702's counters.
    """

    def __init__(self):
        super().__init__({
            "dac": Out(16), "alarm_n": Out(1),
            "a": In(1), "a_n": In(1), "b": In(1), "b_n": In(1),
            "com_pos": Out(1), "com_neg": Out(1), "fb_pos": Out(1), "fb_neg": Out(1),
            "command": Out(signed(COUNTER_WIDTH)), "error": Out(signed(COUNTER_WIDTH)),
        })


class Chipset(Observed, wiring.Component):
    """K3701, a K3702 and an encoder interface per axis and the feed path on one host bus.

    Parameters
    ----------
    axes : int
        2 (the paper's chipset) or 3 (:data:`MACHINE_AXES`): the three-axis chipset has the
        three-axis K3701 and a Z axis (its K3702 and encoder interface on chip select 7).
    accel : Accel or str
        Placement of the accel/decel circuit (``"pre"``, ``"post"`` or ``"none"``).
    accel_bits : int
        Accumulator width n of the accel/decel circuit(s) (tau = 2^n / fa), in
        :data:`ACCEL_BITS`.
    accel_shape : AccelShape or str
        The accel/decel circuit: ``"exponential"`` (the paper's), ``"linear"`` or ``"bell"``.
    axis_accel : dict
        Post placement only: per axis, a ``(shape, bits)`` pair that replaces ``accel_shape``
        and ``accel_bits`` for that axis's circuit (axes not named keep them).
    axis_fa : iterable of str
        Post placement only: the axes whose circuit adds at an addition clock of its own (the
        FEED chip's per-axis fa build, register ``FA_INC_X``, ...), not at the shared fa.

    Members
    -------
    bus : In(HostBus(8))
        Host bus; address = chip select (3 bits) and register (5 bits). A read's data
        appears in the following cycle, from the chip that was read.
    irq_interp : Out(1)
        K3701 data request (the 8085's RST 7.5 in the firmware model).
    irq_alarm : Out(1)
        Either K3702's alarm interrupt (RST 6.5).
    fp : Out(1)
        Observation: the feed pulses the K3701 receives.
    step_x_pos, step_x_neg, step_y_pos, step_y_neg : Out(1)
        Observation: the K3701's step pulses (and ``step_z_*`` on three axes).
    x, y : Out(AxisPins())
        The axes (and ``z`` on three axes).

    Simulation only (attributes, not pins: see :mod:`k37.hdl.common.observation`)
    ----------------------------------------------------------------
    quiet : Signal(1)
        Every accel/decel circuit is ``quiet`` (no output pulse pending; a linear or bell
        circuit drained) and the K3701 is ``quiet``, so the free-running state changes nothing
        else until the next feed pulse through the open decel gate, an accumulator's next
        carry or the K3701's latency count reaching 1; combinational.
    free_running : FreeRunning
        The feed-rate generator's dividers and rate multiplier (whose pulses matter while the
        decel gate is open), each exponential accel/decel accumulator (adding x at each
        strobe of its fa: the shared one or its axis's own) and the K3701's latency count.
    """

    def __init__(self, *, accel: Accel | str = Accel.PRE, accel_bits: int = 15, axes: int = 2,
                 accel_shape: AccelShape | str = AccelShape.EXPONENTIAL,
                 axis_accel: dict[str, tuple[AccelShape | str, int]] | None = None,
                 axis_fa: Iterable[str] = ()):
        self.accel = _enum(Accel, "accel", accel)
        self.accel_bits = ACCEL_BITS.check("accel_bits", accel_bits)
        self.axes = axis_names(axes)
        self.chips = chip_selects(axes)
        self.accel_shape = _enum(AccelShape, "accel_shape", accel_shape)
        axis_accel = axis_accel or {}
        for axis in axis_accel:
            if axis not in self.axes:
                raise ValueError(f"axis_accel: no axis {axis!r}; axes are "
                                 f"{', '.join(self.axes)}")
        if axis_accel and self.accel is not Accel.POST:
            raise ValueError("axis_accel needs accel = post (one circuit per axis)")
        axis_fa = set(axis_fa)
        for axis in axis_fa:
            if axis not in self.axes:
                raise ValueError(f"axis_fa: no axis {axis!r}; axes are {', '.join(self.axes)}")
        if axis_fa and self.accel is not Accel.POST:
            raise ValueError("axis_fa needs accel = post (one circuit per axis)")
        #: The axes whose circuit has an addition clock of its own, in axis order.
        self.axis_fa = tuple(axis for axis in self.axes if axis in axis_fa)
        if self.axis_fa:
            self.chips = {**self.chips, "FEED": (self.chips["FEED"][0], feed_map(self.axis_fa))}
        #: Each axis's circuit (post placement), as (shape, bits).
        self.axis_accel = {
            axis: (_enum(AccelShape, f"{axis}.accel_shape", axis_accel[axis][0]),
                   ACCEL_BITS.check(f"{axis}.accel_bits", axis_accel[axis][1]))
            if axis in axis_accel else (self.accel_shape, self.accel_bits) for axis in self.axes}
        #: The accel/decel circuits by submodule name: (class, bits, bidirectional).
        self._accel: dict[str, tuple[type, int, bool]] = {}
        if self.accel is Accel.PRE:
            self._accel["accel"] = (_ACCEL_CIRCUITS[self.accel_shape], self.accel_bits, False)
        elif self.accel is Accel.POST:
            for axis, (shape, bits) in self.axis_accel.items():
                self._accel[f"accel_{axis}"] = (_ACCEL_CIRCUITS[shape], bits, True)
        super().__init__({
            "bus": In(HostBus(8)),
            "irq_interp": Out(1), "irq_alarm": Out(1), "fp": Out(1),
            **{f"step_{axis}_{sign}": Out(1) for axis in self.axes for sign in ("pos", "neg")},
            **{axis: Out(AxisPins()) for axis in self.axes},
        })
        self.quiet = Signal()

    @property
    def probes(self) -> tuple[str, ...]:
        """Observation outputs, not pins of the chipset (the Verilog export keeps them
        inside): the FP into the K3701, its step pulses, and each axis's K3702 inputs and
        counters."""
        return ("fp", *(f"step_{axis}_{sign}" for axis in self.axes for sign in ("pos", "neg")),
                *(f"{axis}__{name}" for axis in self.axes
                  for name in ("com_pos", "com_neg", "fb_pos", "fb_neg", "command", "error")))

    @property
    def free_running(self) -> FreeRunning:
        """See "Simulation only" above."""
        feed = FeedRate.declare(self.axis_fa).under("feed")
        gated = tuple(replace(c, gate="decel.gate_open") for c in feed.counters)
        carries = tuple(replace(c, clock=f"feed.{FeedRate.fa_clock(self._fa_axis(path))}")
                        for path, (cls, bits, bidirectional) in self._accel.items()
                        for c in cls.declare(bits, bidirectional).under(path).carries)
        return replace(feed, counters=gated).merge(
            FreeRunning(carries=carries), K3701.declare().under("k3701"),
            quiet="quiet")

    def _fa_axis(self, path: str) -> str | None:
        """The axis whose own fa the circuit at ``path`` adds at (None: the shared fa)."""
        axis = path.removeprefix("accel_")
        return axis if path != axis and axis in self.axis_fa else None

    def elaborate(self, platform) -> Module:
        m = Module()
        chips = {
            "K3701": K3701(axes=len(self.axes)),
            **{f"K3702_{a.upper()}": K3702() for a in self.axes},
            **{f"ENCODER_{a.upper()}": EncoderInterface() for a in self.axes},
            "FEED": FeedRate(self.axis_fa), "DECEL": DecelControl(),
        }
        for name, chip in chips.items():
            m.submodules[name.lower()] = chip
        self._decode_bus(m, chips)
        interp, feed, decel = chips["K3701"], chips["FEED"], chips["DECEL"]

        m.d.comb += decel.inp.eq(feed.out)
        quiet = [interp.quiet]  # and every accel/decel circuit's
        circuits = {}
        for path, (cls, bits, bidirectional) in self._accel.items():
            m.submodules[path] = circuits[path] = circuit = cls(bits, bidirectional=bidirectional)
            axis = self._fa_axis(path)
            m.d.comb += circuit.add.eq(feed.fa if axis is None else getattr(feed, f"fa_{axis}"))
            quiet.append(circuit.quiet)
        if self.accel is Accel.PRE:
            accel = circuits["accel"]
            m.d.comb += [accel.inp.eq(decel.out), interp.fp.eq(accel.out)]
        else:
            m.d.comb += interp.fp.eq(decel.out)
        m.d.comb += [
            self.fp.eq(interp.fp),
            *(getattr(self, f"step_{axis}_{sign}").eq(getattr(interp, f"{axis}_{sign}"))
              for axis in self.axes for sign in ("pos", "neg")),
            self.irq_interp.eq(interp.irq),
            self.irq_alarm.eq(reduce(operator.or_,
                                     (chips[f"K3702_{a.upper()}"].irq for a in self.axes))),
        ]

        for axis in self.axes:
            pins = getattr(self, axis)
            ctrl = chips[f"K3702_{axis.upper()}"]
            enc = chips[f"ENCODER_{axis.upper()}"]
            step_pos, step_neg = getattr(interp, f"{axis}_pos"), getattr(interp, f"{axis}_neg")
            if self.accel is Accel.POST:
                post = circuits[f"accel_{axis}"]
                m.d.comb += [post.inp_pos.eq(step_pos), post.inp_neg.eq(step_neg)]
                step_pos, step_neg = post.out_pos, post.out_neg
            m.d.comb += [
                ctrl.com_pos.eq(step_pos), ctrl.com_neg.eq(step_neg),
                enc.a.eq(pins.a), enc.a_n.eq(pins.a_n), enc.b.eq(pins.b), enc.b_n.eq(pins.b_n),
                ctrl.fb_pos.eq(enc.fb_pos), ctrl.fb_neg.eq(enc.fb_neg),
                pins.dac.eq(ctrl.dac), pins.alarm_n.eq(ctrl.alarm_n),
                pins.com_pos.eq(step_pos), pins.com_neg.eq(step_neg),
                pins.fb_pos.eq(enc.fb_pos), pins.fb_neg.eq(enc.fb_neg),
                pins.command.eq(ctrl.command), pins.error.eq(ctrl.error),
            ]
        m.d.comb += self.quiet.eq(Cat(*quiet).all())
        return m

    def _decode_bus(self, m: Module, chips: dict) -> None:
        """Chip selects from the top address bits; read data from the chip last read."""
        cs = self.bus.addr[REG_BITS:]
        read_cs = Signal.like(cs)
        with m.If(self.bus.r_stb):
            m.d.sync += read_cs.eq(cs)
        r_data = Array(Signal(8, name=f"r_data_{k}") for k in range(1 << len(cs)))
        if SUB_WINDOWS.keys() & chips.keys():   # select 7's two windows, told apart by A4
            read_a4 = Signal()
            with m.If(self.bus.r_stb):
                m.d.sync += read_a4.eq(self.bus.addr[REG_BITS - 1])
        for name, chip in chips.items():
            select = self.chips[name][0]
            width = len(chip.bus.addr)
            window = SUB_WINDOWS.get(name, 0)
            hit = (cs == select) & (self.bus.addr[width:REG_BITS] == window >> width)
            m.d.comb += [
                chip.bus.addr.eq(self.bus.addr[:width]),
                chip.bus.w_data.eq(self.bus.w_data),
                chip.bus.w_stb.eq(self.bus.w_stb & hit),
                chip.bus.r_stb.eq(self.bus.r_stb & hit),
            ]
            if name in SUB_WINDOWS:
                m.d.comb += r_data[select].eq(Mux(read_a4, chip.bus.r_data,
                                                  chips["K3702_Z"].bus.r_data))
            elif name not in Z_CHIPS:
                m.d.comb += r_data[select].eq(chip.bus.r_data)
        m.d.comb += self.bus.r_data.eq(r_data[read_cs])
