"""The exported chips' reference models as the co-simulations drive them: a bus model of the
register bank, random host operations, and one driver per exported chip that gives its expected
pins, cycle by cycle, from its plain-Python reference model."""

from __future__ import annotations

import functools
import random
from collections.abc import Callable, Iterator

from k37.hdl.accel.model.bell import AccelBellModel
from k37.hdl.accel.model.exponential import AccelDecelModel
from k37.hdl.accel.model.linear import AccelLinearModel
from k37.hdl.bus.model.hostbus import RegisterBankModel
from k37.hdl.bus.registers import Register, RegisterMap
from k37.hdl.encoder.map import ENCODER_MAP
from k37.hdl.encoder.model import EncoderModel
from k37.hdl.feed.map.decel_control import DECEL_MAP
from k37.hdl.feed.map.feed_rate import DIVIDER_WIDTH, FA_AXES, FEED_MAP, FEED_MAP_AXIS_FA
from k37.hdl.feed.model.decel_control import DecelControlModel
from k37.hdl.feed.model.divider import PhaseDividerModel
from k37.hdl.feed.model.feed_rate import FeedRateModel
from k37.hdl.feed.model.rate_multiplier import RateMultiplierModel
from k37.hdl.k3701.block import Block, Kind
from k37.hdl.k3701.map import K3701_MAP, K3701_MAP_3
from k37.hdl.k3701.model.chip import K3701Model
from k37.hdl.k3702.map import K3702_MAP
from k37.hdl.k3702.model import K3702Model
from k37.sim.backends.verilator.model import Model, build
from k37.sim.fpga.export import verilog_text

SEEDS = (1, 2)
CYCLES = 20000

Op = tuple[str, int, int] | None  # ("w", addr, data), ("r", addr, 0) or idle


@functools.cache
def built(name: str) -> Model:
    return build(verilog_text(name), name)


# --- the host bus as the wrapper's pins see it -------------------------------------------------

class BusModel:
    """Byte-level :class:`~k37.hdl.bus.hostbus.RegisterBank`: shadows for writes, latches for
    reads."""

    def __init__(self, regmap: RegisterMap):
        self.regmap = regmap
        self.reset()

    def reset(self) -> None:
        self.shadow: dict[str, int] = {}
        self.latch: dict[str, int] = {}

    def write(self, addr: int, data: int) -> tuple[str, int] | None:
        """A byte write: the (register, value) it commits, or None."""
        hit = self.regmap.at(addr)
        if hit is None or not hit[0].access.writable:
            return None
        reg, k = hit
        raw = self.shadow.get(reg.name, 0) & ~(0xFF << 8 * k) | data << 8 * k
        if k < reg.nbytes - 1:
            self.shadow[reg.name] = raw
            return None
        return reg.name, reg.from_bytes(raw.to_bytes(reg.nbytes, "little"))

    def read(self, addr: int, registers: dict[str, int]) -> int:
        """The byte a read of ``addr`` puts on D; ``registers`` as the chip presents them."""
        hit = self.regmap.at(addr)
        if hit is None or not hit[0].access.readable:
            return 0
        reg, k = hit
        if k == 0:
            self.latch[reg.name] = registers[reg.name] & ((1 << reg.width) - 1)
            return self.latch[reg.name] & 0xFF
        return self.latch.get(reg.name, 0) >> 8 * k & 0xFF


def host_ops(regmap: RegisterMap, value: Callable[[Register, random.Random], int],
             rng: random.Random, gap: int) -> Iterator[Op]:
    """Random host traffic: whole-register writes and reads, stray bytes, idle gaps."""
    writable = [r for r in regmap if r.access.writable]
    readable = [r for r in regmap if r.access.readable]
    while True:
        for _ in range(int(rng.expovariate(1 / gap))):
            yield None
        kind = rng.random()
        if kind < 0.5:
            reg = rng.choice(writable)
            raw = value(reg, rng) & ((1 << reg.width) - 1)
            for k in range(reg.nbytes):
                yield "w", reg.addr + k, raw >> 8 * k & 0xFF
                if rng.random() < 0.2:
                    yield None
        elif kind < 0.85:
            reg = rng.choice(readable)
            for k in range(reg.nbytes):
                yield "r", reg.addr + k, 0
        else:
            yield rng.choice("wr"), rng.randrange(1 << regmap.addr_width), rng.randrange(256)


# --- one adapter per block: the reference model behind the pins --------------------------------

