"""The path that limits a board build's fmax, read from nextpnr's timing report."""

from __future__ import annotations

from pathlib import Path

from k37.sim.fpga.build import BoardReport
from k37.sim.fpga.timing import critical_path

CLOCK = "$glbnet$clk_buffer.buf.i"


def _step(kind: str, cell: str, delay: float) -> dict:
    end = {"cell": cell, "loc": [1, 1], "port": "Q"}
    return {"type": kind, "from": end, "to": end, "delay": delay}


def _path(launch: str, capture: str, start: str, end: str, logic: list[float]) -> dict:
    steps = [_step("clk-to-q", start, 0.5), *(_step("logic", f"{end}_LUT4_Z", d) for d in logic),
             _step("setup", end, 0.2)]
    return {"from": launch, "to": capture, "path": steps}


REPORT = {"critical_paths": [
    _path(f"posedge {CLOCK}", f"posedge {CLOCK}", "top.core.count_TRELLIS_FF_Q",
          "top.bridge.crc_TRELLIS_FF_Q_DI", [9.0, 10.3]),                       # 20 ns
    _path(f"posedge {CLOCK}", f"negedge {CLOCK}", "top.core.chipset.k3701.x_pos_TRELLIS_FF_Q",
          "top.core.chipset.k3702_x.in_position_TRELLIS_FF_Q", [5.0, 5.0, 2.0]),  # 12.7 ns
    _path("<async>", f"posedge {CLOCK}", "reset_buffer.buf.buf0", "reset_TRELLIS_FF_Q", [40.0]),
]}


def test_a_path_between_opposite_edges_limits_fmax_at_twice_its_delay():
    path = critical_path(REPORT)
    assert (path.launch, path.capture) == ("posedge", "negedge")
    assert (path.start, path.end) == ("top.core.chipset.k3701.x_pos",
                                      "top.core.chipset.k3702_x.in_position")
    assert round(path.delay_ns, 6) == 12.7 and path.logic_levels == 3
    assert round(path.period_ns, 6) == 25.4
    assert "fmax 39.4 MHz" in path.format() and "half a clock period" in path.format()


def test_unclocked_paths_and_an_empty_report_name_no_critical_path():
    assert critical_path({"critical_paths": REPORT["critical_paths"][2:]}) is None
    assert critical_path({}) is None


def test_the_build_report_names_the_critical_path():
    report = BoardReport("ulx3s-25f", Path("."), "k37_ulx3s_25f_3axis", False, 1.0,
                         bitstream_bytes=1, cells={}, utilisation={}, fmax_mhz=39.4,
                         critical=critical_path(REPORT))
    assert ("Critical path: posedge to negedge of the board clock, from "
            "`top.core.chipset.k3701.x_pos` to `top.core.chipset.k3702_x.in_position`, 12.7 ns "
            "through 3 logic cells") in report.format()
