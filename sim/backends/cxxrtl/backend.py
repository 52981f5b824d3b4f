"""The compiled simulation backend: a CXXRTL model (:mod:`.build`) driven through ctypes.

:class:`CxxrtlBackend` implements :class:`k37.sim.backends.contract.Backend` bit for bit like
:class:`k37.sim.backends.pysim.PysimBackend`. Hot paths (stepping, waiting for a port, host-bus
cycles) are one C call each.
"""

from __future__ import annotations

import base64
import ctypes
import dataclasses
import enum
import os
import pickle
import re
import time
import weakref
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from k37.hdl.common.observation import FreeRunning
from k37.sim.backends.contract import (
    CLOCK_PERIOD,
    Backend,
    ClosedLibrary,
    Design,
    Port,
    check_count,
    check_window,
    instantiate,
    select_signals,
)
from k37.sim.backends.cxxrtl.build import build, find_design, remember_design
from k37.sim.backends.toolchain import Model

if TYPE_CHECKING:
    from amaranth.lib import wiring

__all__ = ["CxxrtlBackend"]


class WaitEnd(enum.IntEnum):
    """Why the harness's polling wait returned (``enum class WaitEnd``, wait.h)."""

    #: An interrupt is pending after a wait, or ``max_cycles`` ran out.
    OVER = 0
    #: A routine read a byte with a bit of its port's stop mask set (its bytes are returned).
    STOPPED = 1
    #: ``pause`` cycles passed, or the routines ran out: the same wait goes on.
    PAUSED = 2
    #: The same, at a tick whose routine is due (the wait goes on with ``due``).
    PAUSED_DUE = 3


#: What :meth:`k37.sim.backends.contract.Backend.wait_polling` says of a wait that ended so: 1 it
#: goes on, 2 it goes on with the routine of the tick reached due; 0 (any other end) it is over.
_GOES_ON = {WaitEnd.PAUSED: 1, WaitEnd.PAUSED_DUE: 2}


class _WaitPolling(ctypes.Structure):
    """The polling wait's arguments (``struct WaitPolling``, wait.h, field for field)."""

    _fields_ = (
        ("irq", ctypes.c_size_t),
        ("bus", ctypes.POINTER(ctypes.c_size_t)),
        ("limit", ctypes.c_uint64),
        ("pause", ctypes.c_uint64),
        ("period", ctypes.c_uint64),
        ("ports", ctypes.POINTER(ctypes.c_uint64)),
        ("stops", ctypes.POINTER(ctypes.c_uint64)),
        ("n", ctypes.c_size_t),
        ("idles", ctypes.POINTER(ctypes.c_uint64)),
        ("routines", ctypes.c_uint64),
        ("due", ctypes.c_int),
        ("skip_idle", ctypes.c_int),
    )


