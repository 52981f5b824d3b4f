"""The one place that knows the backends by name: ``--backend``'s choices and their classes."""

from __future__ import annotations

import sys

from k37.sim.backends.contract import CLOCK_PERIOD, Backend, Design, instantiate
from k37.sim.backends.toolchain import find_compiler

__all__ = ["BACKENDS", "BACKEND_NAMES", "make_backend"]

#: The backends, by the ``name`` each reports: Amaranth's simulator and the compiled one.
BACKENDS = ("pysim", "cxxrtl")
#: What ``--backend`` and ``RunOptions.backend`` accept; the first, ``auto`` (the compiled
#: backend when a C++ compiler exists, else Amaranth's simulator), is the default.
BACKEND_NAMES = ("auto", *BACKENDS)


def make_backend(design: Design, kind: str = BACKEND_NAMES[0], *,
                 period: float = CLOCK_PERIOD, design_key: str | None = None) -> Backend:
    """A backend of kind ``kind`` (one of :data:`BACKEND_NAMES`) for ``design``: a component, or
    a function that makes one (called only if the design must be elaborated).

    ``design_key``, if given, names the design by what it is made from (its sources and
    parameters): the compiled backend then finds a model built before without elaborating
    the design (:func:`k37.sim.backends.cxxrtl.build.remember_design`).

    ``auto`` picks the compiled backend when a C++ compiler is available, and otherwise says
    so in one line on stderr and falls back to Amaranth's simulator.
    """
    if kind not in BACKEND_NAMES:
        raise ValueError(f"backend kind must be one of {', '.join(BACKEND_NAMES)}, "
                         f"not {kind!r}")
    if kind == "auto" and find_compiler() is None:
        print("k37: no C++ compiler (g++) on PATH; using Amaranth's simulator (about 500x "
              "slower)", file=sys.stderr)
        kind = "pysim"
    if kind == "pysim":
        from k37.sim.backends.pysim import PysimBackend

        return PysimBackend(instantiate(design), period=period)
    from k37.sim.backends.cxxrtl.backend import CxxrtlBackend

    return CxxrtlBackend(design, period=period, design_key=design_key)
