"""The host bridge's reference model, frame by frame (no Amaranth).

:class:`BridgeModel` takes the bytes a host sends and gives the bridge's replies, executing each
command on a :class:`Target`: the chipset's bus, interrupt inputs and clock. Behind a socket on
the simulated machine (``k37 serve``) the target's time passes only as the commands say; against
the gateware (:class:`k37.hdl.bridge.chip.UartBridge`) each byte comes with the cycle its command
may start (:func:`k37.hdl.bridge.protocol.command_start`), frames are checked and repeated
replies given as the gateware does, so the model gives the same replies,
cycle counts included. """

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Protocol

from k37.hdl.bridge.protocol import (
    COMMANDS,
    COUNTER_BITS,
    END,
    ERROR,
    ESC,
    ESCAPES,
    IRQ_ALARM,
    IRQ_INTERP,
    OK,
    PROBE_BYTES,
    SIMULATED_COMMANDS,
    START,
    Error,
    Identity,
    Op,
    check_cycles_per_bit,
    command_start,
    crc8,
    reply_end,
    stuff,
)

__all__ = ["FRAMING", "BridgeModel", "LineTimed", "Target"]

#: What :meth:`BridgeModel.receive` takes for a byte received with a framing error.
FRAMING = -1

_UNESCAPED = {code: byte for byte, code in ESCAPES.items()}


class Target(Protocol):
    """What the bridge drives: the shape of :class:`k37.firmware_model.link.ChipsetLink`."""

    @property
    def cycle(self) -> int: ...

    def idle(self, cycles: int) -> None: ...

    def write(self, address: int, data: int) -> None: ...

    def read(self, address: int) -> int: ...

    def wait_interrupt(self, max_cycles: int) -> int: ...

    def interrupts(self) -> tuple[bool, bool]: ...