def _load(path: Path) -> ctypes.CDLL:
    lib = ctypes.CDLL(str(path))
    handle, size, u64 = ctypes.c_void_p, ctypes.c_size_t, ctypes.c_uint64
    words = ctypes.POINTER(ctypes.c_uint32)
    signatures = {
        "k37_create": (handle, []),
        "k37_destroy": (None, [handle]),
        "k37_count": (size, [handle]),
        "k37_name": (ctypes.c_char_p, [handle, size]),
        "k37_width": (size, [handle, size]),
        "k37_read": (None, [handle, size, words]),
        "k37_write": (None, [handle, size, words]),
        "k37_get": (u64, [handle, size]),
        "k37_set": (None, [handle, size, u64]),
        "k37_get_many": (None, [handle, ctypes.POINTER(size), size, ctypes.POINTER(u64)]),
        "k37_record": (None, [handle, ctypes.POINTER(size), size, u64]),
        "k37_recorded": (size, [handle, ctypes.POINTER(u64), size]),
        "k37_step": (None, [handle, u64, ctypes.c_int]),
        "k37_run_until": (u64, [handle, size, u64, ctypes.c_int]),
        "k37_bus_write": (None, [handle, size, size, size, u64, u64]),
        "k37_bus_read": (u64, [handle, size, size, size, u64]),
        "k37_wait_polling": (ctypes.c_int, [handle, ctypes.POINTER(_WaitPolling),
                                            ctypes.POINTER(u64), ctypes.POINTER(u64)]),
        "k37_cycle": (u64, [handle]),
        "k37_skipped": (u64, [handle]),
        "k37_trace": (ctypes.c_int, [handle, ctypes.c_char_p, ctypes.c_char_p, ctypes.c_char_p,
                                      u64, u64, u64]),
        "k37_trace_close": (None, [handle]),
        "k37_falling_edge": (ctypes.c_int, [handle]),
        "k37_free_accumulator": (ctypes.c_int, [handle, size, size, size, ctypes.c_uint]),
        "k37_free_counter": (ctypes.c_int, [handle, size, size, ctypes.c_uint, size, size,
                                            size]),
        "k37_free_carry": (ctypes.c_int, [handle, size, size, ctypes.c_uint, ctypes.c_int,
                                          size]),
        "k37_free_plant": (ctypes.c_int, [handle, ctypes.POINTER(size), ctypes.c_uint,
                                          ctypes.c_uint, ctypes.c_uint]),
        "k37_free_countdown": (ctypes.c_int, [handle, size, u64]),
        "k37_free_quiet": (None, [handle, size]),
        "k37_check_eval_skip": (ctypes.c_int, [handle, ctypes.POINTER(size), size]),
    }
    for name, (restype, argtypes) in signatures.items():
        function = getattr(lib, name)
        function.restype = restype
        function.argtypes = argtypes
    return lib


