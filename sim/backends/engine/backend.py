"""The engine behind the backend contract: :class:`EngineBackend` drives the engine's library
(:mod:`.build`) through ctypes, with the ports of :class:`k37.sim.machine.system.System`.

It runs every option of the simulated machine and every block. Of the internal signals it
probes only :data:`PROBES`, and it writes no waveform: those are the RTL backends'.
With ``skip_idle`` it advances the cycles in which only its free-running state and its plants
change in closed form (``skipped_cycles``); the host's polling wait and the sampler's samples
run in the library.
"""

from __future__ import annotations

import ctypes
import weakref
from array import array
from collections.abc import Sequence

import numpy as np

from k37.hdl.chipset.map import AccelShape
from k37.sim.backends.contract import (
    CLOCK_PERIOD,
    Backend,
    ClosedLibrary,
    Design,
    Port,
    check_count,
    check_window,
    instantiate,
)
from k37.sim.backends.engine.build import build
from k37.sim.machine.system import DRIVES, System

__all__ = ["PROBES", "EngineBackend", "load", "machine_params"]


#: The internal signals the engine can probe (where its machine has them), by the RTL's names:
#: one-bit flags that the reproduction's runs read.
PROBES = ("chipset.accel.idle", "chipset.k3701.busy", "chipset.k3701.overrun")
#: The accel/decel shapes by the engine's code (``Circuit::Shape``).
_SHAPES = ("exponential", "linear", "bell")


def load(path: str) -> ctypes.CDLL:
    """The engine's library at ``path``, its functions typed."""
    lib = ctypes.CDLL(path)
    handle, u64, c_int = ctypes.c_void_p, ctypes.c_uint64, ctypes.c_int
    words = ctypes.POINTER(u64)
    signatures = {
        "k37e_create": (handle, [c_int, c_int, ctypes.POINTER(c_int),
                                 ctypes.POINTER(ctypes.c_uint), ctypes.c_uint]),
        "k37e_destroy": (None, [handle]),
        "k37e_drive": (None, [handle, c_int, c_int]),
        "k37e_port": (c_int, [ctypes.c_char_p]),
        "k37e_get": (u64, [handle, c_int]),
        "k37e_set": (None, [handle, c_int, u64]),
        "k37e_get_many": (None, [handle, ctypes.POINTER(c_int), ctypes.c_size_t,
                                 ctypes.POINTER(u64)]),
        "k37e_cycle": (u64, [handle]),
        "k37e_probe": (c_int, [handle, ctypes.c_char_p, words]),
        "k37e_skipped": (u64, [handle]),
        "k37e_step": (None, [handle, u64, c_int]),
        "k37e_run_until": (u64, [handle, c_int, u64, c_int]),
        "k37e_wait_polling": (c_int, [handle, c_int, u64, u64, u64, words, words,
                                      ctypes.c_size_t, words, u64, c_int, c_int, words, words]),
        "k37e_record": (None, [handle, ctypes.POINTER(c_int), ctypes.c_size_t, u64]),
        "k37e_recorded": (ctypes.c_size_t, [handle, ctypes.c_void_p, ctypes.c_size_t]),
        "k37e_bus_write": (None, [handle, u64, u64]),
        "k37e_bus_read": (u64, [handle, u64]),
        "k37e_plant_ns": (ctypes.c_double, [u64]),
        "k37e_clocks_before_pulse": (u64, [u64, u64, ctypes.c_uint]),
        "k37e_cycles_within": (u64, [u64, u64, c_int, ctypes.c_uint, u64]),
        "k37e_strobes_seen": (u64, [u64, u64, c_int, ctypes.c_uint, u64]),
        "k37e_lag_clear": (u64, [ctypes.c_int64, ctypes.c_int64, ctypes.c_int64, u64, c_int]),
        "k37e_lag_run": (None, [ctypes.POINTER(ctypes.c_int64), ctypes.c_int64,
                                ctypes.c_int64, words, c_int, u64]),
    }
    for name, (restype, argtypes) in signatures.items():
        function = getattr(lib, name)
        function.restype = restype
        function.argtypes = argtypes
    return lib


def machine_params(system: System) -> dict:
    """The options ``system`` was built with, as :func:`k37.sim.run.runner.system_params`
    names them."""
    chip = system.chipset
    names = {cls: name for name, cls in DRIVES.items()}
    return {"accel": chip.accel, "accel_bits": chip.accel_bits, "axes": len(system.axes),
            "accel_shape": chip.accel_shape, "axis_fa": chip.axis_fa,
            "axis_accel": chip.axis_accel if chip.accel.value == "post" else {},
            "drives": {axis: names[cls] for axis, cls in system.drives.items()}}