class BridgeModel:
    """The bridge, byte by byte, on ``target``, telling ``identity`` to :attr:`Op.IDENT`.

    ``probe``: a simulated board's observation counters, in the order of
    :attr:`Op.PROBE`'s reply; None (the gateware's case): PROBE is an unknown opcode.
    ``on_frame``: told of each whole frame (executed or answered again) as its command
    starts, as the gateware's ``frame`` output tells the board's watchdog.
    """

    def __init__(self, target: Target, identity: Identity,
                 probe: Callable[[], Sequence[int]] | None = None,
                 on_frame: Callable[[], None] | None = None):
        self.target = target
        self.on_frame = on_frame
        self.identity = identity
        self.probe = probe
        self.commands = {**COMMANDS, **(SIMULATED_COMMANDS if probe is not None else {})}
        self._frame = bytearray()
        self._open = False  # a START came, its END is awaited
        self._escaped = False
        self._framing = False  # a byte of the frame had a framing error
        self._bad_escape = False
        #: The last executed frame's sequence byte and reply payload (None after IDENT).
        self._last: tuple[int, bytes] | None = None
        #: What the last reply answered: an executed opcode, or None (an error or a repeat).
        self.answered: Op | None = None

    @property
    def mid_frame(self) -> bool:
        """Whether a frame's START was received and its END is awaited."""
        return self._open

    def receive(self, byte: int, start: int | None = None) -> bytes:
        """Take one received byte (or :data:`FRAMING`); the reply it completes as it goes on
        the line, or b"".

        ``start``: the cycle the command this byte completes starts in, if later than the
        target's clock (the target idles until then, except for PROBE, which looks at the
        machine as it is); None: at once.
        """
        if byte == START:  # drops a frame cut short
            self._clear()
            self._open = True
        elif not self._open:
            pass  # a byte outside a frame
        elif byte == FRAMING:
            self._framing = True
        elif byte == END:
            return self._end(start)
        elif self._escaped:
            self._escaped = False
            unescaped = _UNESCAPED.get(byte)
            if unescaped is None:
                self._bad_escape = True
            else:
                self._frame.append(unescaped)
        elif byte == ESC:
            self._escaped = True
        else:
            self._frame.append(byte)
        return b""

    def _clear(self) -> None:
        self._frame.clear()
        self._open = self._escaped = self._framing = self._bad_escape = False

    def _end(self, start: int | None) -> bytes:
        frame = bytes(self._frame)
        broken = Error.FRAMING if self._framing else None
        if broken is None and (self._escaped or self._bad_escape or crc8(frame) != 0):
            broken = Error.CHECK
        if broken is None and frame[0] not in self.commands:
            broken = Error.OPCODE
        if broken is None and len(frame) != self.commands[Op(frame[0])].frame_bytes:
            broken = Error.LENGTH
        self._clear()
        self.answered = None
        if broken is not None:
            return stuff(bytes([ERROR, broken]))
        op, seq = Op(frame[0]), frame[1]
        if op is not Op.IDENT and self._last is not None and self._last[0] == seq:
            self._fed()
            return stuff(self._last[1])
        if op is not Op.PROBE and start is not None and start > self.target.cycle:
            self.target.idle(start - self.target.cycle)
        self._fed()
        reply = bytes([OK, seq]) + self._execute(op, frame[2:-1])
        self._last = None if op is Op.IDENT else (seq, reply)
        self.answered = op
        return stuff(reply)

    def _fed(self) -> None:
        if self.on_frame is not None:
            self.on_frame()

    def _execute(self, op: Op, args: bytes) -> bytes:
        target = self.target
        count = int.from_bytes(args, "little")
        if op is Op.IDENT:
            return self.identity.encode()
        if op is Op.WRITE:
            target.write(args[0], args[1])
            return b""
        if op is Op.READ:
            return bytes([target.read(args[0])])
        if op is Op.IDLE:
            target.idle(count)
            return b""
        if op is Op.WAIT:
            return target.wait_interrupt(count).to_bytes(len(args), "little")
        if op is Op.STATUS:
            interp, alarm = target.interrupts()
            return bytes([IRQ_INTERP * interp | IRQ_ALARM * alarm])
        if op is Op.PROBE:
            assert self.probe is not None
            return b"".join(value.to_bytes(PROBE_BYTES, "little", signed=True)
                            for value in self.probe())
        assert op is Op.CYCLE
        return (target.cycle % (1 << COUNTER_BITS)).to_bytes(COUNTER_BITS // 8, "little")


class LineTimed:
    """A :class:`BridgeModel` whose commands start when they would over a UART, to the cycle.

    The host is stop-and-wait: its first frame's start bit begins in cycle 0, each later frame's
    ``turnaround`` cycles after the cycle that ends the previous reply's last stop bit, and a
    frame's bytes go back to back, ten bit times of ``cycles_per_bit`` cycles each. A command
    starts as the gateware's does (:func:`k37.hdl.bridge.protocol.command_start`) and its reply
    takes the line as the gateware's does (:func:`k37.hdl.bridge.protocol.reply_end`). The target's
    time then includes the line's, as a real board's does.
    """

    def __init__(self, model: BridgeModel, cycles_per_bit: int, turnaround: int = 0):
        self.model = model
        self.cycles_per_bit = check_cycles_per_bit(cycles_per_bit)
        if turnaround < 0:
            raise ValueError(f"turnaround must be >= 0 cycles, not {turnaround}")
        self.turnaround = turnaround
        self._line = 0  # the cycle the host's next byte can begin
        self._frame_begins: int | None = None  # the cycle the bytes since the last reply began

    def receive(self, byte: int) -> bytes:
        if self._frame_begins is None:
            self._frame_begins = self._line
        begins = self._line
        self._line += 10 * self.cycles_per_bit
        start = command_start(begins, self.cycles_per_bit)
        model = self.model
        reply = model.receive(byte, start)
        if not reply:
            return reply
        if model.answered is Op.PROBE:
            # The logic analyser is not on the line: it looks at the machine as the host
            # finds it, taking no line time.
            self._line = self._frame_begins
        else:
            ends = (start - 1 if model.answered is None else start
                    if model.answered is Op.WRITE else model.target.cycle)
            self._line = reply_end(ends, len(reply), self.cycles_per_bit) + 1 + self.turnaround
        self._frame_begins = None
        return reply