class Chip:
    """A block's reference model as the co-simulation drives it.

    :meth:`cycle` takes the pins of one cycle and the register write that commits at its
    end; it returns the output pins expected in this cycle and the values of the readable
    registers at the rising edge that ends it (what a read of byte 0 snapshots).
    """

    name: str
    regmap: RegisterMap | None = None
    gap = 30  # mean idle cycles between host operations

    def reset(self) -> None:
        raise NotImplementedError

    def inputs(self, rng: random.Random) -> dict[str, int]:
        raise NotImplementedError

    def value(self, reg: Register, rng: random.Random) -> int:
        return rng.randrange(1 << reg.width)

    def cycle(self, pins: dict[str, int], write: tuple[str, int] | None
              ) -> tuple[dict[str, int], dict[str, int]]:
        raise NotImplementedError


class K3701Chip(Chip):
    name, regmap, gap = "k3701", K3701_MAP, 30
    #: The chip's axes (the three-axis build adds Z, H, CTRL.plane and the Z step pulses).
    axes = "xy"

    def reset(self) -> None:
        self.model = K3701Model(axes=len(self.axes))
        self.bank = RegisterBankModel(self.regmap)
        self.fp_rate = 0.4

    def inputs(self, rng):
        if rng.random() < 0.002:
            self.fp_rate = rng.choice((0.05, 0.4, 1.0))
        return {"fp": int(rng.random() < self.fp_rate)}

    def value(self, reg, rng):
        if reg.name == "CMD":  # mostly start, with its acknowledge and clear
            return rng.choice((1, 1, 3, 7, 2, 4, rng.randrange(256)))
        if reg.name == "CTRL":
            return rng.randrange(256) if rng.random() < 0.2 else rng.randrange(32)
        if reg.name == "H":  # a helix's step count: small, so that some helices run
            return rng.randint(0, 40)
        odd = rng.random()  # -2^23 is invalid; a long block runs past the test
        if odd < 0.05:
            return -(1 << 23) if odd < 0.02 else rng.randint(-(1 << 23), (1 << 23) - 1)
        return rng.randint(-12, 12)

    def cycle(self, pins, write):
        bank, regmap = self.bank, self.regmap
        cmd_reg, ctrl_reg = regmap["CMD"], regmap["CTRL"]
        cmd = bank.values["CMD"] if bank.w_stb("CMD") else 0
        block = None
        if cmd_reg.field("start").decode(cmd):
            v, ctrl = bank.values, bank.values["CTRL"]
            kind = Kind(ctrl_reg.field("circular").decode(ctrl))
            # the curve modes: in CTRL on the two-axis build, in MODE on the three-axis one
            where = regmap["MODE"] if "z" in self.axes else ctrl_reg
            modes = v[where.name]
            if where.field("exponential").decode(modes):
                kind = Kind.EXPONENTIAL
            elif where.field("parabolic").decode(modes):
                kind = Kind.PARABOLIC
            extra = {"swap": bool(where.field("swap").decode(modes)), "frac": v["E"]}
            if "z" in self.axes:  # the three-axis build: its third axis and plane
                extra |= {"ze": v["Z"], "plane": ctrl_reg.field("plane").decode(ctrl),
                          "helix_steps": v["H"]}
            block = Block(kind, v["X"], v["Y"], v["I"], v["J"],
                          bool(ctrl_reg.field("cw").decode(ctrl)),
                          bool(ctrl_reg.field("sqrt2").decode(ctrl)),
                          ctrl_reg.field("quadrant").decode(ctrl) + 1, **extra)
        out = self.model.cycle(fp=bool(pins["fp"]), start=block,
                               ack=bool(cmd_reg.field("ack").decode(cmd)),
                               clear=bool(cmd_reg.field("clear").decode(cmd)))
        status = regmap["STATUS"].encode(busy=out.busy, irq=out.irq, error=out.error,
                                         overrun=out.overrun)
        registers = {**{a.upper(): getattr(out, f"{a}m") for a in self.axes},
                     **{n: bank.values[n] for n in ("CTRL", "MODE") if n in bank.values},
                     "STATUS": status}
        if write:
            bank.write(*write)
        bank.clock()
        names = (*(f"{a}_{d}" for a in self.axes for d in ("pos", "neg")), "busy", "irq",
                 "error", "overrun")
        return {n: getattr(out, n) for n in names}, registers


class K3701Chip3(K3701Chip):
    """The three-axis K3701: Z, H and MODE registers, CTRL.plane routing, the Z step pulses."""

    name, regmap, axes = "k3701_3axis", K3701_MAP_3, "xyz"


