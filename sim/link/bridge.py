"""The chipset over the host bridge's protocol: :class:`BridgeLink`, a
:class:`k37.firmware_model.link.ChipsetLink` on a byte stream.

One link, three transports, opened from a URL by :func:`open_link` with pyserial's
``serial_for_url``: ``tcp://HOST:PORT`` (a simulated board, ``k37 serve``), a serial port
(``serial:///dev/ttyUSB0`` or a bare device path, at
:data:`k37.hdl.bridge.protocol.DEFAULT_BAUD` unless the URL says ``?baud=N``) for the real
board, and ``loop://`` for tests. Each command waits for its reply before the next is sent
and is sent again after an error reply or a timeout (:mod:`k37.hdl.bridge.protocol`); the
link's first command is IDENT, the sync that makes the bridge forget a host before it.

Each whole frame feeds the board's watchdog (:data:`k37.hdl.board.map.BOARD_MAP`):
:meth:`BridgeLink.arm_watchdog` arms it and keeps every IDLE and WAIT a quarter of its time or
shorter, so that a host that is there feeds it in time. :meth:`BridgeLink.watch_stops` has the
link read the board's STATUS after every so many cycles of idling and waiting, and raise
:class:`BoardStopError` once a stop is latched, so that a host waiting for a held feed learns
of it.

The link's :attr:`BridgeLink.cycle` is the host's account of time: the cycles its commands
took (a bus cycle each, an idle's, a wait's). On a simulated board that is the machine's clock
exactly; on a real board the chipset's clock also runs while bytes are on the line, so the gaps
between commands are longer, and :meth:`BridgeLink.board_cycle` reads the bridge's own counter.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from urllib.parse import parse_qs, urlsplit

from k37.firmware_model.job import Job
from k37.firmware_model.link import Interrupts
from k37.hdl.board.map import BOARD_MAP, LATCHED, board_port
from k37.hdl.bridge.protocol import (
    COUNT_BITS,
    DEFAULT_BAUD,
    END,
    ERROR,
    IRQ_ALARM,
    IRQ_INTERP,
    OK,
    PROBE_AXES,
    PROBE_BYTES,
    PROBE_FIELDS,
    START,
    Error,
    Identity,
    Op,
    encode,
    unstuff,
)
from k37.hdl.chipset.identity import chipset_identity

__all__ = ["BoardStopError", "BridgeLink", "LinkError", "Probe", "job_identity", "open_link"]

#: Longest IDLE or WAIT sent at once, about 1 s at 1 MHz, so that every reply comes well within
#: the link's timeout; longer ones are sent in parts (the same cycles on a simulated board).
MAX_COUNT = 1 << 20
#: Times a frame is sent before the link gives up: after an ERROR reply (the frame was not
#: executed) or a timeout (the bridge repeats the reply of a frame it executed).
ATTEMPTS = 3


class LinkError(Exception):
    """The link failed: it cannot be opened, a reply did not come or was not understood, or
    the chipset behind it is not the one expected."""


class BoardStopError(Exception):
    """The board latched a stop (its watchdog, the E-stop, a limit): ``status`` is its STATUS
    by field, read when the host's :attr:`BridgeLink.cycle` was ``cycle`` and the bridge's
    cycle counter ``board_cycle`` (just after the read)."""

    def __init__(self, status: dict[str, int], cycle: int, board_cycle: int):
        super().__init__(f"the board latched a stop (STATUS {status})")
        self.status = status
        self.cycle = cycle
        self.board_cycle = board_cycle


def job_identity(job: Job) -> Identity:
    """What a bridge in front of ``job``'s chipset tells (:attr:`Op.IDENT`)."""
    machine = job.machine
    return chipset_identity(axes=machine.axes, accel=machine.accel,
                            accel_bits=machine.accel_bits, accel_shape=machine.accel_shape,
                            axis_accel=job.accel_circuits(), axis_fa=job.fa_axes())


@dataclass(frozen=True)
class Probe:
    """A simulated board's observation counters (:attr:`Op.PROBE`), per axis by field name."""

    cycle: int
    fp_total: int
    axes: dict[str, dict[str, int]]


