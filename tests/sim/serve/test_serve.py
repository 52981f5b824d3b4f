"""One host link, three transports: a job's firmware over the bridge protocol to a simulated
board (``k37 serve``) gives the run in process, block for block; link failures are clear
errors."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager

import pytest

from k37.firmware_model.job import Job, MachineConfig
from k37.hdl.bridge.protocol import DEFAULT_BAUD, OK, Identity, Op, encode, stuff
from k37.hdl.chipset.identity import chipset_identity
from k37.hdl.chipset.map import Accel, port
from k37.sim.link.bridge import (
    BridgeLink,
    LinkError,
    job_identity,
    open_link,
)
from k37.sim.run.linked import run_linked
from k37.sim.run.output import summary, write_trace
from k37.sim.run.runner import RunOptions, run_job, system_params
from k37.sim.serve.server import SimulatedBoard

#: What a link run shares with the run in process: everything the firmware and the pulses
#: decide (not how the run was computed, nor the samples the served machine keeps).
SAME = ("status", "reason", "cycles", "blocks", "axes", "end_point", "alarms")

PROGRAM = """G21 G91 F600
G01 X0.4 Y0.2
G04 P0.05
G03 X0 Y0 I0.1 J0
G01 X-0.2 Y-0.3
M30"""


def _program(axes: int) -> str:
    return PROGRAM.replace("G01 X0.4 Y0.2", "G01 X0.4 Y0.2 Z0.1") if axes == 3 else PROGRAM


@contextmanager
def served(job: Job, sessions: int = 1, kind: str = "cxxrtl",
           **options) -> Iterator[SimulatedBoard]:
    board = SimulatedBoard(job, kind, **options)
    thread = threading.Thread(target=board.serve, args=(sessions,), daemon=True)
    thread.start()
    try:
        yield board
    finally:
        board.stop.set()
        thread.join(10)
        board.close()


@pytest.mark.parametrize("axes", [2, 3])
def test_a_job_over_a_served_link_matches_the_run_in_process_block_for_block(make_job, axes):
    job = make_job(_program(axes), MachineConfig(axes=axes))
    here = run_job(job, RunOptions(backend="cxxrtl"))
    with served(job) as board:
        linked = run_linked(job, RunOptions(), f"tcp://127.0.0.1:{board.port}")
    assert len(here.report["blocks"]) == 3  # the dwell is no block
    for key in SAME:
        assert linked.report[key] == here.report[key], key
    assert linked.report["link"]["probes"] is True
    assert linked.report["backend"] == "link"
    assert linked.report["path"]["samples"] == 0


@pytest.mark.parametrize("axes", [2, 3])
def test_the_served_machine_s_trace_is_the_run_in_process_s(make_job, tmp_path, axes):
    job = make_job(_program(axes), MachineConfig(axes=axes))
    here = run_job(job, RunOptions(backend="cxxrtl"))
    write_trace(here, tmp_path / "here.csv")
    with served(job, kind="auto", trace=tmp_path / "served.csv") as board:
        assert board.backend.name == "engine"  # a trace of samples needs no internal signal
        run_linked(job, RunOptions(), f"tcp://127.0.0.1:{board.port}")
    wanted = (tmp_path / "here.csv").read_text().splitlines()
    assert len(wanted) > 1000
    # the served machine also ran the few cycles of the final reads
    assert (tmp_path / "served.csv").read_text().splitlines()[:len(wanted)] == wanted


def test_a_board_without_probe_reports_what_a_host_can_read(make_job):
    job = make_job(PROGRAM)
    here = run_job(job, RunOptions(backend="cxxrtl"))
    with served(job, probes=False) as board:
        linked = run_linked(job, RunOptions(), f"tcp://127.0.0.1:{board.port}")
    report = linked.report
    assert report["link"]["probes"] is False
    # the blocks' cycles on the board, from its bridge's counter: on a board without line
    # time, the host's count
    assert report["link"]["board_blocks"] == [[b["start_cycle"], b["end_cycle"]]
                                              for b in report["blocks"]]
    assert report["link"]["board_cycles"] == report["cycles"]
    for a, b in zip(here.report["blocks"], report["blocks"], strict=True):
        assert (b["fp_pulses"], b["steps"], b["end_command"]) == (None, None, None)
        assert (b["start_cycle"], b["end_cycle"]) == (a["start_cycle"], a["end_cycle"])
    for axis, seen in report["axes"].items():
        there = here.report["axes"][axis]
        # command and error from the K3702's registers; the position is the K3702's count
        assert (seen["command"], seen["error"]) == (there["command"], there["error"])
        assert seen["actual"] == seen["command"] - seen["error"]
        assert seen["max_abs_error"] is None
        assert seen["flags"] == there["flags"]
    assert report["end_point"]["reached"] == here.report["end_point"]["reached"]
    text = summary(linked)
    assert "max |error| unknown" in text
    assert "machine time by the host's count" in text
    assert f"the board's own count (its bridge's counter): {report['cycles']:,} cycles" in text


def test_a_served_board_keeps_its_state_across_sessions_and_a_cut_frame_writes_nothing(
        make_job):
    job = make_job("G21 G91 F900\nG01 X0.2 Y0.1\nM30")
    zone = [port("K3702_X", "POSITION_ZONE", k) for k in range(3)]
    with served(job, sessions=3) as board:
        url = f"tcp://127.0.0.1:{board.port}"
        link = open_link(url, timeout=5)
        for k, address in enumerate(zone):
            link.write(address, 0x12 + k)
        link.close()
        with socket.create_connection(("127.0.0.1", board.port)) as host:
            host.sendall(encode(Op.WRITE, zone[0], 0x49, seq=9)[:-1])  # a host dies mid-frame
        link = open_link(url, timeout=5)
        assert [link.read(address) for address in zone] == [0x12, 0x13, 0x14]
        assert link.board_cycle() > 3
        link.close()


def test_a_machine_with_other_axes_is_refused(make_job):
    job2 = make_job("G21 G91 F900\nG01 X0.2 Y0.1\nM30")
    job3 = make_job("G21 G91 F900\nG01 X0.2 Y0.1 Z0.1\nM30", MachineConfig(axes=3))
    with served(job2) as board, pytest.raises(
            LinkError, match="the chipset there has 2 axes, the job's machine 3"):
        run_linked(job3, RunOptions(), f"tcp://127.0.0.1:{board.port}")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_a_refused_connection_is_named():
    url = f"tcp://127.0.0.1:{_free_port()}"
    with pytest.raises(LinkError, match="cannot open: connection refused"):
        open_link(url)


def test_a_board_that_does_not_answer_times_out():
    with socket.create_server(("127.0.0.1", 0)) as silent:
        link = open_link(f"tcp://127.0.0.1:{silent.getsockname()[1]}", timeout=0.2)
        with pytest.raises(LinkError, match="no reply to IDENT"):
            link.identify()
        link.close()


def test_a_far_end_that_is_no_bridge_is_named():
    link = open_link("loop://", timeout=0.2)  # echoes what is sent
    with pytest.raises(LinkError, match=r"IDENT answered b'I', not OK"):
        link.check(chipset_identity())
    link.close()


class Replies:
    """A far end that answers whatever is sent with the bytes given."""

    def __init__(self, data: bytes):
        self.data = bytearray(data)
        self.sent: list[bytes] = []

    def write(self, frame: bytes) -> None:
        self.sent.append(frame)

    def read(self, n: int) -> bytes:
        out = bytes(self.data[:n])
        del self.data[:n]
        return out

    def close(self) -> None:
        pass


IDENT_REPLY = stuff(bytes([OK, 0]) + chipset_identity().encode())


def test_an_error_reply_or_a_short_one_is_named():
    with pytest.raises(LinkError, match="far: the bridge answered IDENT with error FRAMING"):
        BridgeLink(Replies(stuff(b"!\x02") * 3), "far").identify()
    with pytest.raises(LinkError, match="far: IDENT's reply had 1 bytes of results, not 6"):
        BridgeLink(Replies(stuff(b"+\x00\x01")), "far").identify()
    real = BridgeLink(Replies(IDENT_REPLY + stuff(b"!\x01")), "far")  # no PROBE: a real board
    assert real.probe() is None
    assert real.probes is False


def test_a_frame_answered_with_an_error_or_a_broken_reply_is_sent_again():
    far = Replies(stuff(b"!\x03") + b"\xc1+\x00\x00\xc0" + IDENT_REPLY
                  + stuff(bytes([OK, 0]) + b"\x09") + stuff(bytes([OK, 1, 0x42])))
    link = BridgeLink(far, "far")
    assert link.identify() == chipset_identity()
    assert link.read(7) == 0x42  # a stale reply with another sequence byte is skipped
    assert far.sent == [encode(Op.IDENT, seq=0)] * 2 + [encode(Op.READ, 7, seq=1)]


def test_urls_choose_the_transport():
    opened = []

    def opener(target, **kwargs):
        opened.append((target, kwargs))

    open_link("tcp://10.0.0.2:4000", timeout=1.0, opener=opener)
    open_link("serial:///dev/ttyUSB0", timeout=1.0, opener=opener)
    open_link("serial:///dev/ttyUSB1?baud=115200", timeout=1.0, opener=opener)
    open_link("/dev/ttyACM0", timeout=1.0, opener=opener)
    assert opened == [
        ("socket://10.0.0.2:4000", {"timeout": 1.0}),
        ("/dev/ttyUSB0", {"timeout": 1.0, "baudrate": DEFAULT_BAUD}),
        ("/dev/ttyUSB1", {"timeout": 1.0, "baudrate": 115200}),
        ("/dev/ttyACM0", {"timeout": 1.0, "baudrate": DEFAULT_BAUD})]
    for url, message in (("tcp://host", "give tcp://HOST:PORT"),
                         ("serial:///dev/ttyUSB0?baud=fast", "baud must be a positive integer")):
        with pytest.raises(LinkError, match=message):
            open_link(url, opener=opener)


def test_the_identity_tells_chipsets_built_otherwise_apart():
    plain = chipset_identity()
    assert chipset_identity(accel=Accel.PRE, accel_shape="exponential") == plain
    others = [chipset_identity(**params) for params in (
        {"axes": 3}, {"accel": "post"}, {"accel": "none"}, {"accel_bits": 16},
        {"accel_shape": "linear"}, {"accel": "post", "axis_fa": ("x",)},
        {"accel": "post", "axis_accel": {"y": ("bell", 12)}})]
    assert len({plain.fingerprint, *(o.fingerprint for o in others)}) == 1 + len(others)
    assert Identity.decode(plain.encode()) == plain


def test_the_host_and_the_served_machine_agree_on_a_jobs_identity(make_job):
    job = make_job("G21 G91 F900\nG01 X0.2 Y0.1\nM30", MachineConfig(accel="post",
                                                                    accel_shape="linear"))
    built = {k: v for k, v in system_params(job).items() if k != "drives"}
    assert job_identity(job) == chipset_identity(**built)
    assert job_identity(job) != chipset_identity()


def test_run_link_errors_are_one_line_and_exit_2(k37):
    result = k37("run", "--link", f"tcp://127.0.0.1:{_free_port()}")
    assert result.returncode == 2
    assert result.stderr.startswith("k37: error: tcp://127.0.0.1:")
    assert "connection refused" in result.stderr
    assert "Traceback" not in result.stderr
    result = k37("run", "--link", "tcp://127.0.0.1:1", "--plot", "p.png")
    assert result.returncode == 2
    assert "not with --link" in result.stderr


def test_serve_refuses_a_port_in_use(k37):
    with socket.create_server(("127.0.0.1", 0)) as busy:
        port = busy.getsockname()[1]
        result = k37("serve", "--port", str(port))
    assert result.returncode == 2
    assert result.stderr.startswith(f"k37: error: --port {port}: cannot listen on 127.0.0.1: ")
    assert "Traceback" not in result.stderr


@contextmanager
def serve_process(cwd, *options: str) -> Iterator[tuple[str, subprocess.Popen]]:
    """``k37 serve --port 0 --sessions 1 OPTIONS`` running in ``cwd``: its URL (read from its
    first line on stderr) and the process, killed on leaving."""
    serve = subprocess.Popen([sys.executable, "-m", "k37.sim.cli", "serve", "--port", "0",
                              "--sessions", "1", *options], stderr=subprocess.PIPE, text=True,
                             cwd=cwd)
    try:
        line = serve.stderr.readline()
        assert "tcp://127.0.0.1:" in line, line
        yield line[line.index("tcp://"):].split()[0], serve
    finally:
        serve.kill()
        serve.wait()
        serve.stderr.close()


@pytest.mark.slow
def test_k37_serve_and_run_link_from_the_command_line(tmp_path):
    with serve_process(tmp_path) as (url, serve):
        linked = subprocess.run([sys.executable, "-m", "k37.sim.cli", "run", "--link", url,
                                 "--json", "linked.json", "-q"], cwd=tmp_path,
                                capture_output=True, text=True, timeout=300)
        assert linked.returncode == 0, linked.stderr
        assert serve.wait(60) == 0
    here = subprocess.run([sys.executable, "-m", "k37.sim.cli", "run", "--json", "here.json", "-q"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert here.returncode == 0, here.stderr
    a, b = (json.loads((tmp_path / name).read_text()) for name in ("here.json", "linked.json"))
    for key in SAME:
        assert a[key] == b[key], key


def test_line_time_lengthens_the_gaps_and_keeps_every_blocks_pulses(make_job):
    job = make_job("G21 G91 F600\nG01 X0.3 Y0.1\nG01 X-0.1 Y0.2\nM30")
    here = run_job(job, RunOptions(backend="cxxrtl")).report
    board = SimulatedBoard(job, "cxxrtl", line=(8, 500))
    thread = threading.Thread(target=board.serve, args=(1,), daemon=True)
    thread.start()
    try:
        linked = run_linked(job, RunOptions(), f"tcp://127.0.0.1:{board.port}").report
    finally:
        thread.join(10)
        board.close()
    for a, b in zip(here["blocks"], linked["blocks"], strict=True):
        assert (a["fp_pulses"], a["steps"], a["end_command"]) == \
            (b["fp_pulses"], b["steps"], b["end_command"])
    (_, end0), (start1, _) = linked["link"]["board_blocks"]
    in_process_gap = here["blocks"][1]["start_cycle"] - here["blocks"][0]["end_cycle"]
    # every command of the gap now also costs its bytes (80 cycles each) and the host's 500
    assert start1 - end0 > in_process_gap + 500
    assert linked["link"]["board_cycle"] > linked["link"]["board_cycles"] > linked["cycles"]


def test_a_bad_line_is_refused(make_job):
    job = make_job("G21 G91 F600\nG01 X0.3 Y0.1\nM30")
    with pytest.raises(ValueError, match="cycles per UART bit must be an integer"):
        SimulatedBoard(job, "cxxrtl", line=(2, 0))
