"""The chipset's constants that the gateware, the firmware and the simulation share, each
defined here once: the system clock, the axes and the planes."""

from __future__ import annotations

__all__ = ["ALL_AXES", "AXIS_LETTERS", "CHIP_HZ", "PLANE_AXES"]

#: The chipset's system clock CP, the paper's 1 MHz (Hz): the default machine's and a board's.
CHIP_HZ = 1_000_000
#: Every axis a chipset can have, in order: a chipset of n axes has the first n.
ALL_AXES = ("x", "y", "z")
#: The same axes as G-code words and messages name them.
AXIS_LETTERS = "".join(ALL_AXES).upper()
#: The planes by their G-code, G17, G18 and G19, each as the machine axes (0 X, 1 Y, 2 Z) of its
#: first, second and normal coordinates: G17 (X, Y, Z), G18 (Z, X, Y), G19 (Y, Z, X), as
#: LinuxCNC's canon orders them. A K3701 block's plane code is a plane's place here (G17: 0).
PLANE_AXES = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}
