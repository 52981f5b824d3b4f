"""The lockstep checker: the engine and a reference backend (the compiled RTL) run one job side
by side, and the first cycle at which any output port differs stops the run, naming the port.

:class:`LockstepBackend` is a :class:`k37.sim.backends.contract.Backend` over two backends of
one machine: every call goes to both, and after it every output port (and the cycle count) is
compared. Calls that run many cycles (``step(n)``, ``run_until``) compare at their end; when
they differ there, both backends are reset and the calls so far replayed, and the differing
call is run again cycle by cycle, so :class:`DivergenceError` names the first differing cycle
exactly. The backend records no samples and runs no polling wait itself (the caller's loop of
its calls does), so every cycle the firmware runs is checked.

``k37 run --backend lockstep`` and :func:`k37.sim.run.runner.run_job` with
``RunOptions(backend="lockstep")`` run a job so.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from k37.sim.backends.contract import Backend, Port

__all__ = ["DivergenceError", "LockstepBackend"]


#: A call of the backend contract: its method's name, arguments and keyword arguments.
Call = tuple[str, tuple, dict]


@dataclass
class DivergenceError(AssertionError):
    """The two backends differ: after the cycle that brought them to ``cycle`` cycles,
    ``port`` reads ``values`` (the checked backend's, the reference's), in ``call``.
    ``replayed``: the calls that bring two fresh backends to the cycle before, equal."""

    cycle: int
    port: str
    values: tuple[int, int]
    call: str
    names: tuple[str, str]
    replayed: list[Call]

    def __str__(self) -> str:
        return (f"cycle {self.cycle:,}: {self.port} is {self.values[0]} on {self.names[0]}, "
                f"{self.values[1]} on {self.names[1]} (after {self.call})")


class LockstepBackend(Backend):
    """``checked`` (the engine) and ``reference`` (the compiled RTL) in lockstep."""

    name = "lockstep"

    def __init__(self, checked: Backend, reference: Backend):
        if checked.ports.keys() != reference.ports.keys():
            raise ValueError("the two backends must simulate one design (their ports differ)")
        super().__init__(reference.ports, reference.design_name)
        self.checked, self.reference = checked, reference
        self._outputs = tuple(name for name, port in self.ports.items() if not port.is_input)
        #: The calls since the start (or the last reset), to replay (method, args, kwargs).
        self._log: list[Call] = []

    # -- every call to both, compared -----------------------------------------------------

    def _both(self, method: str, *args: Any, **kwargs: Any) -> Any:
        self._log.append((method, args, kwargs))
        mine = getattr(self.checked, method)(*args, **kwargs)
        theirs = getattr(self.reference, method)(*args, **kwargs)
        difference = self._difference()
        if difference is None and mine != theirs:
            difference = ("the call's result", (mine, theirs))
        if difference is not None:
            self._locate(difference)
        return theirs

    def _difference(self) -> tuple[str, tuple[int, int]] | None:
        """The first output port that differs (or the cycle count), with both values."""
        if self.checked.cycle != self.reference.cycle:
            return "the cycle count", (self.checked.cycle, self.reference.cycle)
        mine = self.checked.get_many(self._outputs)
        theirs = self.reference.get_many(self._outputs)
        for name, a, b in zip(self._outputs, mine, theirs, strict=True):
            if a != b:
                return name, (a, b)
        return None

    def _raise(self, difference: tuple[str, tuple[int, int]], call: str,
               replayed: list[Call]) -> None:
        port, values = difference
        raise DivergenceError(self.reference.cycle, port, values, call,
                         (self.checked.name, self.reference.name), replayed)

    def _locate(self, difference: tuple[str, tuple[int, int]]) -> None:
        """Replay to the last call and run it cycle by cycle; raise at the first difference."""
        method, args, _ = self._log[-1]
        call = f"{method}{args!r}"
        log = self._log[:-1]
        if method not in ("step", "run_until"):
            self._raise(difference, call, log)
        for backend in (self.checked, self.reference):
            backend.reset()
        for name, a, k in log:
            for backend in (self.checked, self.reference):
                getattr(backend, name)(*a, **k)
        port_name = args[0] if method == "run_until" else None
        cycles = args[1] if method == "run_until" else (args[0] if args else 1)
        for stepped in range(cycles):
            for backend in (self.checked, self.reference):
                backend.step(1)
            found = self._difference()
            if found is not None:
                self._raise(found, call, [*log, *[("step", (1,), {})] * stepped])
            if port_name is not None and self.reference.get(port_name):
                break
        self._raise(difference, call, log)  # not seen cycle by cycle: reported where seen

    def set(self, port_name: str, value: int) -> None:
        self._log.append(("set", (port_name, value), {}))
        self.checked.set(port_name, value)
        self.reference.set(port_name, value)

    def get(self, port_name: str) -> int:
        return self.reference.get(port_name)

    def get_many(self, port_names: tuple[str, ...]) -> list[int]:
        return self.reference.get_many(port_names)

    def step(self, n: int = 1, *, skip_idle: bool = False) -> None:
        self._both("step", n, skip_idle=skip_idle)

    def run_until(self, port_name: str, max_cycles: int, *, skip_idle: bool = False) -> int:
        return self._both("run_until", port_name, max_cycles, skip_idle=skip_idle)

    def bus_write(self, addr: int, data: int, *, bus: str = "bus") -> None:
        self._both("bus_write", addr, data, bus=bus)

    def bus_read(self, addr: int, *, bus: str = "bus") -> int:
        return self._both("bus_read", addr, bus=bus)

    # -- the rest of the contract ---------------------------------------------------------

    def _set_raw(self, port: Port, raw: int) -> None:
        raise AssertionError("set() is overridden")

    def _get_raw(self, port: Port) -> int:
        raise AssertionError("get() is overridden")

    def _probe_raw(self, path: str) -> tuple[int, int, bool]:
        return self.reference._probe_raw(path)

    def probe_names(self) -> list[str]:
        return self.reference.probe_names()

    @property
    def cycle(self) -> int:
        return self.reference.cycle

    @property
    def skipped_cycles(self) -> int:  # type: ignore[override]
        return self.reference.skipped_cycles

    def reset(self) -> None:
        self._log.clear()
        for backend in (self.checked, self.reference):
            backend.reset()

    def trace(self, path: str, start_cycle: int = 0, stop_cycle: int | None = None,
              signals: tuple[str, ...] = ()) -> None:
        self.reference.trace(path, start_cycle, stop_cycle, signals)

    def stop_trace(self) -> None:
        self.reference.stop_trace()

    def close(self) -> None:
        for backend in (self.checked, self.reference):
            backend.close()
