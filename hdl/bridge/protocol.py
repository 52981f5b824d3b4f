"""The host bridge's protocol: framed commands on a UART, one reply to each.

A frame's payload is an opcode byte, a sequence byte and the opcode's arguments, multi-byte
values little-endian, then a CRC-8 of them (:func:`crc8`); on the line it is byte-stuffed
(:func:`stuff`), starts with :data:`START` and ends with :data:`END`, bytes no payload byte
becomes. So where a frame starts and ends is known whatever its bytes were: a lost, extra or
corrupted byte makes a frame of the wrong length or CRC, which is answered with :data:`ERROR`
and an :class:`Error` code and never executed; a frame cut short is dropped, unanswered, by the
next :data:`START`; bytes outside a frame are dropped. A reply is framed the same way:
:data:`OK`, the frame's sequence byte and the command's results, or :data:`ERROR` and the code.

The host sends a frame only once the previous frame's reply has arrived (stop-and-wait) and
sends it again, with the same sequence byte, after an error reply or a timeout. The bridge
answers a frame whose sequence byte is the last executed frame's with that frame's reply again,
without executing it, so a retry never runs a command twice; IDENT clears that memory, so a
host that connects starts with IDENT (the sync) whatever sequence byte a host before it used.
The bridge buffers :data:`RX_FIFO_DEPTH` received bytes, as many as the longest frame on the
line (an IDLE or WAIT with every payload byte escaped); its decoder takes one a cycle.

Time is counted in chipset clock cycles. A command starts in cycle E, three cycles after its
frame's :data:`END`'s stop bit is sampled (:func:`command_start`); :data:`COMMANDS`
gives each one's bus and timing in those terms.
This module is the one definition of the protocol, for the gateware
(:class:`k37.hdl.bridge.chip.UartBridge`), its reference model (:mod:`k37.hdl.bridge.model`), the
host's link and the documentation. """

from __future__ import annotations

import enum
import zlib
from collections.abc import Iterable
from dataclasses import dataclass

from k37.hdl.bus.registers import RegisterMap
from k37.hdl.common.constants import ALL_AXES

__all__ = ["COMMANDS", "COUNTER_BITS", "COUNT_BITS", "CRC_INIT", "CRC_POLY", "DEFAULT_BAUD", "END",
           "ERROR", "ESC", "ESCAPES", "ESC_END", "ESC_ESC", "ESC_START", "IRQ_ALARM", "IRQ_INTERP",
           "MAX_CYCLES_PER_BIT", "MIN_CYCLES_PER_BIT", "OK", "PROBE_AXES", "PROBE_BYTES",
           "PROBE_FIELDS", "PROTOCOL_VERSION", "REPLY_MAX", "RX_FIFO_DEPTH", "SIMULATED_COMMANDS",
           "START", "Command", "Error", "Identity", "Op", "check_cycles_per_bit", "command_start",
           "crc8", "encode", "map_fingerprint", "markdown", "reply_end", "stuff", "unstuff"]

#: The protocol's version, the first byte of :attr:`Op.IDENT`'s reply.
PROTOCOL_VERSION = 2
#: The serial line's default rate, a board's and a host's: 8 chipset cycles per bit at 1 MHz
#: (125 kBd), which a USB serial adapter makes exactly (3 MHz / 24).
DEFAULT_BAUD = 125_000

#: Width of :attr:`Op.IDLE`'s and :attr:`Op.WAIT`'s cycle counts.
COUNT_BITS = 32
#: Width of the bridge's cycle counter (:attr:`Op.CYCLE`): 12.7 days at 1 MHz before it wraps.
COUNTER_BITS = 40
#: Bytes the bridge's receiver buffers.
RX_FIFO_DEPTH = 16
#: The UART's bit time in clock cycles, least and most.
MIN_CYCLES_PER_BIT = 4
MAX_CYCLES_PER_BIT = 1 << 16

#: The bytes that start and end every frame and reply on the line (END is SLIP's).
START = 0xC1
END = 0xC0
#: The escape byte (SLIP's): ESC ESC_START, ESC ESC_END and ESC ESC_ESC stand for a payload's
#: START, END and ESC.
ESC = 0xDB
ESC_START = 0xDE
ESC_END = 0xDC
ESC_ESC = 0xDD
#: Each byte that is escaped, and what follows ESC for it.
ESCAPES = {START: ESC_START, END: ESC_END, ESC: ESC_ESC}

#: The CRC-8 of frames and replies: polynomial x^8 + x^2 + x + 1, not reflected, register
#: preset to all ones, no final XOR, so a payload followed by its CRC leaves the register 0.
CRC_POLY = 0x07
CRC_INIT = 0xFF

