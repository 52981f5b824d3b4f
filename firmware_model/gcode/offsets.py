"""Work offsets as LinuxCNC's interpreter keeps them (a mixin of
:class:`k37.firmware_model.gcode.interpreter.Interpreter`): the nine coordinate systems G54-G59.3
that G10 L2/L20 set, and the G92 offset that G92, G52 and G92.1 set.

A position in the program's coordinates is the machine's less the offsets in force: the
coordinate system's, the G92 (or G52) offset and, on Z, the tool length. Setting an offset
never moves the machine: an axis a later move does not name stays where it is (as
``rs274`` does). ``G10 L2 Pn`` sets system n's offsets to the values given (absolute, in G91
too), ``G10 L20 Pn`` so that the current point has the given coordinates in system n (P0:
the system in force); the axes not named keep theirs. ``G52`` sets the G92 offset to the
values given (the axes not named keep theirs), as LinuxCNC does.
"""

from __future__ import annotations

from k37.firmware_model.gcode.block_words import BlockError, BlockWords
from k37.firmware_model.gcode.lex import Word
from k37.firmware_model.gcode.units import AXIS_LETTERS

__all__ = ["SYSTEMS", "Offsets", "system_number"]

#: The coordinate systems' codes (table keys: G54 is 540, G59.1 is 591), in number order.
SYSTEMS = (540, 550, 560, 570, 580, 590, 591, 592, 593)


def system_number(code: int) -> int:
    """The number (1-9) of a coordinate system's code (G54: 1, G59.3: 9)."""
    return SYSTEMS.index(code) + 1


class Offsets:
    """The offset words of the interpreter (its state: ``g5x``, ``g92``, ``tool_offset``,
    ``coordinate_system``)."""

    def offset(self, axis: int) -> int:
        """What the program's coordinates add on ``axis`` to be the machine's (LSB)."""
        return (self.g5x[self.coordinate_system][axis] + self.g92[axis]
                + (self.tool_offset if axis == 2 else 0))

    def set_offsets(self, b: BlockWords, key: int, w: Word) -> None:
        """G10, G52, G92 or G92.1 (``key``, its word ``w``)."""
        if key == 921:
            self.g92 = [0, 0, 0]
            return
        if key == 100:
            self.g10(b, w)
            return
        for axis, letter in enumerate(AXIS_LETTERS):
            v = b.word(letter)
            if v is None:
                continue
            if key == 520:  # G52: the offset itself
                self.g92[axis] = self.lsb(v.value)
            else:  # G92: the current point gets the value
                self.g92[axis] = (self.pos[axis] - self.lsb(v.value) - self.offset(axis)
                                  + self.g92[axis])

    def g10(self, b: BlockWords, w: Word) -> None:
        """G10 L2 (a system's offsets) or L20 (a system's offsets from the current point)."""
        form, number = b.word("L"), b.word("P")
        if form is None:
            raise BlockError(w.col, "G10 needs L2 or L20 (a coordinate system's offsets)")
        if form.value not in (2, 20):
            raise BlockError(form.col, f"{form.text}: setting tools with G10 (L1, L10, L11) is "
                                       f"unsupported: tool lengths come from the job's "
                                       f"program.tools; G10 takes L2 or L20")
        if number is None or number.value not in range(10):
            raise BlockError((number or w).col, f"G10 L{form.value} needs P0-P9, the "
                                                f"coordinate system (P0: the one in force)")
        rotation = b.word("R")
        if rotation is not None:
            raise BlockError(rotation.col, f"{rotation.text}: rotated coordinate systems "
                                           f"(G10 R) are unsupported")
        system = self.coordinate_system if number.value == 0 else SYSTEMS[int(number.value) - 1]
        offsets = self.g5x[system]
        for axis, letter in enumerate(AXIS_LETTERS):
            v = b.word(letter)
            if v is None:
                continue
            if form.value == 2:
                offsets[axis] = self.lsb(v.value)
            else:
                offsets[axis] = (self.pos[axis] - self.lsb(v.value) - self.g92[axis]
                                 - (self.tool_offset if axis == 2 else 0))
