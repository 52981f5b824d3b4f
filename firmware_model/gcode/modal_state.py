"""M70-M73 (saving and restoring the modal state) and G93 (inverse time feed) as LinuxCNC's
interpreter has them (a mixin of :class:`k37.firmware_model.gcode.interpreter.Interpreter`).

* ``M70`` saves the modal state in the current call's context (the main program's at the top
  level); ``M72`` restores it (an error if none was saved there); ``M71`` forgets it; ``M73``
  saves it and has the subroutine restore it when it returns (``endsub`` or ``return``). A
  context saved in a subroutine ends with it. Saved and restored: the units (restored first),
  the plane, the distance and arc distance modes, the feed mode and feed, the coordinate
  system, the tool length offset, the canned-cycle retract mode, the spindle speed and state
  and the coolant; not the motion mode. Restored spindle and coolant states are events, as
  ``rs274``'s commands.
* In ``G93`` each G01, G02 or G03 block needs F, the inverse of the move's time in minutes:
  the move's feed is F times its length (an arc's along the helix), a K3701 feed word per
  move as any feed (clamped and warned the same way). Switching between ``G93`` and ``G94``
  forgets the feed, as ``rs274``. Canned cycles, splines, parabolas and exponentials in G93
  are errors (``rs274`` refuses its cycles in G93).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from k37.firmware_model.gcode.block_words import BlockError, BlockWords
from k37.firmware_model.gcode.lex import Word

__all__ = ["ModalSnapshot", "ModalState"]

#: The spindle and coolant events an M code's state is, by kind.
_SPINDLE = ("spindle_cw", "spindle_ccw", "spindle_stop")
_COOLANT = {"coolant_mist": (True, None), "coolant_flood": (None, True),
            "coolant_off": (False, False)}


@dataclass(frozen=True)
class ModalSnapshot:
    """What M70 and M73 save (the interpreter's attributes of the same names)."""

    inch: bool
    plane: int
    incremental: bool
    arc_absolute: bool
    inverse_time: bool
    feed: float | None
    feed_source: tuple[int, int, str] | None
    coordinate_system: int
    tool_offset: int
    retract_r: bool
    speed: float
    spindle: str
    mist: bool
    flood: bool


class ModalState:
    """The M70-M73 and G93 words of the interpreter (its state: ``contexts``, one per call
    level, each a saved snapshot or None and the M73 that restores it on return; the spindle
    and coolant states; ``inverse_time`` and the block's ``inverse_f``)."""

    def init_modal_state(self) -> None:
        self.contexts: list[tuple[ModalSnapshot | None, Word | None]] = [(None, None)]
        self.speed = 0.0
        self.spindle = "spindle_stop"
        self.mist = self.flood = False
        self.inverse_time = False
        self.inverse_f: Word | None = None

    def track(self, kind: str, value: float | None) -> None:
        """Keep the spindle and coolant states an event sets."""
        if kind == "spindle_speed" and value is not None:
            self.speed = value
        elif kind in _SPINDLE:
            self.spindle = kind
        elif kind in _COOLANT:
            mist, flood = _COOLANT[kind]
            self.mist = self.mist if mist is None else mist
            self.flood = self.flood if flood is None else flood

    def snapshot(self) -> ModalSnapshot:
        return ModalSnapshot(**{f.name: getattr(self, f.name) for f in fields(ModalSnapshot)})

    def modal_state(self, b: BlockWords) -> None:
        """M70, M71, M72 or M73, after the block's feed, speed and tool words, as rs274."""
        if "modal state" not in b.m:
            return
        key, w = b.m["modal state"]
        saved, _ = self.contexts[-1]
        if key in (70, 73):
            self.contexts[-1] = self.snapshot(), w if key == 73 else None
        elif key == 71:
            self.contexts[-1] = None, None
        elif saved is None:
            raise BlockError(w.col, f"{w.text}: no modal state saved in this call (M70 or M73 "
                                    f"saves it)")
        else:
            self.restore(saved, w)

    def restore(self, saved: ModalSnapshot, w: Word) -> None:
        """The state ``saved`` back; the spindle and coolant changes as events of ``w``."""
        if self.speed != saved.speed:
            self.event(w, "spindle_speed", saved.speed)
        if self.spindle != saved.spindle:
            self.event(w, saved.spindle)
        mist, flood = self.mist, self.flood
        if (mist and not saved.mist) or (flood and not saved.flood):
            self.event(w, "coolant_off")
            mist = flood = False
        if saved.mist and not mist:
            self.event(w, "coolant_mist")
        if saved.flood and not flood:
            self.event(w, "coolant_flood")
        for f in fields(ModalSnapshot):
            setattr(self, f.name, getattr(saved, f.name))

    def enter_call(self) -> None:
        self.contexts.append((None, None))

    def leave_call(self) -> None:
        """The end of a subroutine (``endsub`` or ``return``): its context ends, restoring
        the state its M73 saved."""
        saved, m73 = self.contexts.pop()
        if m73 is not None and saved is not None:
            self.restore(saved, m73)

    # -- G93 ------------------------------------------------------------------------------------

    def feed_mode(self, b: BlockWords) -> None:
        """G93/G94: a change forgets the feed; in G93, the block's F for its move."""
        mode = b.code("feed mode")
        if mode is not None and (mode == 930) != self.inverse_time:
            self.inverse_time = mode == 930
            self.feed = self.feed_source = None
        self.inverse_f = None
        f = b.word("F")
        if self.inverse_time and f is not None:
            if f.value <= 0:
                raise BlockError(f.col, f"{f.text}: the feed must be positive")
            self.inverse_f = f

    def inverse_time_feed(self, anchor: Word, length: float) -> None:
        """In G93, the feed (mm/min) of a G01-G03 move ``length`` LSB long: F times it."""
        if not self.inverse_time:
            return
        name = f"G0{self.motion // 10}"
        if self.motion not in (10, 20, 30):
            raise BlockError(anchor.col, f"{name if self.motion < 50 else anchor.text} in "
                                         f"inverse time (G93): G93 is for G01, G02 and G03 "
                                         f"(G94 first)")
        f = self.inverse_f
        if f is None:
            raise BlockError(anchor.col, f"{name} in inverse time (G93) needs F (the inverse "
                                         f"of the move's time in minutes)")
        self.feed = float(f.value) * length * float(self.lsb_size)
        self.feed_source = (self.line_no, f.col, f.text)

    def arc_length(self, centre: tuple[int, int], target: tuple[int, int, int],
                   axes: tuple[int, int, int], cw: bool) -> float:
        """An arc's length along its helix (LSB), from the position around ``centre``."""
        first, second, normal = axes
        start = self.pos
        a0 = math.atan2(start[second] - centre[1], start[first] - centre[0])
        a1 = math.atan2(target[second] - centre[1], target[first] - centre[0])
        sweep = (a0 - a1) if cw else (a1 - a0)
        sweep %= 2 * math.pi
        if sweep == 0:
            sweep = 2 * math.pi
        radius = math.hypot(start[first] - centre[0], start[second] - centre[1])
        return math.hypot(radius * sweep, target[normal] - start[normal])
