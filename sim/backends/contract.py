"""The backend contract: one cycle-stepping interface over the simulators of a component.

A :class:`Backend` drives a design's top-level ports by name, steps the system clock, waits for
a port (an interrupt) with a cycle limit, runs host-bus cycles, reads internal signals by
hierarchical name, and writes VCD windows. Its semantics are those of an Amaranth async
testbench: inputs :meth:`~Backend.set` before :meth:`~Backend.step` are sampled at the rising
edge (and by falling-edge logic before it); after ``step`` the design is settled on its
post-edge values, as after ``await ctx.tick()`` followed by ``ctx.get()``. Values set between
steps are visible to :meth:`~Backend.get` at once (combinational paths settle). Only the sync
domain's clock is driven (``rst`` stays low); it starts low, so the first cycle has no falling
edge, as with ``Simulator.add_clock``.

:class:`k37.sim.backends.pysim.PysimBackend` runs Amaranth's own simulator and is the reference;
the compiled :class:`k37.sim.backends.cxxrtl.backend.CxxrtlBackend` matches it bit for bit; the
event-level :class:`k37.sim.backends.engine.backend.EngineBackend` runs the simulated machine at
its ports (checked against the compiled one by :mod:`k37.sim.backends.engine.lockstep`);
:func:`k37.sim.backends.factory.make_backend` picks one.

Names
-----
Ports are the flattened signature paths joined with ``__``, as Amaranth names them in
Verilog (``bus__addr``). Probes are hierarchical signal names below the top module, with
submodule names separated by dots (``regs.value_value``): Amaranth's VCD scopes without the
leading ``bench.top``.
"""

from __future__ import annotations

import abc
import fnmatch
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import TYPE_CHECKING, TypeAlias

import numpy as np

from k37.hdl.common.constants import CHIP_HZ

if TYPE_CHECKING:
    from amaranth.lib import wiring

__all__ = ["CLOCK_PERIOD", "Backend", "ClosedLibrary", "Design", "Port", "instantiate",
           "select_signals", "sign_extend"]

#: The paper's system clock period, 1 us (1 MHz): the time base of waveforms.
CLOCK_PERIOD = 1 / CHIP_HZ

#: What a backend simulates: an Amaranth ``wiring.Component``, or a function that makes one
#: (a compiled backend that finds the design's model by its key never calls it, so a run of a
#: cached design need not import Amaranth).
Design: TypeAlias = "wiring.Component | Callable[[], wiring.Component]"


def instantiate(design: Design) -> wiring.Component:
    """The component of ``design`` (made now if ``design`` is a function that makes it)."""
    return design if hasattr(design, "signature") else design()


@dataclass(frozen=True)
class Port:
    """A top-level port of a component, as a backend sees it."""

    name: str
    width: int
    signed: bool
    is_input: bool
    #: Raw bits of the port's initial value (what an input holds until it is set).
    init: int = 0

    def encode(self, value: int) -> int:
        """The raw bits of ``value``; both signed and unsigned readings of the bits are taken."""
        if not isinstance(value, int):
            raise TypeError(f"port {self.name}: value must be an integer, not {value!r}")
        if not -(1 << (self.width - 1)) <= value < (1 << self.width):
            raise ValueError(f"port {self.name}: {value} does not fit in {self.width} bit(s)")
        return value & ((1 << self.width) - 1)

    def decode(self, raw: int) -> int:
        """The value of raw bits, sign-extended for a signed port."""
        return sign_extend(raw, self.width) if self.signed else raw


def sign_extend(raw: int, width: int) -> int:
    """Read ``width`` raw bits as two's complement."""
    return raw - (1 << width) if width and raw >> (width - 1) & 1 else raw


