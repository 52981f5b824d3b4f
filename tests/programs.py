"""Programs generated for tests and benchmarks alike (imported as ``tests.programs``)."""

from __future__ import annotations

import math

__all__ = ["mixed_program", "surface_finish"]


def mixed_program(lines: int = 1000) -> str:
    """A G21 program of ``lines`` lines (after its first, the modes and feed): lines to
    scattered points, short CW arcs, returns to the origin and full CCW circles of radius
    1-9 mm, in turn."""
    text = ["G21 G90 F1000"]
    k = 0
    while len(text) <= lines:
        text += [f"G01 X{k % 50}.{k % 7} Y{k % 13}", f"G02 X{k % 50 + 2}.{k % 7} "
                 f"Y{k % 13} I1 J0", "G01 X0 Y0", f"G03 I{1 + k % 9} J0"]
        k += 1
    return "\n".join(text[:lines])


def surface_finish(rows: int = 30, per_row: int = 100) -> str:
    """A 3-D surface-finishing pass as CAM writes one: ``rows`` zigzag rows of ``per_row``
    0.25 mm G01 moves at F2400, each moving X, Y and Z over a wavy surface (``rows *
    per_row + 5`` blocks with the approach and the retract)."""
    lines = ["G17 G21 G90 F2400", "G00 Z1", "G00 X0 Y0", "G01 Z0"]
    for row in range(rows):
        xs = [k * 0.25 for k in range(per_row + 1)]
        for k, x in enumerate(xs[::-1] if row % 2 else xs):
            z = 0.2 * math.sin(x / 3) * math.cos(row / 4)
            lines.append(f"G01 X{x:.3f} Y{row * 0.5 + 0.05 * math.sin(k):.3f} Z{z:.3f}")
    return "\n".join([*lines, "G00 Z1", "M30"])
