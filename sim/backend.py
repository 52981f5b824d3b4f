"""One cycle-stepping interface over the simulators of a ``wiring.Component``.

A :class:`Backend` drives a design's top-level ports by name, steps the system clock, waits for
a port (an interrupt) with a cycle limit, runs host-bus cycles, reads internal signals by
hierarchical name, and writes VCD windows. Its semantics are those of an Amaranth async
testbench: inputs :meth:`~Backend.set` before :meth:`~Backend.step` are sampled at the rising
edge (and by falling-edge logic before it); after ``step`` the design is settled on its
post-edge values, as after ``await ctx.tick()`` followed by ``ctx.get()``. Values set between
steps are visible to :meth:`~Backend.get` at once (combinational paths settle). Only the sync
domain's clock is driven (``rst`` stays low); it starts low, so the first cycle has no falling
edge, as with ``Simulator.add_clock``.

:class:`PysimBackend` runs Amaranth's own simulator and is the reference; the compiled
:class:`sim.cxxrtl.CxxrtlBackend` matches it bit for bit. :func:`make_backend` picks one.

Names
-----
Ports are the flattened signature paths joined with ``__``, as Amaranth names them in
Verilog (``bus__addr``). Probes are hierarchical signal names below the top module, with
submodule names separated by dots (``regs.value_value``): Amaranth's VCD scopes without the
leading ``bench.top``.
"""

from __future__ import annotations

import abc
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np
from amaranth.hdl import Shape, Value, ValueCastable
from amaranth.lib import wiring
from amaranth.sim import Simulator

from sim.testbench import CLOCK_PERIOD

__all__ = ["Backend", "CarryAccumulator", "Countdown", "FreeRunning", "PhaseAccumulator", "Port",
           "PysimBackend", "StrobeCounter", "component_ports", "make_backend"]


@dataclass(frozen=True)
class PhaseAccumulator:
    """A :class:`hdl.divider.PhaseDivider` at probe path ``path`` (``phase``, ``increment``,
    ``stb`` below it): it adds ``increment`` to ``phase`` at every edge, for ever."""

    path: str
    width: int


@dataclass(frozen=True)
class StrobeCounter:
    """A :class:`hdl.rate_multiplier.RateMultiplier` at ``path`` (``count``, ``select``,
    ``word``): it counts the cycles in which accumulator number ``clock``'s ``stb`` is high, and
    pulses in those that select a set bit of ``word``. While the probe ``gate`` reads 1 its
    pulses matter, so a skip must stop before the next one (None: they never matter)."""

    path: str
    width: int
    clock: int
    gate: str | None = None


@dataclass(frozen=True)
class CarryAccumulator:
    """An :class:`hdl.accel_decel.AccelDecel` at ``path`` (``y``, ``x``): at each cycle in
    which accumulator number ``clock``'s ``stb`` is high, ``y += x`` in ``n`` bits; a carry out
    of them changes ``x`` and sends a pulse, so a skip must stop before the next carry."""

    path: str
    n: int
    signed: bool
    clock: int


@dataclass(frozen=True)
class Countdown:
    """A register at probe path ``path`` that, while it is not 0, goes down by one each
    cycle; reaching ``stop`` is an event, so a skip must stop before it (e.g. the K3701's step
    latency count, whose step comes out at 1)."""

    path: str
    stop: int


@dataclass(frozen=True)
class FreeRunning:
    """State of a design that runs on by itself, for exact idle skipping.

    A component may declare it as its ``free_running`` attribute. When the probe ``quiet``
    reads 1, this state must affect nothing else in the design until a carry accumulator's
    next carry, a strobe counter's next pulse through its open gate, a plant's next count or a
    countdown's stop;
    a backend that skips idle cycles then proves a fixed point of the rest from one cycle and
    advances this state, up to that event (:meth:`Backend.step` with ``skip_idle``).
    """

    accumulators: tuple[PhaseAccumulator, ...]
    counters: tuple[StrobeCounter, ...]
    carries: tuple[CarryAccumulator, ...]
    #: Paths of :class:`sim.plant.ServoPlant` instances: while the rest stands still, they
    #: are stepped natively (bit for bit as their gateware) up to a change of their count.
    plants: tuple[str, ...]
    quiet: str
    countdowns: tuple[Countdown, ...] = ()

    def registers(self) -> tuple[str, ...]:
        """Probe paths of the registers that make up this state (all else is "the rest")."""
        return (*(f"{a.path}.{name}" for a in self.accumulators for name in ("phase", "stb")),
                *(f"{c.path}.{name}" for c in self.counters for name in ("count", "select")),
                *(f"{c.path}.y" for c in self.carries),
                *(c.path for c in self.countdowns),
                *(f"{p}.{name}" for p in self.plants for name in ("velocity", "before")))


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


