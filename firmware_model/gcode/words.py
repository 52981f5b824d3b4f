"""The G-code words the built-in front end takes: defined once, documented from here.

:data:`G_CODES` and :data:`M_CODES` give every code its modal group and meaning, and
:data:`LETTERS` every other word; the interpreter (:mod:`k37.firmware_model.gcode.parser`)
dispatches on these tables and ``docs/gcode.md`` is generated from them (:func:`markdown`). A new G
code is one entry here and one handler there. """

from __future__ import annotations

from dataclasses import dataclass
from decimal import Decimal

__all__ = ["G_CODES", "LETTERS", "M_CODES", "NGC_LANGUAGE", "REFUSED_G", "REFUSED_M", "Code",
           "code_key", "markdown"]


@dataclass(frozen=True)
class Code:
    """A G or M code: its group (codes of one group exclude each other in a block), the
    event it records (M codes with no hardware here), and its meaning."""

    group: str
    doc: str
    event: str | None = None


def code_key(value: Decimal) -> int:
    """The table key of a code's number: tenths (G90.1 is 901, G0 is 0)."""
    return int(value * 10)


def _g(number: float) -> int:
    return round(number * 10)


G_CODES: dict[int, Code] = {
    _g(0): Code("motion", "rapid line (the machine's `rapid_mm_min`)"),
    _g(1): Code("motion", "feed line"),
    _g(2): Code("motion", "CW arc or helix: I/J/K centre offsets or R radius (R < 0: the "
                          "arc over 180 degrees); an end equal to the start: a full circle"),
    _g(3): Code("motion", "CCW arc or helix, as G02"),
    _g(4): Code("non-modal", "dwell of P seconds"),
    _g(6): Code("motion", "parabola (DIN 66025; XY plane): X/Y the end, I/J the point whose "
                          "tangent is parallel to the chord, relative to the start as arc "
                          "centres; the parabola's axis parallel to X or Y"),
    _g(6.1): Code("motion", "exponential (K37; XY plane): X/Y the end, K the curve's "
                            "constant, a length along X: y - y0 = (ye - y0) "
                            "(e^((x - x0) / K) - 1) / (e^((xe - x0) / K) - 1); K < 0 "
                            "flattens towards the end"),
    _g(6.2): Code("motion", "logarithm (K37; XY plane): the exponential of Y, as "
                            "G06.1 with X and Y exchanged (K a length along Y): "
                            "y - y0 = K ln(1 + (x - x0) (e^((ye - y0) / K) - 1) / (xe - x0))"),
    _g(5): Code("motion", "cubic spline (XY plane): X/Y the end, I/J the first control point "
                          "from the start (after a G05 they may be left out: the previous "
                          "P/Q mirrored), P/Q the second from the end; run as lines within "
                          "the arc tolerance"),
    _g(5.1): Code("motion", "quadratic B-spline (XY plane): X/Y the end, I/J the control point "
                            "from the start; run as lines within the arc tolerance"),
    _g(5.2): Code("motion", "NURBS (XY plane): the start and the control points X/Y of this "
                            "line and the following ones, each with its weight P (default 1), "
                            "order L (default 3); G05.2 P alone weighs the start; run as lines "
                            "within the arc tolerance"),
    _g(5.3): Code("motion", "end of a G05.2 NURBS block (a motion code must follow)"),
    _g(17): Code("plane", "XY plane (arcs take I, J)"),
    _g(18): Code("plane", "ZX plane (arcs take K, I; three-axis machines)"),
    _g(19): Code("plane", "YZ plane (arcs take J, K; three-axis machines; no cutter radius "
                          "compensation, as LinuxCNC)"),
    _g(20): Code("units", "inch"),
    _g(21): Code("units", "millimetre"),
    _g(28): Code("non-modal", "rapid to the home position, the machine origin (through the "
                              "programmed point first, moving only the named axes, if any)"),
    _g(30): Code("non-modal", "as G28 (the second home position is the origin too)"),
    _g(40): Code("cutter", "cutter radius compensation off (the initial state)"),
    _g(41): Code("cutter", "cutter radius compensation, the tool left of the path, as G41.1 "
                           "with the diameter of the loaded tool, or of tool D (D0: the "
                           "loaded tool), from the job's tool table"),
    _g(41.1): Code("cutter", "cutter radius compensation, the tool left of the path: D the "
                             "cutter's diameter, L a lathe tool's orientation (G18) (G17 and "
                             "G18, as LinuxCNC: an entry line or arc, outside corners as arcs, "
                             "inside corners where the paths cross, rs274's gouge checks)"),
    _g(42): Code("cutter", "cutter radius compensation, the tool right of the path, as G41"),
    _g(42.1): Code("cutter", "cutter radius compensation, the tool right of the path, as "
                             "G41.1"),
    _g(43): Code("tool length", "tool length offset: H's length (or the loaded tool's) from "
                                "the job's tool table; no table: zero"),
    _g(49): Code("tool length", "tool length offset off"),
    _g(53): Code("non-modal", "this G00/G01 block in machine coordinates"),
    **{_g(54 + n): Code("coordinate system", f"work coordinate system {n + 1} (offsets zero "
                                             f"until G10 sets them)")
       for n in range(6)},
    **{_g(59 + n / 10): Code("coordinate system", f"work coordinate system {n + 6}, as G54")
       for n in range(1, 4)},
    _g(10): Code("non-modal", "set a coordinate system's offsets (P1-P9: G54-G59.3, P0: the "
                              "one in force): L2 to X/Y/Z, L20 so that the current point is "
                              "X/Y/Z; axes not named keep theirs; the machine does not move"),
    _g(52): Code("non-modal", "local offset: the G92 offset set to X/Y/Z (axes not named keep "
                              "theirs), as LinuxCNC"),
    _g(61): Code("path", "exact path (accepted: the K3701 runs every block to its end, "
                         "one path mode)"),
    _g(64): Code("path", "continuous path, P/Q tolerances ignored (accepted: one path mode)"),
    _g(80): Code("motion", "cancel the canned cycle (no motion mode)"),
    _g(81): Code("motion", "drilling cycle: rapid to X/Y, to R, feed to Z, rapid out"),
    _g(82): Code("motion", "drilling cycle with a dwell of P seconds at the bottom"),
    _g(83): Code("motion", "peck drilling: pecks of Q, rapid out to R between pecks"),
    _g(90): Code("distance", "absolute coordinates"),
    _g(91): Code("distance", "incremental coordinates"),
    _g(90.1): Code("arc distance", "I/J/K absolute (with the offsets in force)"),
    _g(91.1): Code("arc distance", "I/J/K relative to the arc's start (the default)"),
    _g(92): Code("non-modal", "offset the coordinates so the current point is the given one"),
    _g(92.1): Code("non-modal", "clear the G92 offset"),
    _g(93): Code("feed mode", "inverse time: each G01-G03 block's F is the inverse of its "
                              "time in minutes (its feed: F times its length); F is needed on "
                              "each such block"),
    _g(94): Code("feed mode", "feed in units per minute (the initial mode); a change of feed "
                              "mode forgets the feed"),
    _g(98): Code("retract", "canned cycles retract to the Z where they began (the initial "
                            "level, kept until another motion mode; or R if higher)"),
    _g(99): Code("retract", "canned cycles retract to R (the initial mode, as rs274's)"),
}

