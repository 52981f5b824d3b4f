"""Programs generated for tests and benchmarks alike (imported as ``tests.programs``)."""

from __future__ import annotations

__all__ = ["mixed_program"]


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