def component_ports(component: wiring.Component) -> dict[str, tuple[Port, Value]]:
    """The component's signature ports by Verilog name, with the values behind them."""
    if not isinstance(getattr(component, "signature", None), wiring.Signature):
        raise TypeError(f"component must be a wiring.Component, not {component!r}")
    ports: dict[str, tuple[Port, Value]] = {}
    for path, member, value in component.signature.flatten(component):
        if isinstance(value, ValueCastable):
            value = value.as_value()
        if not isinstance(value, Value):
            continue
        name = "__".join(map(str, path))
        shape = Shape.cast(value.shape())
        init = getattr(value, "init", 0) & ((1 << shape.width) - 1)
        ports[name] = (Port(name, shape.width, shape.signed, member.flow == wiring.In, init),
                       value)
    return ports


class Backend(abc.ABC):
    """A cycle-stepped simulation of one component; see the module docstring for semantics.

    Subclasses implement the raw accessors and the stepping; this class checks names and
    values, so every backend refuses the same mistakes with the same messages.
    """

    def __init__(self, component: wiring.Component):
        self.component = component
        self.ports: dict[str, Port] = {name: port
                                       for name, (port, _) in component_ports(component).items()}

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
        component's :class:`FreeRunning` state changes while it is quiet, which is then
        advanced in closed form); the state is exactly that of stepping.
        """

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
    def trace(self, path: str, start_cycle: int = 0, stop_cycle: int | None = None) -> None:
        """Write a VCD of cycles ``start_cycle`` to ``stop_cycle`` (exclusive; None: to close).

        Scopes, names and timestamps are those of Amaranth's VCD writer with
        ``add_clock(period)``; the window may start in the future (or now, if already past).
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

    #: Cycles counted without evaluation by ``skip_idle`` so far.
    skipped_cycles = 0

    def port(self, name: str) -> Port:
        """The port called ``name``."""
        try:
            return self.ports[name]
        except KeyError:
            raise KeyError(f"{type(self.component).__name__} has no port {name!r}; "
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
        """The samples :meth:`record` took: a row per sample, the cycle and the ports."""
        raise NotImplementedError(f"{type(self).__name__} does not record samples")

    def probe(self, path: str) -> int:
        """The value of the internal signal ``path`` (e.g. ``"regs.value_value"``)."""
        try:
            raw, width, signed = self._probe_raw(path)
        except KeyError:
            leaf = path.rsplit(".", 1)[-1]
            close = [n for n in self.probe_names() if n.rsplit(".", 1)[-1] == leaf]
            hint = f"; did you mean {', '.join(close)}?" if close else ""
            raise KeyError(f"no signal {path!r} in {type(self.component).__name__}{hint}") \
                from None
        return sign_extend(raw, width) if signed else raw

    def bus_write(self, addr: int, data: int, *, bus: str = "bus") -> None:
        """One host write cycle on the :class:`hdl.hostbus.HostBus` named ``bus``."""
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


def signal_paths(design: Any) -> dict[str, Value]:
    """Every named signal of a prepared Amaranth design, by dotted path below the top."""
    paths: dict[str, Value] = {}
    for info in design.fragments.values():
        scope = info.name[1:]
        for signal, name in info.signal_names.items():
            paths.setdefault(".".join((*scope, name)), signal)
    return paths


class PysimBackend(Backend):
    """:class:`Backend` on Amaranth's simulator: one long-lived simulation, stepped on demand.

    A background testbench executes the step commands (``ctx.tick().repeat(n)``) and then
    parks a quarter period after the rising edge, before the clock process is due again. The
    driver calls :meth:`Simulator.advance` until it parks, and sets and gets values through
    the testbench's context while it is parked, so an input set between steps is settled
    before the falling edge, exactly as in a testbench that sets right after
    ``await ctx.tick()``. (Setting from outside in a time step where the clock process is
    runnable would commit the input in the same delta cycle as the clock edge.)

    Two private parts of Amaranth 0.5 are used: the simulator's prepared design (for the
    probes' names, the ones its VCD writer uses) and its engine's VCD writer, which, unlike
    ``Simulator.write_vcd``, may start after time 0 (FSM states and enums, written as text,
    then show their init value until they first change). ``skip_idle`` is accepted and
    ignored: every cycle is simulated.
    """

    name = "pysim"

    def __init__(self, component: wiring.Component, *, period: float = CLOCK_PERIOD):
        super().__init__(component)
        self._values = {name: value for name, (_, value) in component_ports(component).items()}
        self._period = period
        self._sim = Simulator(component)
        self._sim.add_clock(period)
        self._sim.add_testbench(self._bench, background=True)
        # The simulator's prepared design names every signal as its VCD writer does.
        self._paths = signal_paths(self._sim._design)
        self._ctx: Any = None
        self._command: Callable[[Any], Any] | None = None
        self._parked = False
        self._cycle = 0
        self._window: tuple[str, int, int | None] | None = None
        self._vcd: Any = None
        self._run_parked()

    async def _bench(self, ctx: Any) -> None:
        self._ctx = ctx
        while True:
            self._parked = True
            await ctx.delay(self._period / 4)
            self._parked = False
            if self._command is not None:
                command, self._command = self._command, None
                await command(ctx)

    def _run_parked(self) -> None:
        self._parked = False
        while not self._parked:
            self._sim.advance()

    def _set_raw(self, port: Port, raw: int) -> None:
        self._ctx.set(self._values[port.name], port.decode(raw))

    def _get_raw(self, port: Port) -> int:
        return self._ctx.get(self._values[port.name]) & ((1 << port.width) - 1)

    def _probe_raw(self, path: str) -> tuple[int, int, bool]:
        signal = self._paths[path]
        shape = Shape.cast(signal.shape())
        return self._ctx.get(signal) & ((1 << shape.width) - 1), shape.width, shape.signed

    def probe_names(self) -> list[str]:
        return sorted(self._paths)

    def _until_edge(self, n: int) -> int:
        """How many of ``n`` cycles to run before the trace window's next edge."""
        self._update_trace()
        if self._window is not None:
            _, start, stop = self._window
            edge = start if self._cycle < start else stop
            if edge is not None:
                return min(n, edge - self._cycle)
        return n

    def _ticks(self, k: int, value: Value | None = None) -> bool:
        """Run ``k`` cycles, or fewer if ``value`` reads non-zero after one; True if it did."""
        found = False

        async def command(ctx: Any) -> None:
            nonlocal found
            if value is None:
                await ctx.tick().repeat(k)
                self._cycle += k
                return
            for _ in range(k):
                await ctx.tick()
                self._cycle += 1
                if ctx.get(value):
                    found = True
                    return

        self._command = command
        self._run_parked()
        return found

    def _update_trace(self) -> None:
        if self._window is None:
            return
        path, start, stop = self._window
        if self._vcd is None and self._cycle >= start:
            # Amaranth's writer only starts at time 0 through the public API; its engine
            # records the current values as the initial ones, which is right at any time.
            self._vcd = self._sim._engine.write_vcd(vcd_file=path, gtkw_file=None, traces=(),
                                                     fs_per_delta=0)
            self._vcd.__enter__()
        if stop is not None and self._cycle >= stop:
            self.stop_trace()

    def step(self, n: int = 1, *, skip_idle: bool = False) -> None:
        check_count("n", n)
        while n:
            k = self._until_edge(n)
            self._ticks(k)
            n -= k
        self._update_trace()

    def run_until(self, port_name: str, max_cycles: int, *, skip_idle: bool = False) -> int:
        check_count("max_cycles", max_cycles)
        value = self._values[self.port(port_name).name]
        start = self._cycle
        while self._cycle - start < max_cycles:
            if self._ticks(self._until_edge(max_cycles - self._cycle + start), value):
                break
        self._update_trace()
        return self._cycle - start

    @property
    def cycle(self) -> int:
        return self._cycle

    def reset(self) -> None:
        self.stop_trace()
        self._sim.reset()
        self._cycle = 0
        self._run_parked()

    def trace(self, path: str, start_cycle: int = 0, stop_cycle: int | None = None) -> None:
        check_window(start_cycle, stop_cycle)
        self.stop_trace()
        self._window = (path, start_cycle, stop_cycle)
        self._update_trace()

    def stop_trace(self) -> None:
        self._window = None
        if self._vcd is not None:
            vcd, self._vcd = self._vcd, None
            vcd.__exit__(None, None, None)

    def close(self) -> None:
        self.stop_trace()


def make_backend(component: wiring.Component, kind: str = "auto", *,
                 period: float = CLOCK_PERIOD) -> Backend:
    """A backend for ``component``: ``"pysim"``, ``"cxxrtl"``, or ``"auto"``.

    ``auto`` picks the compiled backend when a C++ compiler is available, and otherwise says
    so in one line on stderr and falls back to Amaranth's simulator.
    """
    from sim import cxxrtl

    if kind not in ("auto", "pysim", "cxxrtl"):
        raise ValueError(f"backend kind must be 'auto', 'pysim' or 'cxxrtl', not {kind!r}")
    if kind == "auto" and cxxrtl.find_compiler() is None:
        print("k37: no C++ compiler (g++) on PATH; using Amaranth's simulator (about 500x "
              "slower)", file=sys.stderr)
        kind = "pysim"
    if kind == "pysim":
        return PysimBackend(component, period=period)
    return cxxrtl.CxxrtlBackend(component, period=period)
