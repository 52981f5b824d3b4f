"""The host bridge's reference model, frame by frame (no Amaranth).

:class:`BridgeModel` takes the bytes a host sends and gives the bridge's replies, executing each
command on a :class:`Target`: the chipset's bus, interrupt inputs and clock. Behind a socket on
the simulated machine (``k37 serve``) the target's time passes only as the commands say; against
the gateware (:class:`k37.hdl.bridge.chip.UartBridge`) each byte comes with the cycle its command
may start (:func:`k37.hdl.bridge.protocol.command_start`), so the model gives the same replies,
cycle counts included. """

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Protocol

from k37.hdl.bridge.protocol import (
    COMMANDS,
    COUNTER_BITS,
    ERROR,
    IRQ_ALARM,
    IRQ_INTERP,
    OK,
    PROBE_BYTES,
    SIMULATED_COMMANDS,
    Error,
    Identity,
    Op,
    check_cycles_per_bit,
    command_start,
    reply_end,
)

__all__ = ["FRAMING", "BridgeModel", "LineTimed", "Target"]

#: What :meth:`BridgeModel.receive` takes for a byte received with a framing error.
FRAMING = -1


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
    :attr:`Op.PROBE`'s reply; None (the gateware's case): PROBE is no opcode.
    """

    def __init__(self, target: Target, identity: Identity,
                 probe: Callable[[], Sequence[int]] | None = None):
        self.target = target
        self.identity = identity
        self.probe = probe
        self.commands = {**COMMANDS, **(SIMULATED_COMMANDS if probe is not None else {})}
        self._frame = bytearray()

    @property
    def mid_frame(self) -> bool:
        """Whether bytes of a frame were received and more are awaited."""
        return bool(self._frame)

    def receive(self, byte: int, start: int | None = None) -> bytes:
        """Take one received byte (or :data:`FRAMING`); the reply it completes, or b"".

        ``start``: the cycle the command this byte completes starts in, if later than the
        target's clock (the target idles until then); None: at once.
        """
        if byte == FRAMING:
            self._frame.clear()
            return bytes([ERROR, Error.FRAMING])
        if not self._frame and byte not in self.commands:
            return bytes([ERROR, Error.OPCODE])
        self._frame.append(byte)
        command = self.commands[Op(self._frame[0])]
        if len(self._frame) < command.frame_bytes:
            return b""
        frame = bytes(self._frame)
        self._frame.clear()
        if start is not None and start > self.target.cycle:
            self.target.idle(start - self.target.cycle)
        return bytes([OK]) + self._execute(command.op, frame[1:])

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
        self._op = 0  # the first byte of the frame being received

    def receive(self, byte: int) -> bytes:
        if byte == Op.PROBE and not self.model.mid_frame:
            # The logic analyser is not on the line: it looks at the machine as the host
            # finds it, taking no line time.
            return self.model.receive(byte, self._line)
        if not self.model.mid_frame:
            self._op = byte
        begins = self._line
        self._line += 10 * self.cycles_per_bit
        start = command_start(begins, self.cycles_per_bit)
        reply = self.model.receive(byte, start)
        if reply:
            ends = (start - 1 if reply[0] == ERROR else start if self._op == Op.WRITE
                    else self.model.target.cycle)
            self._line = reply_end(ends, len(reply), self.cycles_per_bit) + 1 + self.turnaround
        return reply
