"""Running a job's firmware over a link: a simulated board (``k37 serve``) or the real one.

:func:`run_linked` runs :class:`k37.firmware_model.firmware.Firmware` on a
:class:`k37.sim.link.bridge.BridgeLink` and reports as :func:`k37.sim.run.runner.run_job`
does, with what a host can know:

* every block's cycles, FP budget and feed word, the alarms and events: the firmware's own;
* every block's FP and step pulses and end command, and each axis's counters and encoder count:
  read with the simulated board's PROBE command at the firmware's trace points (no bus cycle, so
  the run is the one in process); a real board has no PROBE: the blocks' pulses are null, an
  axis's command and error are read from its K3702 over the bus after the run, its position is
  COMMAND - ERROR (the K3702's view of the encoder) and its largest error is null;
* no samples: the trace, the plot, the path's contour error and the ballbar are the machine's
  (``k37 serve --trace`` writes a simulated board's); the report's ``path`` has 0 samples and
  null errors;
* the board's STATUS (watchdog, E-stop, limits), read when the run ends: a stop the board
  latched makes the run's status ``fault``. With ``watchdog_s`` the host arms the board's
  watchdog before the run (its frames feed it) and turns it off after, and reads STATUS
  after every quarter of the watchdog's time spent idling or waiting
  (:meth:`BridgeLink.watch_stops`): a stop latched mid-run ends the run there, a ``fault``
  whose report says where it was seen (``link.stop_seen``), with what was computed so far.

A link lost during the run still gives a report: status ``link-lost``, what was not read
null.
"""

from __future__ import annotations

import time

from k37.firmware_model.feeds import check_program
from k37.firmware_model.firmware import BlockRecord, Firmware
from k37.firmware_model.host import Host8085
from k37.firmware_model.job import Job
from k37.hdl.board.map import WATCHDOG_BITS
from k37.hdl.bridge.protocol import COUNTER_BITS
from k37.hdl.chipset.map import chip_register, port
from k37.sim.link.bridge import (
    BoardStopError,
    BridgeLink,
    LinkError,
    Probe,
    job_identity,
    open_link,
)
from k37.sim.machine.plant_model import dac_zero
from k37.sim.run.assemble import report_document, run_status
from k37.sim.run.meter import BlockMeasure
from k37.sim.run.report import validate
from k37.sim.run.runner import OptionError, RunOptions, RunResult, cycle_limit
from k37.sim.run.sampler import SampleStore

__all__ = ["LinkError", "check_linked_options", "run_linked"]


def check_linked_options(options: RunOptions) -> None:
    """Refuse options a linked run cannot honour: the machine's own (a waveform, faults)."""
    if options.vcd is not None:
        raise OptionError("--vcd: not with --link: the waveform is the served machine's")
    if options.faults:
        raise OptionError("--stall, --break-line, --load-step: not with --link: faults are "
                          "the served machine's")


class _ProbeMeter:
    """Block measures from the board's PROBE at the firmware's trace points (none from a
    board without it)."""

    def __init__(self, link: BridgeLink, axes: tuple[str, ...]):
        self.link = link
        self.axes = axes
        self.measures: dict[int, BlockMeasure | None] = {}
        #: Each block's start and end cycle on the board: from PROBE, else from the bridge's
        #: cycle counter (a command more at each, no bus cycle); the end None until it ends.
        self.board_cycles: dict[int, list[int | None]] = {}
        self._start: Probe | None = None

    def _board_cycle(self, probe: Probe | None) -> int:
        return probe.cycle if probe is not None else self.link.board_cycle()

    def block_started(self, record: BlockRecord) -> None:
        self._start = self.link.probe()
        self.board_cycles[record.index] = [self._board_cycle(self._start), None]

    def block_ended(self, record: BlockRecord) -> None:
        end = self.link.probe()
        self.board_cycles[record.index][1] = self._board_cycle(end)
        if end is None or self._start is None:
            self.measures[record.index] = None
            return
        start = self._start
        steps = {f"{axis}{sign}": end.axes[axis][name] - start.axes[axis][name]
                 for axis in self.axes for sign, name in (("+", "pulses_pos"),
                                                          ("-", "pulses_neg"))}
        self.measures[record.index] = BlockMeasure(
            end.fp_total - start.fp_total, steps,
            tuple(end.axes[axis]["pulses_pos"] - end.axes[axis]["pulses_neg"]
                  for axis in self.axes))

    def report(self, b: BlockRecord) -> dict:
        m = self.measures.get(b.index)
        return {"index": b.index, "line": b.line, "kind": b.kind, "start_cycle": b.start_cycle,
                "end_cycle": b.end_cycle, "fp_budget": b.fp_budget,
                "fp_pulses": None if m is None else m.fp_pulses, "feed_word": b.feed_word,
                "steps": None if m is None else m.steps,
                "end_command": None if m is None or m.end_command is None
                else list(m.end_command)}


def _signed(data: int, bits: int) -> int:
    return data - (1 << bits) if data >> (bits - 1) else data


def _read_register(link: BridgeLink, chip: str, name: str) -> int:
    reg = chip_register(chip, name)
    data = sum(link.read(port(chip, name, k)) << 8 * k for k in range(reg.nbytes))
    return _signed(data, reg.width) if reg.signed else data


