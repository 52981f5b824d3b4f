"""K37 as a library: load a job, run it, read the report and the traces, poke registers.

One entry point over the command line's machinery (nothing here is a second runner)::

    from k37.sim import api

    job = api.load("examples/square.toml")          # or api.load(gcode="G01 X1 F600")
    result = api.run(job, max_cycles=2_000_000)      # RunOptions' fields as keywords
    result.report["path"]["max_contour_error"]       # the JSON report, as a dict
    result.traces["x_error"]                         # a numpy array per trace column

    with api.Machine(job) as m:                      # the job's machine, the host bus by name
        m.write("K3702_X", "ERROR", 1000)            # load the X error counter
        m.step(50_000)
        m.read("K3702_X", "ERROR"), m.get("x__count")

:func:`load` is :func:`k37.sim.run.jobfile.load_job` (plus G-code text); :func:`run` is
:func:`k37.sim.run.runner.run_job`; :class:`Machine` is a backend built and configured as a run
builds it, driven through :class:`k37.firmware_model.host.Host8085` (8085 bus timing) with the
register maps of :data:`k37.hdl.chipset.map.CHIP_SELECTS`.
"""

from __future__ import annotations

from os import PathLike
from typing import Any

from k37.firmware_model.host import Host8085
from k37.firmware_model.job import Job, gcode_job
from k37.hdl.chipset.map import CHIP_SELECTS
from k37.sim.backends.contract import Backend
from k37.sim.backends.factory import BACKEND_NAMES
from k37.sim.link.simulated import SimulatedLink
from k37.sim.run.jobfile import load_job
from k37.sim.run.runner import RunOptions, RunResult, build_backend, configure_plants, run_job

__all__ = ["Machine", "load", "run"]


def load(path: str | PathLike[str] | None = None, *, gcode: str | None = None,
         name: str = "api") -> Job:
    """The job in ``path`` (TOML, or G-code on the default machine), or the G-code text
    ``gcode`` on the default machine (named ``name``); neither: the built-in demo.

    Raises :class:`k37.sim.run.jobfile.JobError` or
    :class:`k37.firmware_model.gcode.parser.GcodeError`. """
    if gcode is not None:
        if path is not None:
            raise ValueError("load: give a path or gcode, not both")
        return gcode_job(name, gcode, f"<{name}>")
    return load_job(path)


def _job(job: Job | str | PathLike[str] | None) -> Job:
    """``job`` itself, or the job :func:`load` reads from the path (None: the demo)."""
    return job if isinstance(job, Job) else load(job)


def run(job: Job | str | PathLike[str] | None = None, **options: Any) -> RunResult:
    """Run ``job`` (a :class:`Job`, a path, or None: the demo) with ``options``, the fields of
    :class:`k37.sim.run.runner.RunOptions` (``max_cycles``, ``sample_every``, ``backend``,
    ``faults``, ...). The result's ``report`` is the JSON report, ``traces`` its samples."""
    return run_job(_job(job), RunOptions(**options))


class Machine:
    """The simulated machine of ``job`` (default: the demo's), plants configured, on
    ``backend``: read and write registers by chip and name over the host bus, step, read
    ports and probes. Close it (or use it in a ``with``) to free the simulation."""

    def __init__(self, job: Job | str | PathLike[str] | None = None, *,
                 backend: str = BACKEND_NAMES[0]):
        self.job = _job(job)
        #: The :class:`k37.sim.backends.contract.Backend`: ports, probes, stepping (``auto``:
        #: the compiled RTL, which has the probes).
        self.backend: Backend = build_backend(self.job, backend, internals=True)
        configure_plants(self.backend, self.job)
        self.host = Host8085(SimulatedLink(self.backend), clock_hz=self.job.machine.clock_hz)

    @staticmethod
    def chips() -> dict[str, list[str]]:
        """Every chip on the host bus and its registers' names."""
        return {chip: [reg.name for reg in regmap] for chip, (_, regmap) in CHIP_SELECTS.items()}

    def write(self, chip: str, register: str, value: int) -> None:
        """Write ``register`` of ``chip`` (e.g. ``"K3702_X", "ALARM_ZONE"``) as the 8085 does:
        byte by byte, least significant first. KeyError names an unknown chip or register."""
        self.host.write(chip, register, value)

    def read(self, chip: str, register: str) -> int:
        """Read ``register`` of ``chip`` as the 8085 does (signed where the register is)."""
        return self.host.read(chip, register)

    def status(self, chip: str) -> dict[str, int]:
        """The fields of ``chip``'s STATUS register."""
        return self.host.status(chip)

    def step(self, cycles: int = 1) -> None:
        """Let ``cycles`` system clock cycles pass."""
        self.backend.step(cycles)

    def get(self, name: str) -> int:
        """The value of port ``name`` (e.g. ``"x__count"``, ``"x__dac"``; see
        ``backend.ports``)."""
        return self.backend.get(name)

    def probe(self, path: str) -> int:
        """The value of internal signal ``path`` (see ``backend.probe_names()``)."""
        return self.backend.probe(path)

    @property
    def cycle(self) -> int:
        """Cycles since the start."""
        return self.backend.cycle

    def run(self, **options: Any) -> RunResult:
        """Run the job's program on this machine from cycle 0 (reset first if it has run),
        with :class:`k37.sim.run.runner.RunOptions` fields as keywords; the machine stays open to
        be looked at afterwards."""
        if self.backend.cycle:
            self.backend.reset()
        return run_job(self.job, RunOptions(**options), backend=self.backend)

    def close(self) -> None:
        """Free the simulation."""
        self.backend.close()

    def __enter__(self) -> Machine:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