class K3702Chip(Chip):
    name, regmap, gap = "k3702", K3702_MAP, 20

    def reset(self) -> None:
        self.model = K3702Model()

    def inputs(self, rng):
        return {n: int(rng.random() < 0.3) for n in ("com_pos", "com_neg", "fb_pos", "fb_neg")}

    def value(self, reg, rng):
        if reg.name == "DAC_BITS":
            return rng.choice((8, 12, 16, rng.randrange(256)))
        if reg.name in ("POSITION_ZONE", "ALARM_ZONE"):
            return rng.choice((rng.randrange(8), rng.randrange(1 << 24)))
        if reg.name == "CMD":
            return rng.randrange(16)
        return rng.choice((rng.randint(-40, 40), rng.randrange(1 << 24)))

    def cycle(self, pins, write):
        model = self.model
        now, values = model.outputs, dict(model.bank.values)
        if write:
            model.write(*write)
        after = model.step(**pins)
        names = ("dac", "sat_pos", "sat_neg", "in_position", "negative", "alarm_n", "irq")
        # The counters and flags change at the falling edge inside the cycle, so the rising
        # edge that ends it snapshots their new values; the settings read back unchanged.
        registers = {"COMMAND": after.command, "ERROR": after.error, "STATUS": after.status,
                     **{n: values[n] for n in ("POSITION_ZONE", "ALARM_ZONE", "DAC_BITS")}}
        return {n: getattr(now, n) for n in names}, registers


class EncoderChip(Chip):
    name, regmap, gap = "encoder", ENCODER_MAP, 60

    def reset(self) -> None:
        self.model = EncoderModel()
        self.fb = 0
        self.position = 0
        self.speed = 0.1
        self.broken = ""

    def inputs(self, rng):
        if rng.random() < self.speed:
            self.position += rng.choice((1, 1, -1)) if rng.random() < 0.99 else 2
        if rng.random() < 0.002:
            self.speed = rng.choice((0.02, 0.1, 0.5))
        if rng.random() < 0.0005:
            self.broken = rng.choice(("", "", "a", "b"))
        phase = self.position & 3
        a, b = int(phase in (1, 2)), int(phase in (2, 3))
        pins = {"a": a, "a_n": 1 - a, "b": b, "b_n": 1 - b}
        if self.broken:
            pins[f"{self.broken}_n"] = pins[self.broken]
        if rng.random() < 0.005:
            glitch = rng.choice(tuple(pins))
            pins[glitch] ^= 1
        return pins

    def value(self, reg, rng):
        if reg.name == "FILTER":
            return rng.choice((1, 2, 3, 3, 0, rng.randrange(256)))
        return rng.randrange(4) if reg.name == "MODE" else rng.randrange(256)

    def cycle(self, pins, write):
        model = self.model
        expected = {"fb_pos": int(self.fb == 1), "fb_neg": int(self.fb == -1),
                    "line_fault": model.line_fault, "quad_error": model.quad_error}
        values = model.bank.values
        registers = {"FILTER": values["FILTER"], "MODE": values["MODE"], "STATUS": model.status}
        if write:
            model.write(*write)
        self.fb = model.step(**pins)
        return expected, registers


class AccelDecelChip(Chip):
    name = "accel_decel"
    bidirectional = False
    model_class: type = AccelDecelModel

    def reset(self) -> None:
        self.model = self.model_class(bidirectional=self.bidirectional)
        self.sign = 1

    def inputs(self, rng):
        if rng.random() < 0.001:
            self.sign = -self.sign
        if not self.bidirectional:
            return {"inp": int(rng.random() < 0.6), "add": int(rng.random() < 0.5)}
        pos, neg = int(rng.random() < 0.5), int(rng.random() < 0.1)
        if self.sign < 0:
            pos, neg = neg, pos
        return {"inp_pos": pos, "inp_neg": neg, "add": int(rng.random() < 0.5)}

    def cycle(self, pins, write):
        idle = int(self.model.idle)
        if self.bidirectional:
            out = self.model.step(pins["inp_pos"] - pins["inp_neg"], bool(pins["add"]))
            return {"out_pos": int(out > 0), "out_neg": int(out < 0), "idle": idle}, {}
        out = self.model.step(pins["inp"], bool(pins["add"]))
        return {"out": out, "idle": idle}, {}


class AccelDecelAxisChip(AccelDecelChip):
    name = "accel_decel_axis"
    bidirectional = True


class AccelLinearChip(AccelDecelChip):
    name, model_class = "accel_linear", AccelLinearModel


class AccelLinearAxisChip(AccelDecelChip):
    name, model_class, bidirectional = "accel_linear_axis", AccelLinearModel, True


class AccelBellChip(AccelDecelChip):
    name, model_class = "accel_bell", AccelBellModel