M_CODES: dict[int, Code] = {
    0: Code("stop", "program stop: recorded; the emulator has no operator, the program goes "
                    "on", "program_stop"),
    1: Code("stop", "optional stop: recorded; the optional-stop switch is off", "optional_stop"),
    2: Code("stop", "program end", "program_end"),
    30: Code("stop", "program end", "program_end"),
    3: Code("spindle", "spindle on, CW (no spindle: recorded)", "spindle_cw"),
    4: Code("spindle", "spindle on, CCW (recorded)", "spindle_ccw"),
    5: Code("spindle", "spindle stop (recorded)", "spindle_stop"),
    6: Code("tool change", "tool change to the selected T (no changer: recorded)",
            "tool_change"),
    7: Code("coolant", "mist coolant on (recorded)", "coolant_mist"),
    8: Code("coolant", "flood coolant on (recorded)", "coolant_flood"),
    9: Code("coolant", "coolant off (recorded)", "coolant_off"),
    70: Code("modal state", "save the modal state (units, plane, distance modes, feed mode "
                            "and feed, coordinate system, tool length offset, retract mode, "
                            "spindle, coolant) in the current call"),
    71: Code("modal state", "forget the state M70 saved in the current call"),
    72: Code("modal state", "restore the state saved in the current call (units first)"),
    73: Code("modal state", "save the modal state and restore it when the subroutine "
                            "returns"),
}

LETTERS: dict[str, str] = {
    "G": "preparatory code (table above)",
    "M": "miscellaneous code (table above); several per block in different groups",
    "N": "sequence number (names the block in plots and reports)",
    "X": "X coordinate", "Y": "Y coordinate", "Z": "Z coordinate (moving Z needs "
                                                   "machine.axes = 3)",
    "I": "arc centre offset along X; G05/G05.1: first control point along X",
    "J": "arc centre offset along Y; G05/G05.1: first control point along Y",
    "K": "arc centre offset along Z; G06.1/G06.2: the curve's constant",
    "R": "arc radius; canned cycles' retract plane",
    "F": "feed, units per minute (modal)",
    "S": "spindle speed (recorded)",
    "T": "tool select (recorded; M06 loads it)",
    "H": "tool length offset number (G43)",
    "P": "dwell seconds (G04, G82); G64's tolerance (ignored); G05: second control point "
         "along X; G05.2: a control point's weight; G10: the coordinate system",
    "Q": "peck depth (G83); G64's tolerance (ignored); G05: second control point along Y",
    "D": "the cutter's diameter (G41.1/G42.1); the tool number of the diameter (G41/G42)",
    "L": "order of a G05.2 NURBS (default 3); G10's form (L2, L20); canned cycles: repeats "
         "of the block (G91: each moved by X/Y or a polar step; G90: the same hole); "
         "G41.1/G42.1 in G18: a lathe tool's orientation (1-9)",
}