def _axes(link: BridgeLink, job: Job, probe: Probe | None) -> dict[str, dict]:
    axes = {}
    for axis in job.machine.axis_names:
        chip = f"K3702_{axis.upper()}"
        if probe is not None:
            seen = probe.axes[axis]
            counters = {"command": seen["command"], "error": seen["error"],
                        "actual": seen["count"], "max_abs_error": seen["max_abs_error"]}
        else:
            command = _read_register(link, chip, "COMMAND")
            error = _read_register(link, chip, "ERROR")
            counters = {"command": command, "error": error, "actual": command - error,
                        "max_abs_error": None}
        word = link.read(port(chip, "STATUS"))
        flags = {f.name: f.decode(word) for f in chip_register(chip, "STATUS").fields}
        axes[axis] = {**counters, "flags": flags}
    return axes


def run_linked(job: Job, options: RunOptions, url: str,
               watchdog_s: float | None = None) -> RunResult:
    """Run ``job``'s firmware over the link at ``url`` and report, with the board's watchdog
    armed to ``watchdog_s`` seconds (None: not armed); raises :class:`LinkError` if the link
    cannot be opened or the chipset there is not the job's (a link lost during the run is the
    report's status)."""
    check_program(job)
    check_linked_options(options)
    watchdog = 0 if watchdog_s is None else round(watchdog_s * job.machine.clock_hz)
    if watchdog_s is not None and not 0 < watchdog < 1 << WATCHDOG_BITS:
        raise OptionError(f"--watchdog {watchdog_s:g}: give 1 to {(1 << WATCHDOG_BITS) - 1} "
                          f"cycles of {job.machine.clock_hz:g} Hz, in seconds")
    link = open_link(url)
    try:
        link.check(job_identity(job))
        return _run(job, options, link, url, watchdog)
    finally:
        link.close()


def _lost_axes(job: Job) -> dict[str, dict]:
    return {axis: {"command": None, "error": None, "actual": None, "max_abs_error": None,
                   "flags": {}} for axis in job.machine.axis_names}


def _board_stop(status: dict[str, int]) -> str | None:
    """What the board's latched STATUS bits say stopped the machine, in words; None: nothing."""
    why = [text for name, text in (("watchdog", "its watchdog tripped"),
                                   ("estop", "E-stop"), ("limit_x", "the X limit"),
                                   ("limit_y", "the Y limit"), ("limit_z", "the Z limit"))
           if status.get(name)]
    return f"the board stopped the machine: {', '.join(why)}" if why else None


def _after_run(link: BridgeLink, job: Job, board_start: int, watchdog: int,
               lost: str | None) -> tuple[dict, Probe | None, dict[str, dict], str | None]:
    """What the host reads after the run (unless the link was ``lost``): the board's counts
    and STATUS (its watchdog turned off if armed), the PROBE and each axis; with the link
    lost, or lost here, null."""
    seen: dict = {"board_cycle": None, "board_cycles": None, "board": None}
    probe, axes = None, _lost_axes(job)
    if lost is None:
        try:
            board_end = link.board_cycle()
            seen["board_cycles"] = (board_end - board_start) % (1 << COUNTER_BITS)
            probe = link.probe()
            axes = _axes(link, job, probe)
            seen["board"] = link.board_status()
            if watchdog:
                link.disarm_watchdog()
            seen["board_cycle"] = link.board_cycle()
        except LinkError as e:
            lost = str(e)
    return seen, probe, axes, lost


def _run(job: Job, options: RunOptions, link: BridgeLink, url: str,
         watchdog: int) -> RunResult:
    host = Host8085(link, clock_hz=job.machine.clock_hz)
    meter = _ProbeMeter(link, job.machine.axis_names)
    firmware = Firmware(host, job, budget_offset=options.budget_offset, observer=meter)
    limit, limit_name = cycle_limit(job, options)
    start = time.perf_counter()
    if watchdog:
        link.arm_watchdog(watchdog, dac_zero(job.machine.dac_bits))
    board_start = link.board_cycle()
    if watchdog:
        link.watch_stops(link.max_count)
    lost: str | None = None
    stopped: BoardStopError | None = None
    try:
        firmware.run(limit)
    except LinkError as e:
        lost = str(e)
    except BoardStopError as e:
        stopped = e
    link.watch_stops(0)
    wall = time.perf_counter() - start
    cycles = link.cycle
    seen, probe, axes, lost = _after_run(link, job, board_start, watchdog, lost)
    if watchdog:
        seen["stop_seen"] = None if stopped is None else {"cycle": stopped.cycle,
                                                          "board_cycle": stopped.board_cycle}
    stop = None if seen["board"] is None else _board_stop(seen["board"])
    if stopped is not None:
        stop = (f"{_board_stop(stopped.status)} (seen at board cycle "
                f"{stopped.board_cycle:,}, the host's cycle {stopped.cycle:,})")
    if lost is not None:
        status, reason = "link-lost", f"the link was lost after cycle {cycles:,}: {lost}"
    elif stop is not None:
        status, reason = "fault", stop
    else:
        status, reason = run_status(firmware, None, limit_name, cycles)
    report = report_document(
        job, firmware, status=status, reason=reason, backend="link", cycles=cycles, wall=wall,
        skipped=0, blocks=[meter.report(b) for b in firmware.blocks], axes=axes,
        path={"max_contour_error": None, "rms_contour_error": None, "samples": 0})
    report["link"] = {"url": url, "probes": probe is not None, **seen,
                      "watchdog_cycles": watchdog,
                      "board_blocks": [meter.board_cycles.get(b.index)
                                       for b in firmware.blocks]}
    validate(report)
    store = SampleStore(job.machine.dac_bits, job.machine.axis_names)
    return RunResult(report, store, job)

