"""What a backend reads of an Amaranth design: its ports and its signals' names.

Only the backends that elaborate the design import this (and Amaranth): Amaranth's simulator
always, the compiled backend when it converts a design it has no model of, and the engine for
the machine's ports.
"""

from __future__ import annotations

from typing import Any

from amaranth.hdl import Elaboratable, Shape, Value, ValueCastable
from amaranth.lib import wiring

from k37.sim.backends.contract import Port

__all__ = ["component_ports", "mark_elaborated", "signal_paths"]


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


def signal_paths(design: Any) -> dict[str, Value]:
    """Every named signal of a prepared Amaranth design, by dotted path below the top."""
    paths: dict[str, Value] = {}
    for info in design.fragments.values():
        scope = info.name[1:]
        for signal, name in info.signal_names.items():
            paths.setdefault(".".join((*scope, name)), signal)
    return paths


def mark_elaborated(component: wiring.Component) -> None:
    """Tell Amaranth's unused-elaboratable check that ``component`` and the elaboratables it
    holds are in use, as elaborating them would have (a design found by its key is not
    elaborated: a compiled model stands for it)."""
    stack, seen = [component], set()
    while stack:
        obj = stack.pop()
        if id(obj) in seen:
            continue
        seen.add(id(obj))
        obj._MustUse__used = True  # Amaranth's own flag (amaranth/_unused.py)
        stack.extend(v for v in vars(obj).values() if isinstance(v, Elaboratable))
