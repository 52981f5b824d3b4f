"""The simulated board's watchdog through the real link code: a host that stops mid-move, by
going or by falling silent, leaves the axes held and drive-enable low within the watchdog's
time; a linked run arms it, reads the board's state and reports a link lost as such."""

from __future__ import annotations

import time

import pytest

from k37.firmware_model.firmware import Firmware
from k37.firmware_model.host import Host8085
from k37.hdl.chipset.map import port
from k37.sim.link import bridge
from k37.sim.link.bridge import BridgeLink, open_link
from k37.sim.machine.plant_model import dac_zero
from k37.sim.run import linked
from k37.sim.run.linked import run_linked
from k37.sim.run.output import summary
from k37.sim.run.report import validate
from k37.sim.run.runner import RunOptions
from tests.sim.serve.test_serve import PROGRAM, served

LONG_MOVE = "G21 G91 F600\nG01 X3 Y2\nM30"
WATCHDOG = 20_000  # cycles: 20 ms at 1 MHz


def _start_moving(job, url: str) -> BridgeLink:
    """A host that arms the watchdog, starts the long move and stops 0.1 s into it."""
    link = open_link(url, timeout=10)
    link.arm_watchdog(WATCHDOG, dac_zero(job.machine.dac_bits))
    firmware = Firmware(Host8085(link, clock_hz=job.machine.clock_hz), job)
    firmware.run(link.cycle + 100_000)
    assert firmware.blocks and firmware.blocks[0].end_cycle is None  # mid-move
    return link


def _held(link: BridgeLink, since: int) -> None:
    """The board tripped on its watchdog within its time of ``since`` (the host's last
    frame) and holds: drive-enable low, the feed gate shut, the axes coming to rest."""
    status = link.board_status()
    assert status["watchdog"] == 1 and status["drive_enable"] == 0 and status["held"] == 1
    assert link.read(port("DECEL", "STATUS")) & 0x02 == 0  # not open
    before = link.probe()
    assert before is not None
    # the frame's feed, the tripping edge and the hold write; then the two reads above
    assert before.cycle - 2 <= since + WATCHDOG + 3
    # the accel/decel circuit behind the shut gate drains (the chipset's own stop feed), then
    # no step pulse comes and the unpowered axes come to rest
    seen = [before]
    while len(seen) < 3 or _moved(seen[-2], seen[-1]):
        assert len(seen) < 20, "the axes never came to rest"
        link.idle(500_000)
        seen.append(link.probe())


def _moved(a, b) -> bool:
    return any(a.axes[axis][name] != b.axes[axis][name] for axis in ("x", "y")
               for name in ("pulses_pos", "pulses_neg", "command", "count"))


def test_a_host_that_goes_mid_move_leaves_the_axes_held_and_the_drives_off(make_job):
    job = make_job(LONG_MOVE)
    with served(job, sessions=2) as board:
        url = f"tcp://127.0.0.1:{board.port}"
        link = _start_moving(job, url)
        last = link.board_cycle()
        link.close()
        link = open_link(url, timeout=10)
        _held(link, last)
        link.close()


def test_a_host_that_falls_silent_mid_move_trips_the_watchdog_by_the_wall_clock(make_job):
    job = make_job(LONG_MOVE)
    with served(job) as board:
        link = _start_moving(job, f"tcp://127.0.0.1:{board.port}")
        last = link.board_cycle()
        time.sleep(10 * WATCHDOG / job.machine.clock_hz)
        _held(link, last)
        link.close()


def test_a_linked_run_with_the_watchdog_armed_ends_ok_and_reports_the_board(make_job):
    job = make_job(PROGRAM)
    with served(job) as board:
        result = run_linked(job, RunOptions(), f"tcp://127.0.0.1:{board.port}", watchdog_s=0.5)
    report = result.report
    assert report["status"] == "ok", report["reason"]
    assert report["link"]["watchdog_cycles"] == 500_000
    assert report["link"]["board"]["drive_enable"] == 1
    assert report["link"]["board"]["watchdog"] == 0
    assert report["path"]["max_contour_error"] is None
    assert report["path"]["rms_contour_error"] is None


def test_a_latched_estop_makes_a_linked_run_a_fault(make_job):
    job = make_job(PROGRAM)
    with served(job) as board:
        board.board.estop_n = False
        result = run_linked(job, RunOptions(max_cycles=300_000),
                            f"tcp://127.0.0.1:{board.port}", watchdog_s=0.5)
    assert result.report["status"] == "fault"
    assert "E-stop" in result.report["reason"]
    assert result.report["link"]["board"]["estop"] == 1
    assert not result.ok


class _Cut:
    """A port whose cable is pulled after ``writes`` frames."""

    def __init__(self, port, writes: int):
        self.port, self.writes = port, writes

    def write(self, data: bytes) -> int:
        self.writes -= 1
        if self.writes < 0:
            raise OSError("the cable was pulled")
        return self.port.write(data)

    def read(self, n: int) -> bytes:
        return self.port.read(n)

    def close(self) -> None:
        self.port.close()


def test_a_link_lost_mid_run_reports_link_lost_with_nulls(make_job, monkeypatch):
    job = make_job(PROGRAM)
    with served(job) as board:
        url = f"tcp://127.0.0.1:{board.port}"
        monkeypatch.setattr(linked, "open_link", lambda u: BridgeLink(
            _Cut(bridge._serial_for_url(f"socket://127.0.0.1:{board.port}", timeout=10), 60),
            u))
        result = run_linked(job, RunOptions(), url)
    report = result.report
    validate(report)
    assert report["status"] == "link-lost"
    assert "the cable was pulled" in report["reason"]
    assert not result.ok
    assert all(a["command"] is None and a["actual"] is None for a in report["axes"].values())
    assert report["end_point"]["reached"] is False
    assert report["link"]["board_cycle"] is None and report["link"]["board"] is None
    text = summary(result)
    assert "link-lost" in text and "x: unknown (the link was lost)" in text


@pytest.mark.parametrize("seconds", [0.0, 20.0])
def test_a_watchdog_time_out_of_range_is_refused(make_job, seconds):
    with pytest.raises(linked.OptionError, match="--watchdog"):
        run_linked(make_job(PROGRAM), RunOptions(), "tcp://127.0.0.1:1", watchdog_s=seconds)
