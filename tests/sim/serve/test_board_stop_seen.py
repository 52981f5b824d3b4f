"""A stop the board latches mid-run, seen by the host while it waits (through the real link
code): a linked run with the watchdog armed ends there as a ``fault`` naming the stop and the
board cycle it was seen at, within a quarter of the watchdog's time; ``k37 serve --estop-at``
and ``--limit`` press the simulated board's inputs."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from k37.hdl.chipset.map import port
from k37.sim.link.bridge import open_link
from k37.sim.machine.plant_model import dac_zero
from k37.sim.run.linked import run_linked
from k37.sim.run.report import validate
from k37.sim.run.runner import RunOptions
from k37.sim.serve.board import InputChange
from tests.sim.serve.test_board_stop import LONG_MOVE, _moved
from tests.sim.serve.test_serve import serve_process, served

WATCHDOG_S = 0.1  # 100,000 cycles at 1 MHz: STATUS read every 25,000 cycles of waiting
EVERY = 25_000
PRESSED = 160_000  # mid-move (the long move takes about 360,000 cycles), between reads
#: The bus cycles between the last wait before a STATUS read is due and the read: a few
#: timer or interrupt routines' accesses.
SLACK = 200


def _stopped_run(job, change: InputChange):
    with served(job, sessions=2, changes=(change,)) as board:
        url = f"tcp://127.0.0.1:{board.port}"
        result = run_linked(job, RunOptions(), url, watchdog_s=WATCHDOG_S)
        link = open_link(url, timeout=10)
        gate_open = link.read(port("DECEL", "STATUS")) & 0x02
        seen = [link.probe()]
        while len(seen) < 3 or _moved(seen[-2], seen[-1]):
            assert len(seen) < 20, "the axes never came to rest"
            link.idle(500_000)
            seen.append(link.probe())
        link.close()
    report = result.report
    validate(report)
    assert report["status"] == "fault" and not result.ok
    stop = report["link"]["stop_seen"]
    assert PRESSED + 1 < stop["board_cycle"] <= PRESSED + EVERY + SLACK
    assert f"seen at board cycle {stop['board_cycle']:,}" in report["reason"]
    # the run ended there, with the first block begun and kept, not at its cycle limit
    assert report["cycles"] <= stop["cycle"] + SLACK
    assert report["blocks"][0]["start_cycle"] is not None
    assert report["blocks"][0]["end_cycle"] is None
    assert gate_open == 0  # the feed held
    return report


def test_an_estop_pressed_mid_move_ends_the_linked_run_at_once_with_the_drives_off(make_job):
    report = _stopped_run(make_job(LONG_MOVE), InputChange(PRESSED, "estop"))
    assert "E-stop" in report["reason"] and "limit" not in report["reason"]
    board = report["link"]["board"]
    assert board["estop"] == 1 and board["drive_enable"] == 0 and board["held"] == 1


def test_a_limit_hit_mid_move_ends_the_linked_run_naming_the_axis_with_the_drives_on(
        make_job):
    report = _stopped_run(make_job(LONG_MOVE), InputChange(PRESSED, "y"))
    assert "the Y limit" in report["reason"] and "E-stop" not in report["reason"]
    board = report["link"]["board"]
    assert board["limit_y"] == 1 and board["limit_x"] == 0
    assert board["drive_enable"] == 1 and board["held"] == 1


def test_a_run_with_the_watchdog_and_no_stop_sees_none(make_job):
    job = make_job(LONG_MOVE)
    with served(job) as board:
        report = run_linked(job, RunOptions(), f"tcp://127.0.0.1:{board.port}",
                            watchdog_s=WATCHDOG_S).report
    assert report["status"] == "ok", report["reason"]
    assert report["link"]["stop_seen"] is None


def test_a_run_without_the_watchdog_does_not_watch_for_stops(make_job):
    job = make_job(LONG_MOVE)
    with served(job, changes=(InputChange(PRESSED, "estop"),)) as board:
        report = run_linked(job, RunOptions(max_cycles=400_000),
                            f"tcp://127.0.0.1:{board.port}").report
    # the stop is found only when the held run reaches its cycle limit
    assert report["status"] == "fault" and "E-stop" in report["reason"]
    assert "stop_seen" not in report["link"]
    assert report["cycles"] >= 400_000


@pytest.mark.parametrize(("option", "value", "message"), [
    ("--limit", "w@100", "--limit: 'w': not an input of the 2-axis board"),
    ("--limit", "100", "give AXIS@CYCLE[:RELEASE]"),
    ("--estop-at", "500:400", "the release cycle must come after 500"),
    ("--estop-at", "soon", "is not a number of cycles"),
])
def test_serve_refuses_an_input_it_cannot_press(k37, option, value, message):
    result = k37("serve", "--port", "0", option, value)
    assert result.returncode == 2
    assert message in result.stderr
    assert "Traceback" not in result.stderr


@pytest.mark.slow
def test_k37_serve_estop_at_ends_k37_run_link_watchdog_with_a_fault(tmp_path):
    with serve_process(tmp_path, "--estop-at", "300000") as (url, serve):
        assert serve.stderr.readline() == "k37 serve: the E-stop pressed at cycle 300,000\n"
        linked = subprocess.run([sys.executable, "-m", "k37.sim.cli", "run", "--link", url,
                                 "--watchdog", "0.5", "--json", "linked.json", "-q"],
                                cwd=tmp_path, capture_output=True, text=True, timeout=300)
        assert linked.returncode == 1, linked.stderr
        assert serve.wait(60) == 0
    report = json.loads((tmp_path / "linked.json").read_text())
    assert report["status"] == "fault" and "E-stop" in report["reason"]
    assert 300_000 <= report["link"]["stop_seen"]["board_cycle"] <= 300_000 + 125_000 + SLACK


def test_a_served_estop_latches_at_its_cycle_and_stays_latched_after_its_release(make_job):
    job = make_job(LONG_MOVE)
    changes = (InputChange(10_000, "estop"), InputChange(20_000, "estop", active=False))
    with served(job, changes=changes) as board:
        link = open_link(f"tcp://127.0.0.1:{board.port}", timeout=10)
        link.idle(10_000 - link.probe().cycle - 1)
        before = link.board_status()  # read in cycle 9,999
        pressed = link.board_status()  # in cycle 10,000: its edge latches the E-stop
        after = link.board_status()
        link.idle(15_000)
        released = link.board_status()
        link.arm_watchdog(0, dac_zero(job.machine.dac_bits))  # clears the latched stops
        cleared = link.board_status()
        link.close()
    assert before["estop_in"] == 0 and before["estop"] == 0 and before["drive_enable"] == 1
    assert pressed["estop_in"] == 1 and pressed["estop"] == 0
    assert after["estop"] == 1 and after["estop_in"] == 1 and after["drive_enable"] == 0
    assert released["estop"] == 1 and released["estop_in"] == 0
    assert cleared["estop"] == 0 and cleared["drive_enable"] == 1 and cleared["held"] == 0