class CxxrtlBackend(Backend):
    """:class:`k37.sim.backends.contract.Backend` on a compiled CXXRTL model of ``component``.

    Construction converts and builds the design (or loads it from the cache; ``model`` tells
    which). ``step(n, skip_idle=True)`` and ``run_until(..., skip_idle=True)`` stop evaluating once
    a whole clock cycle changed no state but the component's declared
    :class:`k37.hdl.common.observation.FreeRunning` state, while its ``quiet`` probe reads 1: with
    the inputs held, the rest is at a fixed point, so the cycles up to the next event of the
    free-running state are only counted (``skipped_cycles``) and that state is advanced in closed
    form; the result is bit-identical to stepping. The commits tell after every cycle whether the
    rest changed (:func:`design_main`), so a skip starts at the first quiet cycle. An undeclared
    free-running counter keeps skipping from firing; a declaration with no ``quiet`` (a part of some
    parent's state, such as the FEED chip's) declares nothing to skip on.

    Probes are CXXRTL debug items; their names follow the Amaranth hierarchy, so they are the
    same as :class:`k37.sim.backends.pysim.PysimBackend`'s wherever Yosys kept the signal.
    """

    name = "cxxrtl"

    #: Scope prefix of waveforms, as in Amaranth's VCD writer.
    VCD_SCOPE: ClassVar[str] = "bench top "

    def __init__(self, design: Design, *, period: float = CLOCK_PERIOD,
                 compiler: str | None = None, design_key: str | None = None):
        self._period = period
        known = find_design(design_key, compiler=compiler) if design_key else None
        if known is None:
            component = instantiate(design)
            self.model, facts = self._convert_and_build(component, compiler)
            if design_key:
                remember_design(design_key, self.model, facts, compiler=compiler)
        else:
            self.model, facts = known
            if hasattr(design, "signature"):  # a component made by the caller
                from k37.sim.backends.introspect import mark_elaborated

                mark_elaborated(design)
        super().__init__({p["name"]: Port(**p) for p in facts["ports"]}, facts["name"])
        self._free: FreeRunning | None = (pickle.loads(base64.b64decode(facts["free_running"]))
                                          if facts["free_running"] else None)
        self._signed = set(facts["signed"])
        self._lib = lib = _load(self.model.path)
        self._own(lib.k37_create())
        self._items = {lib.k37_name(self._handle, i).decode(): i
                       for i in range(lib.k37_count(self._handle))}
        # CXXRTL separates the hierarchy with spaces; names may hold dots (struct fields).
        self._probes = {name.replace(" ", "."): i for name, i in self._items.items()}
        self._names = {name.replace(" ", "."): name for name in self._items}
        self._index = {name: self._items[name] for name in self.ports}
        self._k37_get, self._k37_set = lib.k37_get, lib.k37_set
        self._buses: dict[str, tuple[Port, Port, int, int, int, int, int]] = {}
        self._batches: dict[tuple[str, ...], tuple[list[Port], ctypes.Array, ctypes.Array]] = {}
        self._recording: list[Port] | None = None  # the ports k37_record samples
        self._set_inits()

    @staticmethod
    def _convert_and_build(component: wiring.Component,
                           compiler: str | None) -> tuple[Model, dict[str, Any]]:
        """Convert the design to RTLIL (as ``amaranth.back.rtlil.convert`` does), check that
        it has a clock to step, and build its model; with the facts the backend needs of the
        design itself, so that a design found by its key is never elaborated: its name, ports,
        signed signals and free-running state (pickled: plain data of
        :mod:`k37.hdl.common.observation`)."""
        from amaranth.back import rtlil
        from amaranth.hdl import Fragment, Shape
        from amaranth.hdl._ir import PortDirection

        from k37.sim.backends.introspect import component_ports, signal_paths

        free: FreeRunning | None = getattr(component, "free_running", None)
        if free is not None and free.quiet is None:
            free = None  # a part of a parent's state, with no quiet of its own: nothing to skip
        ports = component_ports(component)
        start = time.perf_counter()
        design = Fragment.get(component, None).prepare(
            ports={name: (value, PortDirection.Input if port.is_input else PortDirection.Output)
                   for name, (port, value) in ports.items()}, hierarchy=("top",))
        rtlil_text, _ = rtlil.convert_fragment(design, name="top", emit_src=False)
        rtlil_seconds = time.perf_counter() - start
        inputs = _top_inputs(rtlil_text)
        # Other domains' clocks stay low, as in Amaranth's simulator with one add_clock().
        if "clk" not in inputs:
            raise ValueError(f"{type(component).__name__} has no sync clock domain to step")
        model = build(rtlil_text, free=free.registers() if free is not None else (),
                      reads=free.reads() if free is not None else (),
                      compiler=compiler)
        model.seconds["rtlil"] = rtlil_seconds
        signed = sorted(path for path, signal in signal_paths(design).items()
                        if Shape.cast(signal.shape()).signed)
        return model, {
            "name": type(component).__name__,
            "ports": [dataclasses.asdict(port) for port, _ in ports.values()],
            "signed": signed,
            "free_running": base64.b64encode(pickle.dumps(free)).decode() if free else None}

    def _own(self, handle: int) -> None:
        """Hold the model instance ``handle``: it is destroyed by :meth:`close`, or when this
        backend is collected, or at the interpreter's exit (before the library is unloaded)."""
        self._handle = handle
        self._destroy = weakref.finalize(self, self._lib.k37_destroy, handle)

    def reset(self) -> None:
        self._destroy()
        self._own(self._lib.k37_create())
        self._recording = None
        self._set_inits()

    def _declare_free_running(self, free: FreeRunning) -> None:
        def item(path: str) -> int:
            try:
                return self._probes[path]
            except KeyError:
                raise KeyError(f"free-running state {path!r} is not in the compiled model") \
                    from None

        lib, handle = self._lib, self._handle
        clocks = {acc.path: k for k, acc in enumerate(free.accumulators)}

        def clock(owner: str, path: str | None) -> int:
            if path not in clocks:
                raise ValueError(f"{owner}: its clock {path!r} is not a declared accumulator")
            return clocks[path]

        for acc in free.accumulators:
            if lib.k37_free_accumulator(handle, item(f"{acc.path}.phase"),
                                        item(f"{acc.path}.increment"), item(f"{acc.path}.stb"),
                                        acc.width) < 0:
                raise ValueError(f"{acc.path}: phase and stb must be registers of <= 64 bits")
        for counter in free.counters:
            gate = ctypes.c_size_t(-1).value if counter.gate is None else item(counter.gate)
            if lib.k37_free_counter(handle, item(f"{counter.path}.count"),
                                    item(f"{counter.path}.select"), counter.width,
                                    clock(counter.path, counter.clock),
                                    item(f"{counter.path}.word"), gate) < 0:
                raise ValueError(f"{counter.path}: count and select must be registers of "
                                 f"<= 64 bits, clocked by a declared accumulator")
        for carry in free.carries:
            if lib.k37_free_carry(handle, item(f"{carry.path}.y"), item(f"{carry.path}.x"),
                                  carry.n, carry.signed, clock(carry.path, carry.clock)) < 0:
                raise ValueError(f"{carry.path}: y must be an n-bit register, x at most 63 bits, "
                                 f"clocked by a declared accumulator")
        for plant in free.plants:
            items = _sizes([item(f"{plant.path}.{n}") for n in plant.ITEMS])
            if lib.k37_free_plant(handle, items, plant.vc_bits, plant.alpha_bits,
                                  plant.frac_bits) < 0:
                raise ValueError(f"{plant.path}: velocity, position, phase and ff must be "
                                 f"registers")
        for countdown in free.countdowns:
            if lib.k37_free_countdown(handle, item(countdown.path), countdown.stop) < 0:
                raise ValueError(f"{countdown.path}: must be a register of <= 64 bits")
        lib.k37_free_quiet(handle, item(str(free.quiet)))

    def _set_inits(self) -> None:
        if self._free is not None:
            self._declare_free_running(self._free)
        # CXXRTL starts inputs at zero; Amaranth at their init values.
        for port in self.ports.values():
            if port.is_input and port.init:
                self._set_raw(port, port.init)

    # set, get and the bus cycles are what a firmware model calls most: kept to one C call.

    def set(self, port_name: str, value: int) -> None:
        port = self.ports.get(port_name)
        if port is None or not port.is_input or port.width > 64:
            super().set(port_name, value)
        else:
            self._k37_set(self._handle, self._index[port_name], port.encode(value))

    def get(self, port_name: str) -> int:
        port = self.ports.get(port_name)
        if port is None or port.width > 64:
            return super().get(port_name)
        return port.decode(self._k37_get(self._handle, self._index[port_name]))

    def get_many(self, port_names: tuple[str, ...]) -> list[int]:
        if port_names not in self._batches:
            ports = [self.port(name) for name in port_names]
            if any(port.width > 64 for port in ports):
                return super().get_many(port_names)
            self._batches[port_names] = (ports, self._items_of(ports),
                                         (ctypes.c_uint64 * len(ports))())
        ports, indices, out = self._batches[port_names]
        self._lib.k37_get_many(self._handle, indices, len(ports), out)
        return [port.decode(raw) for port, raw in zip(ports, out, strict=True)]

    def record(self, port_names: tuple[str, ...], every: int) -> bool:
        if not isinstance(every, int) or every < 1:
            raise ValueError(f"every must be a positive number of cycles, not {every!r}")
        ports = [self.port(name) for name in port_names]
        if any(port.width > 63 for port in ports):
            return False
        self._lib.k37_record(self._handle, self._items_of(ports), len(ports), every)
        self._recording = ports
        return True

    def recorded(self) -> np.ndarray:
        if self._recording is None:
            return super().recorded()
        ports = self._recording
        words = self._lib.k37_recorded(self._handle, None, 0)  # held, none taken
        raw = np.zeros(words, dtype=np.uint64)
        self._lib.k37_recorded(self._handle, raw.ctypes.data_as(ctypes.POINTER(ctypes.c_uint64)),
                               words)  # taken
        rows = raw.astype(np.int64).reshape(-1, 1 + len(ports))
        for column, port in enumerate(ports, start=1):
            if port.signed:  # sign-extend
                rows[:, column] -= (rows[:, column] >> (port.width - 1) & 1) << port.width
        return rows

    def _items_of(self, ports: list[Port]) -> ctypes.Array:
        """The ports' item indices, as a C array."""
        return _sizes([self._index[port.name] for port in ports])

    def _bus(self, bus: str) -> tuple[Port, Port, int, int, int, int, int]:
        if bus not in self._buses:
            names = [f"{bus}__{member}" for member in
                     ("addr", "w_data", "w_stb", "r_stb", "r_data")]
            addr, w_data = self.port(names[0]), self.port(names[1])
            self._buses[bus] = (addr, w_data, *(self._index[self.port(n).name] for n in names))
        return self._buses[bus]

    def bus_write(self, addr: int, data: int, *, bus: str = "bus") -> None:
        addr_port, data_port, i_addr, i_data, i_stb, _, _ = self._bus(bus)
        self._lib.k37_bus_write(self._handle, i_addr, i_data, i_stb, addr_port.encode(addr),
                                data_port.encode(data))

    def bus_read(self, addr: int, *, bus: str = "bus") -> int:
        addr_port, _, i_addr, _, _, i_stb, i_data = self._bus(bus)
        return self._lib.k37_bus_read(self._handle, i_addr, i_stb, i_data,
                                      addr_port.encode(addr))

    def wait_polling(self, port_name: str, max_cycles: int, pause: int, period: int,
                     ports: Sequence[int], stops: Sequence[int], idles: Sequence[int], *,
                     due: bool = False, skip_idle: bool = False,
                     bus: str = "bus") -> tuple[int, list[int] | None, int] | None:
        for name, value in (("max_cycles", max_cycles), ("pause", pause), ("period", period)):
            check_count(name, value)
        n = len(ports)
        if not n or len(stops) != n or len(idles) % (n + 1) or period < 1:
            raise ValueError("wait_polling: one stop mask per port, n + 1 idles per routine")
        addr_port, _, i_addr, _, _, i_stb, i_data = self._bus(bus)
        u64 = ctypes.c_uint64
        wait = _WaitPolling(
            irq=self._index[self.port(port_name).name], bus=_sizes([i_addr, i_stb, i_data]),
            limit=max_cycles, pause=pause, period=period,
            ports=(u64 * n)(*(addr_port.encode(a) for a in ports)), stops=(u64 * n)(*stops),
            n=n, idles=(u64 * len(idles))(*idles), routines=len(idles) // (n + 1), due=due,
            skip_idle=skip_idle)
        done, read = u64(), (u64 * n)()
        end = WaitEnd(self._lib.k37_wait_polling(self._handle, ctypes.byref(wait),
                                                 ctypes.byref(done), read))
        return done.value, list(read) if end is WaitEnd.STOPPED else None, _GOES_ON.get(end, 0)

    def _set_raw(self, port: Port, raw: int) -> None:
        index = self._items[port.name]
        if port.width <= 64:
            self._lib.k37_set(self._handle, index, raw)
        else:
            self._lib.k37_write(self._handle, index, _words(raw, port.width))

    def _get_raw(self, port: Port) -> int:
        return self._read(self._items[port.name], port.width)

    def _read(self, index: int, width: int) -> int:
        buffer = _words(0, width)
        self._lib.k37_read(self._handle, index, buffer)
        return int.from_bytes(bytes(buffer), "little")

    def _probe_raw(self, path: str) -> tuple[int, int, bool]:
        index = self._probes[path]
        width = self._lib.k37_width(self._handle, index)
        return self._read(index, width), width, path in self._signed  # struct fields: unsigned

    def probe_names(self) -> list[str]:
        return sorted(self._probes)

    def check_eval_skip(self, paths: Sequence[str]) -> bool | None:
        """A self-check of the model's evaluation for skip decisions (for tests): whether,
        from the current state, it computes the signals ``paths`` (of at most 64 bits) as a
        settle does; None if the model has none. Leaves the design settled."""
        result = self._lib.k37_check_eval_skip(self._handle,
                                               _sizes([self._probes[p] for p in paths]),
                                               len(paths))
        return None if result < 0 else bool(result)

    def step(self, n: int = 1, *, skip_idle: bool = False) -> None:
        check_count("n", n)
        self._lib.k37_step(self._handle, n, skip_idle)

    def run_until(self, port_name: str, max_cycles: int, *, skip_idle: bool = False) -> int:
        check_count("max_cycles", max_cycles)
        index = self._index[self.port(port_name).name]
        return self._lib.k37_run_until(self._handle, index, max_cycles, skip_idle)

    @property
    def cycle(self) -> int:
        return self._lib.k37_cycle(self._handle)

    @property
    def needs_falling_edge(self) -> bool:
        """Whether the falling edge of the clock is evaluated (else it costs only a commit)."""
        return bool(self._lib.k37_falling_edge(self._handle))

    @property
    def skipped_cycles(self) -> int:  # type: ignore[override]
        return self._lib.k37_skipped(self._handle)

    def trace(self, path: str, start_cycle: int = 0, stop_cycle: int | None = None,
              signals: Sequence[str] = ()) -> None:
        """Write a VCD of cycles ``[start_cycle, stop_cycle)`` (a window may lie in the future).

        Scopes and names follow Amaranth's VCD writer (``bench.top.<submodule>``), timestamps
        its ``add_clock`` edges; tracing runs at about 1e6 cycles/s, untraced cycles at full
        speed.
        """
        check_window(start_cycle, stop_cycle)
        # The selected items by their CXXRTL names, one a line (None: every item).
        keep = None if not signals else "\n".join(
            self.VCD_SCOPE + self._names[path]
            for path in sorted(select_signals(self._probes, signals))).encode()
        stop = (1 << 64) - 1 if stop_cycle is None else stop_cycle
        quarter_fs = round(self._period * 1e15 / 4)
        if self._lib.k37_trace(self._handle, os.fsencode(path), self.VCD_SCOPE.encode(), keep,
                               start_cycle, stop, quarter_fs):
            raise OSError(f"cannot write waveform file {path}")

    def stop_trace(self) -> None:
        self._lib.k37_trace_close(self._handle)

    def close(self) -> None:
        if self._handle:
            self._destroy()
            self._handle = None
            # Any later call fails in Python rather than in C.
            self._lib = self._k37_get = self._k37_set = ClosedLibrary(type(self).__name__)


def _top_inputs(rtlil_text: str) -> set[str]:
    """Names of the top module's inputs in RTLIL text."""
    top = re.search(r"^attribute \\top 1\nmodule \\top\n(.*?)^end$", rtlil_text, re.M | re.S)
    assert top is not None, "Amaranth names the top module 'top'"
    return set(re.findall(r"^ *wire width \d+ input \d+ .*?\\(\S+)$", top.group(1), re.M))


def _sizes(values: list[int]) -> ctypes.Array:
    """``values`` as a C array of size_t."""
    return (ctypes.c_size_t * len(values))(*values)


def _words(raw: int, width: int) -> ctypes.Array:
    count = (width + 31) // 32
    return (ctypes.c_uint32 * count).from_buffer_copy(raw.to_bytes(4 * count, "little"))