#: G codes refused with a reason (by table key).
REFUSED_G: dict[int, str] = {
    **dict.fromkeys((382, 383, 384, 385), "probing is unsupported: K37 has no probe input"),
    **dict.fromkeys((431, 432), "dynamic tool length offsets (tool-length sensing) are "
                                "unsupported: lengths come from the job's program.tools"),
}

#: M codes refused with a reason: (first, last) to why.
REFUSED_M: dict[tuple[int, int], str] = {
    (100, 199): "user M-codes (M100-M199) are unsupported: K37 runs no external programs",
    (61, 61): "M61 (setting the loaded tool) is unsupported: M06 loads the selected T",
    (62, 68): "digital and analog I/O (M62-M68) is unsupported: the K3701 has no such ports",
}

#: The RS-274/NGC language the front end evaluates before the words above act
#: (:mod:`k37.firmware_model.gcode.ngc`): construct, what is taken.
NGC_LANGUAGE: dict[str, str] = {
    "`#1`-`#5000`": "numbered parameters, zero until set; `#1`-`#30` are a call's arguments",
    "`#<name>`, `#<_name>`": "named parameters: local to the call (or main program), global "
                             "with `_`; reading one never set is an error",
    "`#5161`-`#5428`, `#<_x>`...": "the interpreter's: homes (zero), G92 and G54-G59.3 offsets, "
                                   "coordinate system, tool, current position, modes "
                                   "(`ngc_state`); others are errors naming them",
    "`#1 = value`": "takes effect after the whole line is read",
    "`[...]`": "expressions: `**`; `* / MOD`; `+ -`; `EQ NE GT GE LT LE`; `AND OR XOR` "
               "(each level left to right)",
    "`ABS ACOS ASIN ATAN[y]/[x] COS EXP FIX FUP ROUND LN SIN SQRT TAN EXISTS`":
        "functions, angles in degrees",
    "`o.. sub`/`endsub`/`call`/`return`": "subroutines anywhere in the file, arguments "
                                          "`[..]` to `#1`-`#30`, a value to `#<_value>`",
    "`o.. while`/`do`/`repeat`/`if`/`elseif`/`else`/`break`/`continue`": "control flow, "
                                                                         "numbered or named",
    "`@`, `^`": "polar radius and angle (degrees) for G00/G01 and canned cycles (with L, "
                "a bolt circle: `G91 G81 ^60 L6`), as LinuxCNC",
    "`(MSG,..)`, `(DEBUG,..)`, `(PRINT,..)`": "program events (DEBUG and PRINT with "
                                              "parameter values)",
}


def markdown() -> str:
    """``docs/gcode.md``: the dialect's words, generated from the tables above."""
    from k37.firmware_model.gcode.ngc import MAX_BLOCKS, MAX_CALL_DEPTH
    def code(prefix: str, key: int) -> str:
        number = f"{key // 10:02d}" if key % 10 == 0 else f"{key / 10:04.1f}"
        return prefix + number

    rows = ["# G-code words of the built-in front end", "",
            "Generated from `firmware_model/gcode/words.py` (`k37 docs`). Anything else is "
            "an error naming its line and column; `--frontend linuxcnc` runs a program "
            "through LinuxCNC's own interpreter, `rs274`, where it is installed.", "",
            "| code | group | meaning |", "|---|---|---|"]
    rows += [f"| {code('G', k)} | {c.group} | {c.doc} |" for k, c in G_CODES.items()]
    rows += [f"| M{k:02d} | {c.group} | {c.doc} |" for k, c in M_CODES.items()]
    rows += ["", "| word | meaning |", "|---|---|"]
    rows += [f"| {letter} | {doc} |" for letter, doc in LETTERS.items()]
    rows += ["", "| refused | why |", "|---|---|"]
    rows += [f"| {code('G', k)} | {why} |" for k, why in REFUSED_G.items()]
    rows += [f"| M{a}{'' if a == b else f'-M{b}'} | {why} |" for (a, b), why in REFUSED_M.items()]
    rows += ["", "## The RS-274/NGC language", "",
             f"At most {MAX_BLOCKS:,} lines executed (loops and calls counted each time) and "
             f"{MAX_CALL_DEPTH} nested calls; beyond, an error at the line.", "",
             "| construct | meaning |", "|---|---|"]
    rows += [f"| {what} | {doc} |" for what, doc in NGC_LANGUAGE.items()]
    rows += [""]
    return "\n".join(rows)