#: Reply status bytes.
OK = 0x2B  # '+'
ERROR = 0x21  # '!'

#: Bits of :attr:`Op.STATUS`'s reply: the interrupt inputs' levels.
IRQ_INTERP = 0x01
IRQ_ALARM = 0x02


class Op(enum.IntEnum):
    """The opcodes (ASCII letters, so that a terminal shows a frame's kind)."""

    IDENT = 0x49  # 'I'
    WRITE = 0x57  # 'W'
    READ = 0x52  # 'R'
    IDLE = 0x44  # 'D'
    WAIT = 0x51  # 'Q'
    STATUS = 0x53  # 'S'
    CYCLE = 0x43  # 'C'
    #: A simulated board's only: :data:`SIMULATED_COMMANDS`.
    PROBE = 0x50  # 'P'


class Error(enum.IntEnum):
    """The code after :data:`ERROR`: why a frame was dropped (the first that applies)."""

    #: A byte of the frame arrived with a framing error (its stop bit low).
    FRAMING = 0x02
    #: The frame's CRC did not match, or an escape was none of :data:`ESCAPES`'.
    CHECK = 0x03
    #: The frame's first byte is no opcode.
    OPCODE = 0x01
    #: The frame is longer or shorter than its opcode's.
    LENGTH = 0x04


@dataclass(frozen=True)
class Command:
    """One command: its arguments and results, as (name, bytes) pairs, and what it does."""

    op: Op
    args: tuple[tuple[str, int], ...]
    results: tuple[tuple[str, int], ...]
    does: str

    @property
    def frame_bytes(self) -> int:
        """The payload's bytes and its CRC's: opcode, sequence, arguments, CRC."""
        return 3 + sum(n for _, n in self.args)

    @property
    def reply_bytes(self) -> int:
        """The reply's payload bytes, before its CRC: OK, sequence, results."""
        return 2 + sum(n for _, n in self.results)


_COUNT = COUNT_BITS // 8

