"""The reference backend: Amaranth's own simulator behind the backend contract."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from types import SimpleNamespace
from typing import Any

from amaranth.hdl import Shape, Value
from amaranth.hdl._ast import SignalDict
from amaranth.lib import wiring
from amaranth.sim import Simulator

from k37.sim.backends.contract import (
    CLOCK_PERIOD,
    Backend,
    Port,
    check_count,
    check_window,
    select_signals,
)
from k37.sim.backends.introspect import component_ports, signal_paths

__all__ = ["PysimBackend"]


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
    then show their init value until they first change), and, given a view of the design
    naming only the selected signals, writes only those. ``skip_idle`` is accepted and
    ignored: every cycle is simulated.
    """

    name = "pysim"

    def __init__(self, component: wiring.Component, *, period: float = CLOCK_PERIOD):
        ports = component_ports(component)
        super().__init__({name: port for name, (port, _) in ports.items()},
                         type(component).__name__)
        self.component = component
        self._values = {name: value for name, (_, value) in ports.items()}
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
        self._window: tuple[str, int, int | None, set[str] | None] | None = None
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
            _, start, stop, _ = self._window
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
        path, start, stop, selected = self._window
        if self._vcd is None and self._cycle >= start:
            # Amaranth's writer only starts at time 0 through the public API; its engine
            # records the current values as the initial ones, which is right at any time.
            self._vcd = self._sim._engine.write_vcd(vcd_file=path, gtkw_file=None, traces=(),
                                                     fs_per_delta=0)
            if selected is None:
                self._vcd.__enter__()
            else:  # the writer declares every signal of the design it is given
                engine, design = self._sim._engine, self._sim._engine._design
                engine._design = _selected_design(design, selected)
                try:
                    self._vcd.__enter__()
                finally:
                    engine._design = design
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

    def trace(self, path: str, start_cycle: int = 0, stop_cycle: int | None = None,
              signals: Sequence[str] = ()) -> None:
        check_window(start_cycle, stop_cycle)
        selected = select_signals(self._paths, signals) if signals else None
        self.stop_trace()
        self._window = (path, start_cycle, stop_cycle, selected)
        self._update_trace()

    def stop_trace(self) -> None:
        self._window = None
        if self._vcd is not None:
            vcd, self._vcd = self._vcd, None
            vcd.__exit__(None, None, None)

    def close(self) -> None:
        self.stop_trace()


def _selected_design(design: Any, selected: set[str]) -> SimpleNamespace:
    """A view of a prepared design naming only the ``selected`` signal paths (what the VCD
    writer reads: each fragment's hierarchical name and signal names)."""
    fragments = {}
    for fragment, info in design.fragments.items():
        scope = ".".join(info.name[1:])
        names = SignalDict((signal, name) for signal, name in info.signal_names.items()
                           if (f"{scope}.{name}" if scope else name) in selected)
        fragments[fragment] = SimpleNamespace(name=info.name, signal_names=names)
    return SimpleNamespace(fragments=fragments)