class BridgeLink:
    """:class:`k37.firmware_model.link.ChipsetLink` over the bridge protocol on ``port`` (an open
    pyserial port, or anything with ``read(n)``, ``write(data)`` and ``close()``), whose
    ``read`` returns fewer bytes than asked only when it timed out."""

    def __init__(self, port, name: str = "the link"):
        self.port = port
        self.name = name
        self._cycle = 0
        self._seq = 0
        self._synced = False
        self._received = bytearray()
        #: Whether the far end answers :attr:`Op.PROBE` (a simulated board); None: not asked.
        self.probes: bool | None = None
        #: The longest IDLE or WAIT sent at once (shorter with the watchdog armed).
        self.max_count = MAX_COUNT
        #: Cycles between the board's STATUS reads while idling and waiting (0: none), and
        #: the host's cycle from which the next is due.
        self.stop_every = 0
        self._next_check = 0

    @property
    def cycle(self) -> int:
        return self._cycle

    def _command(self, op: Op, *args: int, reply: int) -> bytes:
        """Send ``op`` until it is answered OK (at most :data:`ATTEMPTS` times); its results."""
        if not self._synced and op is not Op.IDENT:
            self.identify()
        seq = self._seq
        self._seq = (seq + 1) % 256
        frame = encode(op, *args, seq=seq)
        refused: Error | bytes | None = None
        try:
            for _ in range(ATTEMPTS):
                self.port.write(frame)
                answer = self._answer(seq)
                if answer is None:
                    continue
                status, data = answer
                if status == ERROR:
                    known = len(data) == 1 and data[0] in {e.value for e in Error}
                    refused = Error(data[0]) if known else data
                    if refused is Error.OPCODE:
                        break  # an opcode the far end lacks is lacked on every attempt
                    continue
                if status != OK:
                    raise LinkError(f"{self.name}: {op.name} answered {bytes([status])!r}, not OK")
                if len(data) != reply:
                    raise LinkError(f"{self.name}: {op.name}'s reply had {len(data)} bytes of "
                                    f"results, not {reply}")
                if op is Op.IDENT:
                    self._synced = True
                return data
        except OSError as e:
            raise LinkError(f"{self.name}: {e.strerror or e}") from None
        if refused is not None:
            raise _RefusedError(self.name, op, refused)
        raise LinkError(f"{self.name}: no reply to {op.name} after {ATTEMPTS} attempts")

    def _answer(self, seq: int) -> tuple[int, bytes] | None:
        """The next reply to the frame with sequence byte ``seq``, as (status, what follows
        the sequence byte, or the error code); None if none came in time. Replies that are
        not whole, or that answer another frame, are skipped."""
        while True:
            body = self._reply_body()
            if body is None:
                return None
            payload = unstuff(body)
            if payload is None:
                continue
            if payload[0] == ERROR:
                return ERROR, payload[1:]
            if len(payload) >= 2 and payload[1] == seq:
                return payload[0], payload[2:]
            if payload[0] != OK:
                return payload[0], payload[1:]

    def _reply_body(self) -> bytes | None:
        """The bytes between the next START and the END after it (a later START starts
        again); None on a timeout."""
        received = self._received
        while True:
            start = received.find(START)
            if start < 0:
                received.clear()  # bytes outside a reply
            else:
                del received[:start]
                end = received.find(END)
                if end >= 0:
                    body = bytes(received[received.rfind(START, 0, end) + 1:end])
                    del received[:end + 1]
                    return body
            # a whole short reply at once, then what is missing byte by byte
            data = self.port.read(5 if not received else 1)
            if not data:
                return None
            received += data

    def identify(self) -> Identity:
        """What the bridge tells of the chipset behind it."""
        return Identity.decode(self._command(Op.IDENT, reply=6))

    def check(self, expected: Identity) -> None:
        """Raise :class:`LinkError` unless the chipset behind the link is ``expected``."""
        found = self.identify()
        if found.version != expected.version:
            raise LinkError(f"{self.name}: the bridge speaks protocol version {found.version}, "
                            f"not {expected.version}")
        if found.axes != expected.axes:
            raise LinkError(f"{self.name}: the chipset there has {found.axes} axes, the job's "
                            f"machine {expected.axes}")
        if found.fingerprint != expected.fingerprint:
            raise LinkError(f"{self.name}: the chipset there was built otherwise than the job's "
                            f"machine (other accel/decel circuits or register maps: fingerprint "
                            f"{found.fingerprint:#010x}, the job's {expected.fingerprint:#010x})")

    def _part(self, cycles: int) -> int:
        """The most of ``cycles`` one IDLE or WAIT may take: within :attr:`max_count` and, when
        watching for stops, up to the next STATUS read."""
        part = min(cycles, self.max_count)
        return min(part, max(1, self._next_check - self._cycle)) if self.stop_every else part

    def _check_stops(self) -> None:
        """Read the board's STATUS if it is due; raise :class:`BoardStopError` on a latched stop."""
        if not self.stop_every or self._cycle < self._next_check:
            return
        self._next_check = self._cycle + self.stop_every
        status = self.read(board_port("STATUS"))
        if status & LATCHED:
            raise BoardStopError(BOARD_MAP["STATUS"].decode(status), self._cycle,
                               self.board_cycle())

    def watch_stops(self, every: int) -> None:
        """Read the board's STATUS (a bus cycle) each time ``every`` cycles (0: never) have
        passed since the last read, after the IDLE or WAIT that reaches them: a latched stop
        raises :class:`BoardStopError`."""
        self.stop_every = every
        self._next_check = self._cycle + every

    def idle(self, cycles: int) -> None:
        while cycles > 0:
            part = self._part(cycles)
            self._command(Op.IDLE, part, reply=0)
            self._cycle += part
            cycles -= part
            self._check_stops()

    def write(self, address: int, data: int) -> None:
        self._command(Op.WRITE, address, data, reply=0)
        self._cycle += 1

    def read(self, address: int) -> int:
        data = self._command(Op.READ, address, reply=1)[0]
        self._cycle += 1
        return data

    def wait_interrupt(self, max_cycles: int) -> int:
        waited = 0
        while waited < max_cycles:
            part = self._part(max_cycles - waited)
            n = int.from_bytes(self._command(Op.WAIT, part, reply=COUNT_BITS // 8), "little")
            self._cycle += n
            waited += n
            self._check_stops()
            if n < part:
                break
        return waited

    def interrupts(self) -> Interrupts:
        irq = self._command(Op.STATUS, reply=1)[0]
        return Interrupts(bool(irq & IRQ_INTERP), bool(irq & IRQ_ALARM))

    def _write_board(self, register: str, value: int) -> None:
        for k, byte in enumerate(BOARD_MAP[register].to_bytes(value)):
            self.write(board_port(register, k), byte)

    def arm_watchdog(self, cycles: int, dac_zero: int) -> None:
        """Clear the board's latched stops, set the D/A word of 0 V and arm its watchdog to
        ``cycles`` (0: off); with it armed, waits go in parts of a quarter of it."""
        self._write_board("CLEAR", LATCHED)
        self._write_board("DAC_ZERO", dac_zero)
        self._write_board("WATCHDOG", cycles)
        self.max_count = MAX_COUNT if cycles == 0 else max(1, min(MAX_COUNT, cycles // 4))

    def disarm_watchdog(self) -> None:
        """Turn the board's watchdog off (its latched stops stay)."""
        self._write_board("WATCHDOG", 0)
        self.max_count = MAX_COUNT

    def board_status(self) -> dict[str, int]:
        """The board's STATUS, by field (:data:`k37.hdl.board.map.BOARD_MAP`)."""
        return BOARD_MAP["STATUS"].decode(self.read(board_port("STATUS")))

    def board_cycle(self) -> int:
        """The bridge's cycle counter (modulo 2^40)."""
        return int.from_bytes(self._command(Op.CYCLE, reply=5), "little")

    def probe(self) -> Probe | None:
        """The simulated machine's observation counters; None from a real board (which has no
        such command)."""
        if self.probes is False:
            return None
        size = PROBE_BYTES * (2 + len(PROBE_FIELDS) * len(PROBE_AXES))
        try:
            data = self._command(Op.PROBE, reply=size)
        except _RefusedError as e:
            if e.code is not Error.OPCODE:
                raise
            self.probes = False
            return None
        self.probes = True
        values = [int.from_bytes(data[k:k + PROBE_BYTES], "little", signed=True)
                  for k in range(0, size, PROBE_BYTES)]
        per_axis = len(PROBE_FIELDS)
        return Probe(values[0], values[1], {
            axis: dict(zip(PROBE_FIELDS, values[2 + k * per_axis:2 + (k + 1) * per_axis],
                           strict=True))
            for k, axis in enumerate(PROBE_AXES)})

    def close(self) -> None:
        self.port.close()


class _RefusedError(LinkError):
    """The bridge answered ERROR."""

    def __init__(self, name: str, op: Op, code: Error | bytes):
        what = code.name if isinstance(code, Error) else repr(code)
        super().__init__(f"{name}: the bridge answered {op.name} with error {what}")
        self.code = code


def _serial_for_url(url: str, **kwargs):
    import serial  # pyserial: imported only by a link that needs it

    return serial.serial_for_url(url, **kwargs)


def open_link(url: str, timeout: float = 30.0,
              opener: Callable[..., object] = _serial_for_url) -> BridgeLink:
    """The link at ``url`` (``tcp://HOST:PORT``, ``serial:///dev/ttyUSB0[?baud=N]``, a device
    path, ``socket://``, ``loop://``), each reply awaited at most ``timeout`` seconds."""
    parts = urlsplit(url)
    kwargs: dict = {"timeout": timeout}
    if parts.scheme == "tcp":
        if not parts.hostname or parts.port is None:
            raise LinkError(f"{url}: give tcp://HOST:PORT")
        target = f"socket://{parts.hostname}:{parts.port}"
    elif parts.scheme in ("serial", ""):
        target = parts.path
        baud = parse_qs(parts.query).get("baud", [str(DEFAULT_BAUD)])[0]
        if not baud.isdigit() or int(baud) == 0:
            raise LinkError(f"{url}: baud must be a positive integer, not {baud!r}")
        kwargs["baudrate"] = int(baud)
        if not target:
            raise LinkError(f"{url}: give serial:///dev/DEVICE")
    else:
        target = url
    try:
        port = opener(target, **kwargs)
    except ImportError:
        raise LinkError(f"{url}: a link needs pyserial (pip install pyserial)") from None
    except (OSError, ValueError) as e:
        raise LinkError(f"{url}: cannot open: {_why(e)}") from None
    return BridgeLink(port, url)


def _why(e: Exception) -> str:
    text = str(e)
    if "Connection refused" in text or "[Errno 111]" in text:
        return "connection refused (is `k37 serve` running there?)"
    return text