class AccelBellAxisChip(AccelDecelChip):
    name, model_class, bidirectional = "accel_bell_axis", AccelBellModel, True


class RateMultiplierChip(Chip):
    name = "rate_multiplier"

    def reset(self) -> None:
        self.model = RateMultiplierModel()
        self.word = 0

    def inputs(self, rng):
        if rng.random() < 0.01:
            self.word = rng.choice((0xF0FF, 0x00FF, rng.randrange(1 << 18), (1 << 18) - 1))
        return {"word": self.word, "clk_en": int(rng.random() < 0.7)}

    def cycle(self, pins, write):
        out, enable_out = self.model.step(pins["word"], bool(pins["clk_en"]))
        return {"out": int(out), "enable_out": int(enable_out)}, {}


class DividerChip(Chip):
    name = "divider"

    def reset(self) -> None:
        self.model = PhaseDividerModel()
        self.increment = 0

    def inputs(self, rng):
        if rng.random() < 0.01:
            self.increment = rng.choice((1832519, rng.randrange(1 << 24), (1 << 24) - 1, 0))
        return {"increment": self.increment}

    def cycle(self, pins, write):
        return {"stb": int(self.model.step(pins["increment"]))}, {}


class DecelControlChip(Chip):
    name, regmap, gap = "decel_control", DECEL_MAP, 40

    def reset(self) -> None:
        self.model = DecelControlModel()
        self.bank = RegisterBankModel(DECEL_MAP)

    def inputs(self, rng):
        return {"inp": int(rng.random() < 0.5)}

    def value(self, reg, rng):
        if reg.name == "BUDGET":
            return rng.choice((0, 1, 2, rng.randrange(60), rng.randrange(1 << 24)))
        return int(rng.random() < 0.3) if reg.name == "CTRL" else rng.randrange(256)

    def cycle(self, pins, write):
        model, bank = self.model, self.bank
        load = bank.values["BUDGET"] if bank.w_stb("BUDGET") else None
        ctrl = bank.values["CTRL"]
        model.hold = bool(DECEL_MAP["CTRL"].field("hold").decode(ctrl))
        spent = model.spent
        status = DECEL_MAP["STATUS"].encode(spent=int(spent),
                                            open=int(not spent and not model.hold))
        registers = {"REMAINING": model.remaining, "CTRL": ctrl, "STATUS": status}
        out = model.step(bool(pins["inp"]), load)
        if write:
            bank.write(*write)
        bank.clock()
        return {"out": int(out), "spent": int(spent)}, registers


class FeedRateChip(Chip):
    name, regmap, gap = "feed_rate", FEED_MAP, 40

    def reset(self) -> None:
        self.bank = RegisterBankModel(FEED_MAP)
        self.rm_clock = PhaseDividerModel(DIVIDER_WIDTH)
        self.fa_clock = PhaseDividerModel(DIVIDER_WIDTH)
        self.rate = RateMultiplierModel()

    def inputs(self, rng):
        return {}

    def value(self, reg, rng):
        if reg.name == "FEED":  # beyond 18 bits is refused (w_err)
            return rng.choice((0xF0FF, 0x00FF, rng.randrange(1 << 18), rng.randrange(1 << 24)))
        return rng.choice((rng.randrange(1 << 24), rng.randrange(1 << 22, 1 << 24), 0))

    def cycle(self, pins, write):
        values = dict(self.bank.values)
        rm_stb = self.rm_clock.step(values["RM_INC"])
        out, _ = self.rate.step(values["FEED"], rm_stb)
        fa = self.fa_clock.step(values["FA_INC"])
        if write:
            self.bank.write(*write)
        self.bank.clock()
        return {"out": int(out), "fa": int(fa)}, values


class FeedRateAxisFaChip(FeedRateChip):
    """The per-axis fa build, every axis's own clock: the chip's own reference model."""

    name, regmap = "feed_rate_axis_fa", FEED_MAP_AXIS_FA

    def reset(self) -> None:
        self.model = FeedRateModel(FA_AXES)

    def cycle(self, pins, write):
        values = self.model.registers
        if write:
            self.model.write(*write)
        return self.model.step(), values


CHIPS = {chip.name: chip for chip in (K3701Chip, K3702Chip, EncoderChip, AccelDecelChip,
                                      AccelDecelAxisChip, AccelLinearChip, AccelLinearAxisChip,
                                      AccelBellChip, AccelBellAxisChip, RateMultiplierChip,
                                      DividerChip, DecelControlChip, FeedRateChip,
                                      FeedRateAxisFaChip, K3701Chip3)}


# --- the co-simulation loop ---------------------------------------------------------------------
