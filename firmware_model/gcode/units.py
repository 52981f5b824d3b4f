"""The built-in front end's constants: units, tolerances, limits and letters."""

from __future__ import annotations

from decimal import Decimal

from k37.hdl.common.constants import AXIS_LETTERS
from k37.hdl.common.params import Limit

__all__ = ["ARC_TOLERANCE_LIMIT", "ARC_TOLERANCE_MM", "AXES_LIMIT", "AXIS_LETTERS",
           "G83_CLEARANCE_MM", "HINTS", "INCH_MM", "LSB_MM_LIMIT",
           "MAX_ERRORS", "MAX_PECKS", "OFFSET_LETTERS", "USES"]

#: Millimetres per inch (G20).
INCH_MM = Decimal("25.4")
#: The most pecks a G83 hole may take (each is three moves): a deeper hole or a smaller Q is
#: refused before it is expanded.
MAX_PECKS = 10_000
#: Default arc tolerance (mm) in G21 and G20: LinuxCNC's (0.028 mm, 0.0028 in): how far the
#: end's distance from the centre may differ from the start's.
ARC_TOLERANCE_MM = {False: 0.028, True: 0.0028 * 25.4}
#: The arc tolerances (LSB) the front end accepts instead of the default.
ARC_TOLERANCE_LIMIT = Limit(0, unit="LSB")
#: The LSB lengths it converts coordinates with.
LSB_MM_LIMIT = Limit(0, low_open=True, unit="mm")
#: Machine axes: X, Y (the paper's machine) or X, Y, Z.
AXES_LIMIT = Limit(2, 3, integer=True)
#: Most errors reported for one program.
MAX_ERRORS = 20
#: G83's rapid stop above the last peck: LinuxCNC's G83_RAPID_DELTA, 0.010 in.
G83_CLEARANCE_MM = Decimal("0.254")
#: The largest R-form arc radius (LSB): beyond the 24-bit registers an arc runs as chords,
#: computed in floating point, which stays well within an LSB up to this.
MAX_R_LSB = 2**40

HINTS = {**dict.fromkeys("ABC", " (K37's axes are X, Y and Z)"),
          **dict.fromkeys("UVW", " (K37's axes are X, Y and Z)"),
          "E": ""}
#: What R and Q are for (in the error for one used elsewhere).
USES = {"R": "arcs and canned cycles", "Q": "G83 (peck depth) and G64"}
OFFSET_LETTERS = "IJK"