#: Every command, by opcode.
COMMANDS: dict[Op, Command] = {c.op: c for c in (
    Command(Op.IDENT, (), (("version", 1), ("axes", 1), ("fingerprint", 4)),
            "What is behind the bridge: the protocol version, the chipset's axes and its "
            "fingerprint (a CRC-32 of every register's name, address, width and access and of the "
            "accel/decel circuits). No bus cycle."),
    Command(Op.WRITE, (("address", 1), ("data", 1)), (),
            "One bus write cycle: `w_stb` high in cycle E."),
    Command(Op.READ, (("address", 1),), (("data", 1),),
            "One bus read cycle: `r_stb` high in cycle E, the byte taken in E + 1."),
    Command(Op.IDLE, (("cycles", _COUNT),), (),
            "No bus activity for `cycles` cycles, E to E + cycles - 1; the reply follows."),
    Command(Op.WAIT, (("max_cycles", _COUNT),), (("cycles", _COUNT),),
            "Wait for an interrupt: the least n in 1..max_cycles with an interrupt input high "
            "in cycle E + n, else max_cycles (0 if max_cycles is 0). The reply follows at once: "
            "the interrupt notification."),
    Command(Op.STATUS, (), (("irq", 1),),
            "The interrupt inputs' levels in cycle E: bit 0 `irq_interp` (RST 7.5), bit 1 "
            "`irq_alarm` (RST 6.5)."),
    Command(Op.CYCLE, (), (("cycle", COUNTER_BITS // 8),),
            "The bridge's cycle counter in cycle E: the cycles since reset, modulo 2^40."),
)}

#: The longest reply payload of the gateware (before its CRC).
REPLY_MAX = max(c.reply_bytes for c in COMMANDS.values())

#: What :attr:`Op.PROBE` reads of each axis, after the FP count: the observation counters of
#: the simulated machine (its ports ``<axis>__<name>``), which no bus reaches.
PROBE_FIELDS = ("pulses_pos", "pulses_neg", "command", "error", "count", "max_abs_error")
#: Axes :attr:`Op.PROBE` always reports (zeros for an axis a machine lacks).
PROBE_AXES = ALL_AXES
#: Bytes of each value :attr:`Op.PROBE` reads (signed, two's complement).
PROBE_BYTES = 8

#: Commands only a simulated board (``k37 serve``) answers: the logic analyser a real board
#: lacks. The gateware answers them as an unknown opcode (:attr:`Error.OPCODE`).
SIMULATED_COMMANDS: dict[Op, Command] = {c.op: c for c in (
    Command(Op.PROBE, (), (("cycle", PROBE_BYTES), ("fp_total", PROBE_BYTES),
                           ("per axis x, y, z: " + ", ".join(PROBE_FIELDS),
                            PROBE_BYTES * len(PROBE_FIELDS) * len(PROBE_AXES))),
            "The simulated machine's observation counters in cycle E: the cycle, FP pulses "
            "since reset "
            "and, per axis, step pulses each way, K3702 command and error counters, the "
            "plant's encoder count and the largest error yet. No bus cycle."),
)}


def crc8(data: Iterable[int], crc: int = CRC_INIT) -> int:
    """The CRC-8 of ``data`` (:data:`CRC_POLY`), continuing from register value ``crc``."""
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = ((crc << 1) ^ (CRC_POLY if crc & 0x80 else 0)) & 0xFF
    return crc


def stuff(payload: bytes) -> bytes:
    """``payload`` and its CRC as they go on the line: escaped, between :data:`START` and
    :data:`END`."""
    body = bytearray([START])
    for byte in payload + bytes([crc8(payload)]):
        body += bytes([ESC, ESCAPES[byte]]) if byte in ESCAPES else bytes([byte])
    return bytes(body + bytes([END]))


_UNESCAPED = {code: byte for byte, code in ESCAPES.items()}


def unstuff(body: bytes) -> bytes | None:
    """The payload of ``body``, the bytes between :data:`START` and :data:`END` (without
    them), if its escapes and CRC are intact; else None."""
    out = bytearray()
    escaped = False
    for byte in body:
        if escaped:
            if byte not in _UNESCAPED:
                return None
            out.append(_UNESCAPED[byte])
            escaped = False
        elif byte == ESC:
            escaped = True
        else:
            out.append(byte)
    if escaped or len(out) < 2 or crc8(out) != 0:
        return None
    return bytes(out[:-1])


def encode(op: Op, *args: int, seq: int = 0) -> bytes:
    """The frame of command ``op`` with ``args`` (each in its width) and sequence byte ``seq``,
    as it goes on the line (:func:`stuff`)."""
    command = {**COMMANDS, **SIMULATED_COMMANDS}[op]
    if len(args) != len(command.args):
        raise ValueError(f"{op.name} takes {len(command.args)} arguments, not {len(args)}")
    if not 0 <= seq <= 0xFF:
        raise ValueError(f"the sequence byte must be in 0..255, not {seq}")
    payload = bytes([op, seq])
    for (name, n), value in zip(command.args, args, strict=True):
        if not 0 <= value < 1 << 8 * n:
            raise ValueError(f"{op.name} {name} must be in 0..{(1 << 8 * n) - 1}, not {value}")
        payload += value.to_bytes(n, "little")
    return stuff(payload)


def check_cycles_per_bit(cycles_per_bit: object) -> int:
    """``cycles_per_bit`` if it is a supported UART bit time, else a ValueError naming it."""
    if (not isinstance(cycles_per_bit, int) or isinstance(cycles_per_bit, bool)
            or not MIN_CYCLES_PER_BIT <= cycles_per_bit <= MAX_CYCLES_PER_BIT):
        raise ValueError(f"cycles per UART bit must be an integer in {MIN_CYCLES_PER_BIT}.."
                         f"{MAX_CYCLES_PER_BIT}, not {cycles_per_bit!r}")
    return cycles_per_bit


def command_start(last_byte: int, cycles_per_bit: int) -> int:
    """The start cycle E of a command whose frame's :data:`END`'s start bit began on
    ``rx`` in cycle ``last_byte`` (the line sampled at each rising clock edge): its stop bit is
    sampled ``cycles_per_bit // 2 + 9 * cycles_per_bit`` cycles after its start bit is seen, two
    cycles late (a two-stage synchroniser), and the command starts three cycles later (the
    receive FIFO and the frame decoder)."""
    return last_byte + 2 + cycles_per_bit // 2 + 9 * cycles_per_bit + 3


def reply_end(command_end: int, reply_bytes: int, cycles_per_bit: int) -> int:
    """The last cycle of the last reply byte's stop bit on ``tx``, for a command that ended in
    cycle ``command_end`` (E for WRITE, IDENT, STATUS and CYCLE, E + 1 for READ, E + N for an
    IDLE of N, E + n for a WAIT that returned n, E - 1 for an error or a repeated reply) and a
    reply of ``reply_bytes`` bytes on the line: the first start bit two cycles later, each next
    one a cycle after the stop bit before."""
    return command_end + reply_bytes * (10 * cycles_per_bit + 1)


@dataclass(frozen=True)
class Identity:
    """What :attr:`Op.IDENT` tells of the chipset behind a bridge."""

    axes: int
    fingerprint: int
    version: int = PROTOCOL_VERSION

    def encode(self) -> bytes:
        return bytes([self.version, self.axes]) + self.fingerprint.to_bytes(4, "little")

    @classmethod
    def decode(cls, data: bytes) -> Identity:
        return cls(axes=data[1], fingerprint=int.from_bytes(data[2:6], "little"),
                   version=data[0])


def map_fingerprint(maps: Iterable[tuple[str, int, RegisterMap]], build: str = "") -> int:
    """A CRC-32 of a chipset's chips as (name, chip select, register map), every register's
    name, address, width and access, and of ``build``, the rest of what it was built with, so
    a host can tell whether it drives the chipset it expects."""
    text = [build]
    for name, select, regmap in maps:
        text.append(f"{name}@{select}:")
        text += [f"{r.name},{r.addr},{r.width},{r.access.name};" for r in regmap]
    return zlib.crc32("".join(text).encode())


def markdown() -> str:
    """The text of ``docs/bridge-protocol.md``."""
    def fields(pairs: tuple[tuple[str, int], ...]) -> str:
        return ", ".join(f"{name} ({n})" for name, n in pairs) or "-"

    lines = [
        "# Bridge protocol", "",
        "Generated by `k37 docs` from `hdl/bridge/protocol.py` (do not edit by hand).", "",
        f"Protocol version {PROTOCOL_VERSION}. A frame's payload is an opcode byte, a sequence "
        f"byte and the arguments, multi-byte values little-endian, then a CRC-8 of them "
        f"(polynomial {0x100 | CRC_POLY:#05x}, preset {CRC_INIT:#04x}, not reflected, no final "
        f"XOR); on the line the payload and CRC are escaped as SLIP does ("
        + ", ".join(f"{b:#04x} as {ESC:#04x} {c:#04x}" for b, c in ESCAPES.items())
        + f"), preceded by START {START:#04x} and followed by END {END:#04x}. A reply is "
        f"framed the same way: a status byte, then the frame's sequence byte and the "
        f"command's results (OK), or an error code (ERROR). A frame with a framing error, a "
        f"wrong CRC or escape, an unknown opcode or the wrong length is answered with ERROR "
        f"and never executed; a frame cut short is dropped, unanswered, by the next START, "
        f"and bytes between an END and the next START are dropped.", "",
        "The host sends a frame once the previous reply has arrived, and sends it again with "
        "the same sequence byte after an ERROR reply or a timeout. A frame with the sequence "
        "byte of the last executed frame is answered with that frame's reply again and not "
        "executed, so a retry never runs a command twice; IDENT is always executed and clears "
        "that memory, so a host starts with IDENT (the sync at connect); its START drops "
        "whatever frame a host before it left cut.", "",
        f"The bridge buffers {RX_FIFO_DEPTH} received bytes. Times are in chipset clock cycles; "
        f"E is the cycle a command starts in, three cycles after the stop bit of its frame's "
        f"END is sampled. The UART is 8N1, idle high, "
        f"{MIN_CYCLES_PER_BIT} to {MAX_CYCLES_PER_BIT} cycles per bit.", "",
        "| command | opcode | arguments (bytes) | reply after OK (bytes) | does |",
        "|---|---|---|---|---|"]
    for c in COMMANDS.values():
        lines.append(f"| {c.op.name} | {c.op:#04x} `{chr(c.op)}` | {fields(c.args)} "
                     f"| {fields(c.results)} | {c.does} |")
    lines += ["", "A simulated board (`k37 serve`) also answers the command below; the gateware "
              "answers it as an unknown opcode.", "",
              "| command | opcode | arguments (bytes) | reply after OK (bytes) | does |",
              "|---|---|---|---|---|"]
    for c in SIMULATED_COMMANDS.values():
        lines.append(f"| {c.op.name} | {c.op:#04x} `{chr(c.op)}` | {fields(c.args)} "
                     f"| {fields(c.results)} | {c.does} |")
    lines += ["", "| reply status | byte | then |", "|---|---|---|",
              f"| OK | {OK:#04x} `{chr(OK)}` | the frame's sequence byte, the command's results |",
              f"| ERROR | {ERROR:#04x} `{chr(ERROR)}` | one code byte: "
              + "; ".join(f"{e:#04x} {e.name}: {_ERROR_TEXT[e]}" for e in Error) + " |"]
    return "\n".join(lines) + "\n"


_ERROR_TEXT = {
    Error.FRAMING: "a byte of the frame came with its stop bit low",
    Error.CHECK: "the CRC did not match, or an escape was wrong",
    Error.OPCODE: "the first byte is no opcode",
    Error.LENGTH: "the frame is longer or shorter than its opcode's",
}
