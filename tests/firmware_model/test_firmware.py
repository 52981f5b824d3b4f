"""Firmware model: 8085 I/O timing, feed words, and what it refuses before loading."""

from __future__ import annotations

from dataclasses import replace

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from k37.firmware_model.feeds import (
    FirmwareError,
    check_program,
    clamped_feeds,
    feed_limit,
    feed_word,
    max_feed_mm_min,
    run_feed,
    word_feed,
    word_rate,
)
from k37.firmware_model.host import T_STATES, Host8085
from k37.firmware_model.job import MachineConfig, RunConfig
from k37.hdl.chipset.map import port
from k37.hdl.feed.map.feed_rate import FEED_BITS
from k37.hdl.k3701.block import Kind


class FakeLink:
    """A :class:`k37.firmware_model.link.ChipsetLink` that records the cycle of every bus access;
    reads return a fixed byte."""

    def __init__(self):
        self.cycle = 0
        self.writes: list[tuple[int, int, int]] = []

    def idle(self, n: int) -> None:
        self.cycle += n

    def write(self, addr: int, data: int) -> None:
        self.writes.append((self.cycle, addr, data))
        self.cycle += 1

    def read(self, addr: int) -> int:
        self.cycle += 1
        return 0x5A


def test_out_instructions_take_17_t_states_at_the_host_clock():
    backend = FakeLink()
    host = Host8085(backend, host_hz=3.072e6, clock_hz=1e6)
    for k in range(300):
        host.out(0x10, k & 0xFF)
    assert host.t_states == 300 * T_STATES.out_byte
    # 300 x 17 T-states at 3.072 MHz = 1660.16 us: the 300th write ends in cycle 1660.
    assert backend.cycle == int(300 * 17 / 3.072)
    gaps = {b[0] - a[0] for a, b in zip(backend.writes, backend.writes[1:], strict=False)}
    assert gaps <= {5, 6}


def test_register_writes_go_lsb_first_to_the_chip_select_ports():
    backend = FakeLink()
    host = Host8085(backend)
    host.write("K3701", "X", -2)
    assert [(a, d) for _, a, d in backend.writes] == [
        (port("K3701", "X", 0), 0xFE), (port("K3701", "X", 1), 0xFF),
        (port("K3701", "X", 2), 0xFF)]
    with pytest.raises(ValueError, match="K3701 STATUS is read-only"):
        host.write("K3701", "STATUS", 1)
    with pytest.raises(ValueError, match="register X: 8388608 is outside"):
        host.write("K3701", "X", 1 << 23)
    assert host.read("K3701", "X") == 0x5A5A5A


def test_feed_word_gives_the_programmed_feed_from_the_rate_multiplier():
    machine = MachineConfig()
    # 600 mm/min = 1e4 LSB/s; the rate multiplier's input clock is 1 MHz / 11.
    word = feed_word(machine, 600.0)
    assert word == round(1e4 / (1e6 / 11) * 2**18)
    assert word * (1e6 / 11) / 2**18 == pytest.approx(1e4, rel=1e-4)


@settings(derandomize=True, max_examples=200, deadline=None)
@given(st.integers(1, (1 << FEED_BITS) - 1), st.sampled_from([0.001, 0.0254, 0.01]),
       st.sampled_from([1_000_000, 2_000_000, 3_072_000]))
def test_a_word_gives_back_its_feed_and_the_feed_its_word(word, lsb_mm, clock_hz):
    machine = MachineConfig(clock_hz=clock_hz, lsb_mm=lsb_mm)
    feed = word_feed(machine, word)
    assert feed_word(machine, feed) == word
    assert feed == pytest.approx(machine.mm_per_min(clock_hz / 11 * word / 2**FEED_BITS))


def test_maximum_feeds_follow_the_step_latencies():
    machine = MachineConfig()
    assert max_feed_mm_min(machine, Kind.LINEAR) == pytest.approx(1e6 / 11 * 0.06)
    assert max_feed_mm_min(machine, Kind.CIRCULAR) == pytest.approx(1e6 / 21 * 0.06)


@pytest.mark.parametrize(("gcode", "message"), [
    ("G01 X1 F6000", r"t.ngc:1:8: feed 6000 mm/min is above the K3701's maximum for a line, "
                     r"5454.54 mm/min .*: lower F6000, or raise machine.clock_hz or "
                     r"machine.lsb_mm \(run.strict_feed = false clamps it to the "
                     r"maximum\)$"),
    ("G01 X1 F5455", r"t.ngc:1:8: feed 5455 mm/min is above the K3701's maximum for a line, "
                     r"5454.54 mm/min"),
    ("G01 X1 F0.01", r"t.ngc:1: feed 0.01 mm/min is below the rate multiplier's resolution, "
                     r"0.0208 mm/min"),
])
def test_impossible_feeds_are_refused_with_the_line_under_strict_feed(make_job, gcode, message):
    job = replace(make_job(gcode, source="t.ngc"), run=RunConfig(strict_feed=True))
    with pytest.raises(FirmwareError, match=message):
        check_program(job)


def test_feeds_above_the_maximum_run_at_it_with_one_warning_naming_the_lines(make_job):
    job = make_job("G21 G90 F9000\nG01 X10\nG01 X20\nG02 X30 I5 F4000\nG01 X0 F100\n"
                   "G01 X1 F6000", source="t.ngc")
    check_program(job)
    moves = job.program.moves
    assert [run_feed(m, job.machine) for m in moves] == [
        feed_limit(job.machine, Kind.LINEAR)] * 2 + [feed_limit(job.machine, Kind.CIRCULAR),
                                                      100, feed_limit(job.machine, Kind.LINEAR)]
    assert clamped_feeds(job) == [
        "t.ngc:2: feeds above the K3701's maximum run at it: lines 2-3, 6 at 5454.52 mm/min "
        "(the maximum for lines); line 4 at 2857.13 mm/min (the maximum for arcs) "
        "(run.strict_feed = true refuses them)"]
    assert clamped_feeds(make_job("G01 X1 F5000")) == []


def test_a_clamped_feed_is_the_fastest_word_not_above_the_step_rate():
    machine = MachineConfig()
    for kind in (Kind.LINEAR, Kind.CIRCULAR):
        word = feed_word(machine, feed_limit(machine, kind))
        assert word_rate(machine, word) <= machine.clock_hz / (11 if kind is Kind.LINEAR else 21)
        assert word_rate(machine, word + 1) > machine.clock_hz / (11 if kind is Kind.LINEAR
                                                                    else 21) \
            or word + 1 == 1 << FEED_BITS


def test_rapid_moves_use_the_machine_rapid_feed(make_job):
    check_program(make_job("G00 X5 Y5"))  # 3000 mm/min: inside the linear maximum
