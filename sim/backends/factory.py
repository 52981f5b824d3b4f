"""The one place that knows the backends by name: ``--backend``'s choices, which one ``auto``
picks for a machine (and why), and their classes."""

from __future__ import annotations

import sys
from collections.abc import Mapping
from typing import Any

from k37.sim.backends.contract import CLOCK_PERIOD, Backend, Design, instantiate
from k37.sim.backends.toolchain import find_compiler

__all__ = ["BACKENDS", "BACKEND_NAMES", "choose_backend", "make_backend"]

#: The backends, by the ``name`` each reports: Amaranth's simulator, the compiled RTL, the
#: event-level engine, and the engine checked against the compiled RTL cycle by cycle
#: (:mod:`k37.sim.backends.engine.lockstep`).
BACKENDS = ("pysim", "cxxrtl", "engine", "lockstep")
#: What ``--backend`` and ``RunOptions.backend`` accept; the first, ``auto``
#: (:func:`choose_backend`), is the default.
BACKEND_NAMES = ("auto", *BACKENDS)


def choose_backend(kind: str, params: Mapping[str, Any] | None = None, *,
                   internals: bool = False) -> tuple[str, str]:
    """The backend ``kind`` runs a machine built with ``params`` (the keyword arguments of
    :class:`k37.sim.machine.system.System`; None: not that machine) on, and why, in words.

    ``auto`` picks the engine for the simulated machine (it runs every option of it and every
    block) where the caller reads no internal signals (``internals``: a waveform, probes),
    which only the RTL has; else the compiled RTL backend; and Amaranth's simulator when there
    is no C++ compiler.
    """
    if kind not in BACKEND_NAMES:
        raise ValueError(f"backend kind must be one of {', '.join(BACKEND_NAMES)}, "
                         f"not {kind!r}")
    if kind != "auto":
        return kind, f"--backend {kind}"
    if find_compiler() is None:
        return "pysim", "auto: no C++ compiler (g++) on PATH"
    if internals:
        return "cxxrtl", "auto: internal signals (a waveform, probes) need the RTL"
    if params is None:
        return "cxxrtl", "auto: the engine runs only the simulated machine (System)"
    return "engine", "auto: the engine runs this machine and program"


def make_backend(design: Design, kind: str = BACKEND_NAMES[0], *,
                 period: float = CLOCK_PERIOD, design_key: str | None = None,
                 params: Mapping[str, Any] | None = None,
                 internals: bool = False) -> Backend:
    """A backend of kind ``kind`` (one of :data:`BACKEND_NAMES`, ``auto`` as
    :func:`choose_backend` picks with ``params`` and ``internals``) for ``design``: a
    component, or a function that makes one (called only if the design must be elaborated).
    The backend's ``reason`` says why it was picked.

    ``design_key``, if given, names the design by what it is made from (its sources and
    parameters): the compiled backend then finds a model built before without elaborating
    the design (:func:`k37.sim.backends.cxxrtl.build.remember_design`).
    """
    chosen, reason = choose_backend(kind, params, internals=internals)
    if chosen == "pysim" and kind == "auto":
        print("k37: no C++ compiler (g++) on PATH; using Amaranth's simulator (about 500x "
              "slower)", file=sys.stderr)
    backend = _make(design, chosen, period, design_key)
    backend.reason = reason
    return backend


def _make(design: Design, kind: str, period: float, design_key: str | None) -> Backend:
    if kind == "pysim":
        from k37.sim.backends.pysim import PysimBackend

        return PysimBackend(instantiate(design), period=period)
    if kind in ("engine", "lockstep"):
        from k37.sim.backends.engine.backend import EngineBackend

        engine = EngineBackend(design, period=period)
        if kind == "engine":
            return engine
        from k37.sim.backends.engine.lockstep import LockstepBackend

        return LockstepBackend(engine, _make(design, "cxxrtl", period, design_key))
    from k37.sim.backends.cxxrtl.backend import CxxrtlBackend

    return CxxrtlBackend(design, period=period, design_key=design_key)
