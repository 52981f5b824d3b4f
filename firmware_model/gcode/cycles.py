"""Canned cycles (G81, G82, G83) as the interpreter expands them (a mixin of
:class:`k37.firmware_model.gcode.interpreter.Interpreter`), as LinuxCNC's interpreter does.

``L`` repeats a cycle's block (:func:`cycle_repeats`): in G91 each repeat moves by the block's
X/Y (or its polar ``@``/``^`` step, a bolt circle), in G90 it drills the same hole again; the
repeats keep the first block's R and Z planes.
"""

from __future__ import annotations

from decimal import Decimal

from k37.firmware_model.gcode.block_words import BlockError, BlockWords
from k37.firmware_model.gcode.lex import Word
from k37.firmware_model.gcode.units import G83_CLEARANCE_MM, MAX_PECKS
from k37.firmware_model.gcode.words import code_key

__all__ = ["CYCLES", "MAX_REPEATS", "CannedCycles", "cycle_repeats"]

#: The canned cycles' motion codes (table keys).
CYCLES = (810, 820, 830)
#: The most repeats (L) of one cycle block.
MAX_REPEATS = 10_000


def cycle_repeats(words: list[Word], motion: int | None, incremental: bool
                  ) -> tuple[list[Word], list[Word], int]:
    """A block without its ``L`` word, the words each repeat runs and how many repeats
    follow, when the block is a canned cycle's (``motion``: the modal motion before it;
    ``incremental``: G91 in force); other blocks unchanged, with no repeats. Raises
    :class:`BlockError` for an L that is not a whole number from 1 to :data:`MAX_REPEATS`."""
    count = next((w for w in words if w.letter == "L"), None)
    keys = [code_key(w.value) for w in words if w.letter == "G"]
    motion = next((k for k in keys if k in CYCLES or k in (0, 10, 20, 30, 800)), motion)
    if count is None or motion not in CYCLES or 100 in keys:
        return words, [], 0
    if count.value != count.value.to_integral_value() or not 1 <= count.value <= MAX_REPEATS:
        raise BlockError(count.col, f"{count.text}: a canned cycle's L (repeats) is a whole "
                                    f"number from 1 to {MAX_REPEATS:,}")
    if 910 in keys or (incremental and 900 not in keys):
        again = [w for w in words if w.letter in "XY@^"] or [Word("X", "X0", Decimal(0),
                                                                  count.col)]
    else:
        again = [w for w in words if w.letter in "XY@^RZ"]
    return [w for w in words if w is not count], again, int(count.value) - 1


class CannedCycles:
    """The canned-cycle words of the interpreter (its state: ``cycle``, ``cycle_planes``,
    ``cycle_il``: the initial level, the Z where the cycles began, for G91's R and G98's
    retract, as LinuxCNC keeps it from one cycle block to the next until another motion
    mode)."""

    def canned_cycle(self, b: BlockWords, anchor: Word) -> None:
        """G81/G82/G83 at the block's X/Y, expanded as LinuxCNC's interpreter does."""
        if self.plane != 17:
            raise BlockError(anchor.col, f"G{self.motion // 10} in G{self.plane} is "
                                          f"unsupported: canned cycles drill along Z, in G17")
        for letter in "ZRPQ":
            w = b.word(letter)
            if w is not None:
                self.cycle[letter] = w.value
        needs = "ZR" + ("P" if self.motion == 820 else "") + ("Q" if self.motion == 830 else "")
        missing = [letter for letter in needs if letter not in self.cycle]
        if missing:
            raise BlockError(anchor.col, f"G{self.motion // 10} needs {' and '.join(missing)}")
        if self.motion == 830 and self.cycle["Q"] <= 0:
            raise BlockError(anchor.col, f"G83: the peck Q{self.cycle['Q']} must be positive")
        old_z = self.pos[2]
        if self.cycle_il is None:
            self.cycle_il = old_z
        if self.cycle_planes is None or "motion" in b.g or b.word("R") or b.word("Z"):
            # R and Z as of the cycle's first block (in G91: from the Z there), kept for its
            # repeats, with that block's Z for G98's retract
            if self.incremental:
                r = self.cycle_il + self.lsb(self.cycle["R"])
                bottom = r + self.lsb(self.cycle["Z"])
            else:
                r = self.offset(2) + self.lsb(self.cycle["R"])
                bottom = self.offset(2) + self.lsb(self.cycle["Z"])
            self.cycle_planes = r, bottom, self.cycle_il
        r, bottom, start_z = self.cycle_planes
        if r < bottom:
            raise BlockError(anchor.col, f"G{self.motion // 10}: the retract plane R is below "
                                          f"the bottom Z")
        xy = self.target(BlockWords([w for w in (b.word("X"), b.word("Y")) if w is not None]))
        clear = r if self.retract_r else max(r, start_z)
        if self.planner.axes == 2 and (r != old_z or bottom != old_z):
            raise BlockError(anchor.col, f"G{self.motion // 10} moves Z: this machine has two "
                                          f"axes (machine.axes = 3 runs it)")
        moves: list[tuple[int, bool]] = []  # (z, feed?) at the hole
        if old_z < r:
            self.plan(anchor.col, self.planner.line, (*self.pos[:2], r), None)
        if self.motion == 830:
            delta = self.lsb(self.cycle["Q"])
            if delta < 1:
                raise BlockError(anchor.col, f"G83: the peck Q{self.cycle['Q']} is under half "
                                              f"an LSB ({self.planner.mm(1)})")
            pecks = -(-(r - bottom) // delta)
            if pecks > MAX_PECKS:
                raise BlockError(anchor.col, f"G83: {pecks} pecks of Q{self.cycle['Q']} from R "
                                              f"to Z; at most {MAX_PECKS} a hole")
            rapid_delta = self.lsb(G83_CLEARANCE_MM, inch=False)
            depth = r - delta
            while depth > bottom:
                moves += [(depth, True), (r, False), (depth + rapid_delta, False)]
                depth -= delta
        moves += [(bottom, True)]
        self.plan(anchor.col, self.planner.line, (xy[0], xy[1], self.pos[2]), None)
        self.plan(anchor.col, self.planner.line, (xy[0], xy[1], r), None)
        for z, feed in moves:
            self.plan(anchor.col, self.planner.line, (xy[0], xy[1], z),
                      self.feed if feed else None, feed_source=self.feed_source)
        if self.motion == 820:
            self.planner.dwell(self.line_no, float(self.cycle["P"]))
        self.plan(anchor.col, self.planner.line, (xy[0], xy[1], clear), None)
