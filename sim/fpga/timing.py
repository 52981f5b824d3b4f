"""The path that limits a board build's fmax, from nextpnr's timing report (``--report``).

nextpnr lists the slowest path between each pair of clock edges (``critical_paths``): from
a register's clock-to-output through logic and routing to the next register's setup. A path
between the two edges of one clock (the chipset's rising-edge registers into the K3702's
falling-edge ones) has half a clock period, so it limits fmax at twice its delay;
:func:`critical_path` picks the path that limits fmax and names its end registers.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

__all__ = ["CriticalPath", "critical_path"]

#: The suffix nextpnr's cell names get from the ECP5 cells mapped onto a signal.
_CELL_SUFFIX = re.compile(r"_(?:TRELLIS_FF|LUT4|PFUMX|L6MUX21|CCU2C|TRELLIS_IO)(?:_.*)?$")
#: A clock event as nextpnr writes it: edge and net (``posedge $glbnet$clk``).
_EVENT = re.compile(r"^(posedge|negedge) ")


@dataclass(frozen=True)
class CriticalPath:
    """The path that limits fmax: its clock edges, end registers, delay and logic levels."""

    launch: str        # "posedge" or "negedge"
    capture: str
    start: str         # the launching register (the signal it holds)
    end: str           # the capturing register
    delay_ns: float
    logic_levels: int

    @property
    def period_ns(self) -> float:
        """The clock period this path needs (twice its delay between opposite edges)."""
        return self.delay_ns * (1 if self.launch == self.capture else 2)

    def format(self) -> str:
        half = ("" if self.launch == self.capture else
                "; between opposite edges it has half a clock period")
        return (f"Critical path: {self.launch} to {self.capture} of the board clock, from "
                f"`{self.start}` to `{self.end}`, {self.delay_ns:.1f} ns through "
                f"{self.logic_levels} logic cells{half} (fmax {1e3 / self.period_ns:.1f} MHz).")


def _register(cell: str) -> str:
    """A cell's name without the ECP5 cells' suffixes: the signal it holds or drives."""
    return _CELL_SUFFIX.sub("", cell)


def critical_path(report: dict[str, Any]) -> CriticalPath | None:
    """The path of nextpnr's ``report`` (its ``--report`` JSON) that limits fmax: the one
    needing the longest clock period among those from one clock edge to another (paths to and
    from I/O pins, ``<async>``, are not clocked). None when the report lists none."""
    paths = []
    for entry in report.get("critical_paths", []):
        launch, capture = _EVENT.match(entry["from"]), _EVENT.match(entry["to"])
        steps = entry.get("path", [])
        if launch is None or capture is None or not steps:
            continue
        paths.append(CriticalPath(
            launch.group(1), capture.group(1), _register(steps[0]["from"]["cell"]),
            _register(steps[-1]["to"]["cell"]), sum(s["delay"] for s in steps),
            sum(s["type"] == "logic" for s in steps)))
    return max(paths, key=lambda p: p.period_ns, default=None)
