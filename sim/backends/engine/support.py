"""What the engine runs: a predicate over a machine's options and a program's blocks.

The engine runs the two- and three-axis machines with accel/decel circuits of every shape in
every placement (``machine.accel``: before the K3701, one per axis after it, each of its own
shape, ``accel_bits`` and addition clock, or none), every servo drive on every axis
(first-order, torque, two-mass), and programs of lines, arcs and helices.
:func:`unsupported` names the first option outside that (None: the engine runs the machine);
it reads the parameters the simulated machine is built with
(:func:`k37.sim.run.runner.system_params`), so it needs no Amaranth.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

__all__ = ["unsupported", "unsupported_blocks"]


def unsupported(params: Mapping[str, Any], kinds: Iterable[object] = ()) -> str | None:
    """The first machine option in ``params`` (the keyword arguments of
    :class:`k37.sim.machine.system.System`) that the engine does not run, in words naming
    the job's key, or else the first block kind of ``kinds`` (:func:`unsupported_blocks`);
    None if it runs them all."""
    del params  # every machine option: each drive on every axis, every accel/decel circuit
    return unsupported_blocks(kinds)


def unsupported_blocks(kinds: Iterable[object]) -> str | None:
    """The first block kind (a :class:`k37.hdl.k3701.block.Kind`) the engine does not run, in
    words; None if it runs them all (lines and arcs, helices among them)."""
    for kind in kinds:
        name = str(getattr(kind, "name", kind)).lower()
        if name not in ("linear", "circular", "parabolic", "exponential"):
            return f"a {name} block (the engine runs lines, arcs and helices)"
    return None