class Backend(abc.ABC):
    """A cycle-stepped simulation of one component; see the module docstring for semantics.

    Subclasses implement the raw accessors and the stepping; this class checks names and
    values, so every backend refuses the same mistakes with the same messages.
    """

    def __init__(self, ports: Mapping[str, Port], name: str):
        #: The top-level ports by name (:func:`k37.sim.backends.introspect.component_ports`).
        self.ports: dict[str, Port] = dict(ports)
        #: The design's class name, for messages.
        self.design_name = name

    # -- to implement ------------------------------------------------------------------------

    @abc.abstractmethod
    def _set_raw(self, port: Port, raw: int) -> None: ...

    @abc.abstractmethod
    def _get_raw(self, port: Port) -> int: ...

    @abc.abstractmethod
    def _probe_raw(self, path: str) -> tuple[int, int, bool]:
        """Raw bits, width and signedness of the signal at ``path`` (KeyError if none)."""

    @abc.abstractmethod
    def probe_names(self) -> list[str]:
        """Every signal :meth:`probe` can read, sorted."""

    @abc.abstractmethod
    def step(self, n: int = 1, *, skip_idle: bool = False) -> None:
        """Run ``n`` system-clock cycles.

        With ``skip_idle``, a backend may count cycles without evaluating them once the design
        is provably at a fixed point (nothing changes and the inputs are held, or only the
        component's declared :class:`k37.hdl.common.observation.FreeRunning` state changes while it
        is quiet, which is then advanced in closed form); the state is exactly that of stepping. """

    @abc.abstractmethod
    def run_until(self, port_name: str, max_cycles: int, *, skip_idle: bool = False) -> int:
        """Step until ``port_name`` reads non-zero after an edge, at most ``max_cycles`` cycles.

        At least one cycle is stepped (if ``max_cycles`` > 0), even if the port is already
        non-zero. Returns the cycles stepped (``max_cycles`` if the port stayed zero).
        """

    @property
    @abc.abstractmethod
    def cycle(self) -> int:
        """Cycles stepped since the start."""

    @abc.abstractmethod
    def reset(self) -> None:
        """Start again from cycle 0: initial values everywhere, inputs at their ``init``.

        Ends any waveform. Cheaper than a new backend (no conversion, no build).
        """

    @abc.abstractmethod
    def trace(self, path: str, start_cycle: int = 0, stop_cycle: int | None = None,
              signals: Sequence[str] = ()) -> None:
        """Write a VCD of cycles ``start_cycle`` to ``stop_cycle`` (exclusive; None: to close).

        Scopes, names and timestamps are those of Amaranth's VCD writer with
        ``add_clock(period)``; the window may start in the future (or now, if already past).
        ``signals``, if given, are globs over the dotted paths below the top (those of
        :meth:`probe_names`, see :func:`select_signals`): only the signals they match are
        written.
        """

    @abc.abstractmethod
    def stop_trace(self) -> None:
        """Finish the waveform being written, if any."""

    @abc.abstractmethod
    def close(self) -> None:
        """Release the simulation (and finish any waveform)."""

    # -- shared ------------------------------------------------------------------------------

    #: Short name of the backend, as ``--backend`` spells it.
    name = "backend"

    #: Why this backend runs the design, in words (set by
    #: :func:`k37.sim.backends.factory.make_backend`).
    reason = ""

    #: Cycles counted without evaluation by ``skip_idle`` so far.
    skipped_cycles = 0

    def port(self, name: str) -> Port:
        """The port called ``name``."""
        try:
            return self.ports[name]
        except KeyError:
            raise KeyError(f"{self.design_name} has no port {name!r}; "
                           f"ports are {', '.join(self.ports)}") from None

    def set(self, port_name: str, value: int) -> None:
        """Drive input ``port_name`` with ``value`` from now on."""
        port = self.port(port_name)
        if not port.is_input:
            raise ValueError(f"port {port_name} is an output; only inputs can be set")
        self._set_raw(port, port.encode(value))

    def get(self, port_name: str) -> int:
        """The settled value of ``port_name`` (sign-extended if the port is signed)."""
        port = self.port(port_name)
        return port.decode(self._get_raw(port))

    def get_many(self, port_names: tuple[str, ...]) -> list[int]:
        """:meth:`get` of several ports (a compiled backend reads them in one call)."""
        return [self.get(name) for name in port_names]

    def record(self, port_names: tuple[str, ...], every: int) -> bool:
        """Have the backend itself sample ``port_names`` (as :meth:`get_many` would) at every
        later multiple of ``every`` cycles, as its stepping reaches it (:meth:`recorded`).

        False if it cannot (then the caller samples between its calls): a compiled backend
        records without a call per sample, and a skip ends at a sample.
        """
        return False

    def recorded(self) -> np.ndarray:
        """The samples :meth:`record` took since the last call: a row per sample, the cycle and
        the ports. Each sample is returned once, so the caller may stream them away."""
        raise NotImplementedError(f"{type(self).__name__} does not record samples")

    def probe(self, path: str) -> int:
        """The value of the internal signal ``path`` (e.g. ``"regs.value_value"``)."""
        try:
            raw, width, signed = self._probe_raw(path)
        except KeyError:
            leaf = path.rsplit(".", 1)[-1]
            close = [n for n in self.probe_names() if n.rsplit(".", 1)[-1] == leaf]
            hint = f"; did you mean {', '.join(close)}?" if close else ""
            raise KeyError(f"no signal {path!r} in {self.design_name}{hint}") \
                from None
        return sign_extend(raw, width) if signed else raw

    def bus_write(self, addr: int, data: int, *, bus: str = "bus") -> None:
        """One host write cycle on the :class:`k37.hdl.bus.hostbus.HostBus` named ``bus``."""
        self.set(f"{bus}__addr", addr)
        self.set(f"{bus}__w_data", data)
        self.set(f"{bus}__w_stb", 1)
        self.step()
        self.set(f"{bus}__w_stb", 0)

    def bus_read(self, addr: int, *, bus: str = "bus") -> int:
        """One host read cycle; returns the byte the chip presents in the following cycle."""
        self.set(f"{bus}__addr", addr)
        self.set(f"{bus}__r_stb", 1)
        self.step()
        self.set(f"{bus}__r_stb", 0)
        return self.get(f"{bus}__r_data")

    def wait_polling(self, port_name: str, max_cycles: int, pause: int, period: int,
                     ports: Sequence[int], stops: Sequence[int], idles: Sequence[int], *,
                     due: bool = False, skip_idle: bool = False,
                     bus: str = "bus") -> tuple[int, list[int] | None, int] | None:
        """A host's halted wait for ``port_name`` with a timer routine that only reads, run by
        the backend itself (:meth:`k37.firmware_model.host.Host8085.wait_polling`, whose own loop
        of :meth:`run_until`, :meth:`step` and :meth:`bus_read` it equals): at most
        ``max_cycles``; at each tick (a multiple of ``period``) that a wait reached without the
        port high, and before ``max_cycles`` ran out, routine k idles ``idles[k (n + 1) + j]``
        cycles before reading ``ports[j]`` (n of them), then ``idles[k (n + 1) + n]`` after;
        with ``due``, the first routine runs at once.

        Returns the routines run to their end; the bytes of the routine after them if it read
        a byte with a bit of its port's ``stops`` mask set (its last idle cycles not run); and
        whether the wait goes on (call again with what is left): 0 no (an interrupt or the
        limit), 1 yes (``pause`` cycles passed, or the routines ran out), 2 yes, with the
        routine of the tick reached due (``due``). A routine under way is finished before a
        pause. None if this backend cannot (the caller runs the loop); the default.
        """
        return None

    @contextmanager
    def tracing(self, path: str, start_cycle: int = 0,
                stop_cycle: int | None = None) -> Iterator[None]:
        """Trace (see :meth:`trace`) for the duration of a ``with`` block."""
        self.trace(path, start_cycle, stop_cycle)
        try:
            yield
        finally:
            self.stop_trace()

    def __enter__(self) -> Backend:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class ClosedLibrary:
    """Stands in for the library of a closed compiled backend (``owner``, its class's name):
    any later call fails in Python rather than in C."""

    def __init__(self, owner: str):
        self.owner = owner

    def __getattr__(self, name: str) -> ClosedLibrary:
        return self

    def __call__(self, *args: object) -> None:
        raise RuntimeError(f"this {self.owner} is closed")