class EngineBackend(Backend):
    """:class:`k37.sim.backends.contract.Backend` on the engine, for a
    :class:`k37.sim.machine.system.System` (or a function that makes one)."""

    name = "engine"

    def __init__(self, design: Design, *, period: float = CLOCK_PERIOD,
                 compiler: str | None = None):
        from k37.sim.backends.introspect import component_ports, mark_elaborated

        system = instantiate(design)
        if not isinstance(system, System):
            raise TypeError(f"the engine runs the simulated machine (System), not "
                            f"{type(system).__name__}")
        mark_elaborated(system)
        params = machine_params(system)
        ports = {name: port for name, (port, _) in component_ports(system).items()}
        super().__init__(ports, type(system).__name__)
        self._period = period
        self.model = build(compiler)
        self._lib = lib = load(str(self.model.path))
        # The axes, the placement (0 none, 1 pre, 2 post) and the circuits' shapes and widths
        # (before the K3701, then each axis's after it), as k37e_create takes them.
        placement = ("none", "pre", "post").index(params["accel"].value)
        circuits = [(params["accel_shape"], params["accel_bits"]),
                    *(params["axis_accel"].get(axis, (params["accel_shape"], params["accel_bits"]))
                      for axis in ("x", "y", "z"))]
        shapes = [_SHAPES.index(AccelShape(shape).value) for shape, _ in circuits]
        fa_axes = sum(1 << "xyz".index(axis) for axis in params["axis_fa"])
        self._machine = (params["axes"], placement, (ctypes.c_int * 4)(*shapes),
                         (ctypes.c_uint * 4)(*(bits for _, bits in circuits)), fa_axes)
        #: Each axis's drive, by the engine's code (``DriveKind``: the order of DRIVES).
        self._drives = [list(DRIVES).index(params["drives"][axis]) for axis in system.axes]
        self._index = {name: lib.k37e_port(name.encode()) for name in ports}
        missing = [name for name, i in self._index.items() if i < 0]
        if missing:
            raise RuntimeError(f"the engine has no port {', '.join(missing)}")
        self._batches: dict[tuple[str, ...], tuple[list[Port], ctypes.Array, ctypes.Array]] = {}
        #: The addresses and stop masks of the polling routines' reads, by ports and masks.
        self._routine_ports: dict[tuple[tuple[int, ...], tuple[int, ...]],
                                  tuple[ctypes.Array, ctypes.Array]] = {}
        #: The ports k37e_record samples, and per column of its rows (the cycle, each port)
        #: a signed port's sign bit (0 for an unsigned column).
        self._recording: tuple[list[Port], np.ndarray] | None = None
        self._create()

    def _create(self) -> None:
        self._handle = self._lib.k37e_create(*self._machine)
        for axis, kind in enumerate(self._drives):
            self._lib.k37e_drive(self._handle, axis, kind)
        self._destroy = weakref.finalize(self, self._lib.k37e_destroy, self._handle)
        for name, port in self.ports.items():
            if port.is_input and port.init:
                self.set(name, port.init)

    def reset(self) -> None:
        self._destroy()
        self._recording = None
        self._create()

    def _set_raw(self, port: Port, raw: int) -> None:
        self._lib.k37e_set(self._handle, self._index[port.name], raw)

    def _get_raw(self, port: Port) -> int:
        return self._lib.k37e_get(self._handle, self._index[port.name])

    def get_many(self, port_names: tuple[str, ...]) -> list[int]:
        if port_names not in self._batches:
            ports = [self.port(name) for name in port_names]
            indices = (ctypes.c_int * len(ports))(*(self._index[p.name] for p in ports))
            self._batches[port_names] = (ports, indices, (ctypes.c_uint64 * len(ports))())
        ports, indices, out = self._batches[port_names]
        self._lib.k37e_get_many(self._handle, indices, len(ports), out)
        return [port.decode(raw) for port, raw in zip(ports, out, strict=True)]

    def _probe_raw(self, path: str) -> tuple[int, int, bool]:
        value = ctypes.c_uint64()
        if self._lib.k37e_probe(self._handle, path.encode(), ctypes.byref(value)) < 0:
            raise KeyError(path)
        return value.value, 1, False

    def probe_names(self) -> list[str]:
        value = ctypes.c_uint64()
        return [path for path in PROBES
                if self._lib.k37e_probe(self._handle, path.encode(), ctypes.byref(value)) == 0]

    def step(self, n: int = 1, *, skip_idle: bool = False) -> None:
        check_count("n", n)
        self._lib.k37e_step(self._handle, n, skip_idle)

    def _output(self, port_name: str) -> int:
        return self._index[self.port(port_name).name]

    def run_until(self, port_name: str, max_cycles: int, *, skip_idle: bool = False) -> int:
        check_count("max_cycles", max_cycles)
        return self._lib.k37e_run_until(self._handle, self._output(port_name), max_cycles,
                                        skip_idle)

    def wait_polling(self, port_name: str, max_cycles: int, pause: int, period: int,
                     ports: Sequence[int], stops: Sequence[int], idles: Sequence[int], *,
                     due: bool = False, skip_idle: bool = False,
                     bus: str = "bus") -> tuple[int, list[int] | None, int] | None:
        if bus != "bus":
            return None
        for name, value in (("max_cycles", max_cycles), ("pause", pause), ("period", period)):
            check_count(name, value)
        n = len(ports)
        if not n or len(stops) != n or len(idles) % (n + 1) or period < 1:
            raise ValueError("wait_polling: one stop mask per port, n + 1 idles per routine")
        u64 = ctypes.c_uint64
        key = (tuple(ports), tuple(stops))
        if key not in self._routine_ports:
            addr = self.port("bus__addr")
            self._routine_ports[key] = ((u64 * n)(*(addr.encode(a) for a in ports)),
                                        (u64 * n)(*stops))
        done, read = u64(), (u64 * n)()
        end = self._lib.k37e_wait_polling(
            self._handle, self._output(port_name), max_cycles, pause, period,
            *self._routine_ports[key], n, (u64 * len(idles)).from_buffer(array("Q", idles)),
            len(idles) // (n + 1), due, skip_idle, ctypes.byref(done), read)
        # The ends of the compiled RTL backend's wait (WaitEnd): 1 stopped, 2 and 3 go on.
        return done.value, list(read) if end == 1 else None, {2: 1, 3: 2}.get(end, 0)

    def record(self, port_names: tuple[str, ...], every: int) -> bool:
        if not isinstance(every, int) or every < 1:
            raise ValueError(f"every must be a positive number of cycles, not {every!r}")
        ports = [self.port(name) for name in port_names]
        if any(port.width > 63 for port in ports):
            return False
        indices = [self._index[port.name] for port in ports]
        self._lib.k37e_record(self._handle, (ctypes.c_int * len(ports))(*indices), len(ports),
                              every)
        self._recording = (ports, np.array(
            [0, *(1 << (port.width - 1) if port.signed else 0 for port in ports)], dtype=np.int64))
        return True

    def recorded(self) -> np.ndarray:
        if self._recording is None:
            return super().recorded()
        ports, sign = self._recording
        rows = np.empty(self._lib.k37e_recorded(self._handle, None, 0), dtype=np.int64)
        self._lib.k37e_recorded(self._handle, rows.ctypes.data, len(rows))
        rows = rows.reshape(-1, 1 + len(ports))
        rows ^= sign  # a signed port's two's complement: its sign bit's weight negative
        rows -= sign
        return rows

    @property
    def skipped_cycles(self) -> int:  # type: ignore[override]
        return self._lib.k37e_skipped(self._handle)

    def bus_write(self, addr: int, data: int, *, bus: str = "bus") -> None:
        if bus != "bus":
            super().bus_write(addr, data, bus=bus)
            return
        self._lib.k37e_bus_write(self._handle, self.port("bus__addr").encode(addr),
                                 self.port("bus__w_data").encode(data))

    def bus_read(self, addr: int, *, bus: str = "bus") -> int:
        if bus != "bus":
            return super().bus_read(addr, bus=bus)
        return self._lib.k37e_bus_read(self._handle, self.port("bus__addr").encode(addr))

    @property
    def cycle(self) -> int:
        return self._lib.k37e_cycle(self._handle)

    def trace(self, path: str, start_cycle: int = 0, stop_cycle: int | None = None,
              signals: tuple[str, ...] = ()) -> None:
        check_window(start_cycle, stop_cycle)
        raise ValueError("the engine writes no waveform: use --backend cxxrtl for --vcd")

    def stop_trace(self) -> None:
        pass

    def close(self) -> None:
        self._destroy()
        self._lib = ClosedLibrary(type(self).__name__)

    def plant_ns(self, cycles: int = 10**8) -> float:
        """Nanoseconds per cycle of one first-order plant stepped alone in the engine's C++
        (the cost of stepping a plant per axis and cycle)."""
        return self._lib.k37e_plant_ns(cycles)
