"""``k37 serve``: the simulated machine behind a TCP socket, speaking the host bridge's protocol.

The machine is reset once, when the board is made, and keeps its state and its bridge's from
one connection to the next, as a board does while hosts come and go (a host's first frame ends
whatever frame a host before it left cut). The bytes received go through the bridge's reference
model (:class:`k37.hdl.bridge.model.BridgeModel`) onto the machine's bus, interrupt inputs and
clock (:class:`k37.sim.link.simulated.SimulatedLink` over a
:class:`k37.sim.run.sampler.Sampler`), and simulated time passes only as the host's commands say
(and the line's, with a UART's line time), so a session is as deterministic as a run in
process. The board answers :attr:`Op.PROBE` too: the observation counters a real board has no
bus for. One session at a time; a host that connects while another is being served waits.

The board's machine I/O (:class:`k37.sim.serve.board.BoardIO`: watchdog, E-stop, limits) sits
between the bridge and the machine. A board's time runs on when its host goes silent; a
simulated board's stands still, except that with its watchdog armed, once the host has sent
nothing for the watchdog's time by the wall clock, or has gone (its connection closed), the
machine runs on until the watchdog trips and the board holds, as a board's would.
"""

from __future__ import annotations

import socket
import threading
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from k37.firmware_model.job import Job
from k37.hdl.bridge.model import BridgeModel, LineTimed
from k37.hdl.bridge.protocol import PROBE_AXES, PROBE_FIELDS, check_cycles_per_bit
from k37.sim.backends.contract import Backend
from k37.sim.link.bridge import job_identity
from k37.sim.link.simulated import SimulatedLink
from k37.sim.run.output import write_samples
from k37.sim.run.runner import build_backend, configure_plants
from k37.sim.run.sampler import Sampler, SampleStore
from k37.sim.serve.board import BoardIO, InputChange, check_changes

__all__ = ["Session", "SimulatedBoard"]


@dataclass
class Session:
    """What one connection did: its peer, the bytes it sent and the cycles the machine ran
    while it was connected."""

    peer: str
    received: int = 0
    cycles: int = 0


class SimulatedBoard:
    """The machine of ``job`` on backend ``kind``, served on ``host``:``port`` (0: a free
    port, :attr:`port` once bound).

    ``line``: (cycles per bit, host turnaround in cycles) to let the machine's time include a
    UART's as on a real board (:class:`k37.hdl.bridge.model.LineTimed`); None: time passes only as
    the commands say. ``trace``: where the machine's samples since it was reset (one every
    ``sample_every`` cycles) are written as CSV when each session ends. ``probes``:
    False to answer as a real board does, without :attr:`Op.PROBE`. ``changes``: the board's
    E-stop and limit inputs changing at given machine cycles
    (:class:`k37.sim.serve.board.InputChange`).
    """

    def __init__(self, job: Job, kind: str = "auto", host: str = "127.0.0.1", port: int = 0,
                 sample_every: int = 1000, line: tuple[int, int] | None = None,
                 trace: Path | None = None, probes: bool = True,
                 changes: tuple[InputChange, ...] = ()):
        self.job = job
        self.probes = probes
        self.line = line
        self.trace = trace
        if line is not None:
            check_cycles_per_bit(line[0])
            if line[1] < 0:
                raise ValueError(f"the host's turnaround must be >= 0 cycles, not {line[1]}")
        check_changes(job, changes)
        self.listener = socket.create_server((host, port))  # first: a port in use fails fast
        self.port: int = self.listener.getsockname()[1]
        try:
            self.backend: Backend = build_backend(job, kind)
        except BaseException:
            self.listener.close()
            raise
        self.identity = job_identity(job)
        self.stop = threading.Event()
        self.backend.reset()
        configure_plants(self.backend, job)
        self.store = SampleStore(job.machine.dac_bits, job.machine.axis_names)
        self.sampler = Sampler(self.backend, sample_every, self.store, skip_idle=True)
        #: The board's watchdog, E-stop and limits in front of the machine.
        self.board = BoardIO(SimulatedLink(self.sampler), self.backend, job, changes)
        self.model: BridgeModel | LineTimed = BridgeModel(
            self.board, self.identity, probe=self._probe if probes else None,
            on_frame=self.board.frame)
        if line is not None:
            self.model = LineTimed(self.model, *line)

    def _probe(self) -> list[int]:
        backend, axes = self.backend, self.job.machine.axis_names
        return [backend.cycle, backend.get("fp_total"),
                *(backend.get(f"{axis}__{name}") if axis in axes else 0
                  for axis in PROBE_AXES for name in PROBE_FIELDS)]

    def serve_one(self, conn: socket.socket, peer: str) -> Session:
        """Serve one connection to its end."""
        session = Session(peer)
        began = self.backend.cycle
        with conn:
            while not self.stop.is_set():
                timeout = self.board.seconds_to_trip(self.job.machine.clock_hz)
                if timeout is not None and timeout <= 0:
                    self.board.unattended()
                    continue
                conn.settimeout(timeout)
                try:
                    data = conn.recv(4096)
                except TimeoutError:  # a silent host: the watchdog's time has passed
                    self.board.unattended()
                    continue
                except OSError:
                    break
                if not data:
                    break
                session.received += len(data)
                reply = b"".join(self.model.receive(byte) for byte in data)
                if reply:
                    try:
                        conn.sendall(reply)
                    except OSError:
                        break
        self.board.unattended()  # the host has gone
        self.sampler.flush()
        session.cycles = self.backend.cycle - began
        if self.trace is not None:
            write_samples(self.store, self.trace)
        return session

    def serve(self, sessions: int | None = None,
              report: Callable[[Session], None] | None = None) -> None:
        """Serve connections one after another until :attr:`stop` is set or ``sessions`` were
        served; ``report`` is told of each."""
        served = 0
        self.listener.settimeout(0.2)
        while not self.stop.is_set() and (sessions is None or served < sessions):
            try:
                conn, address = self.listener.accept()
            except TimeoutError:
                continue
            conn.settimeout(None)
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            session = self.serve_one(conn, f"{address[0]}:{address[1]}")
            served += 1
            if report is not None:
                report(session)

    def close(self) -> None:
        self.listener.close()
        self.store.close()
        self.backend.close()