def check_count(name: str, n: int) -> None:
    """Refuse a cycle count that is not a non-negative integer."""
    if not isinstance(n, int) or n < 0:
        raise ValueError(f"{name} must be a non-negative integer, not {n!r}")


def check_window(start_cycle: int, stop_cycle: int | None) -> None:
    """Refuse a trace window that is not ``0 <= start_cycle < stop_cycle``."""
    check_count("start_cycle", start_cycle)
    if stop_cycle is not None and (not isinstance(stop_cycle, int) or stop_cycle <= start_cycle):
        raise ValueError(f"stop_cycle must be an integer after start_cycle ({start_cycle}), "
                         f"not {stop_cycle!r}")


def select_signals(paths: Iterable[str], globs: Sequence[str]) -> set[str]:
    """The ``paths`` (dotted, below the top) matched by any of ``globs`` (``fnmatch``, ``*``
    spanning dots); a glob that matches none is refused (ValueError)."""
    paths = list(paths)
    selected: set[str] = set()
    for glob in globs:
        matched = fnmatch.filter(paths, glob)
        if not matched:
            raise ValueError(f"--signals {glob}: matches no signal (signals are dotted paths "
                             f"below the top, e.g. chipset.k3701.* or x__*)")
        selected.update(matched)
    return selected
