"""One block of G-code as the interpreter reads it: its words grouped by letter and its G and
M codes by modal group, and the error that refuses it."""

from __future__ import annotations

from collections.abc import Callable

from k37.firmware_model.gcode.lex import Word
from k37.firmware_model.gcode.units import HINTS
from k37.firmware_model.gcode.words import (
    G_CODES,
    LETTERS,
    M_CODES,
    REFUSED_G,
    REFUSED_M,
    Code,
    code_key,
)

__all__ = ["BlockError", "BlockWords", "g_name"]


def g_name(key: int) -> str:
    """A G code as written from its table key (tenths): 10 is G01, 61 is G06.1."""
    return f"G{key // 10:02d}" + (f".{key % 10}" if key % 10 else "")


class BlockError(Exception):
    def __init__(self, col: int, message: str):
        super().__init__(message)
        self.col = col
        self.message = message


class BlockWords:
    """The words of one line, sorted: G and M codes by group, the rest by letter."""

    def __init__(self, words: list[Word]):
        self.g: dict[str, tuple[int, Word]] = {}
        self.m: dict[str, tuple[int, Word]] = {}
        self.words: dict[str, Word] = {}
        #: The word of a letter, or None.
        self.word: Callable[[str], Word | None] = self.words.get
        for w in words:
            if w.letter in "GM":
                self._code(w, G_CODES if w.letter == "G" else M_CODES,
                           self.g if w.letter == "G" else self.m)
            elif w.letter not in LETTERS:
                raise BlockError(w.col, f"unsupported word {w.text}{HINTS.get(w.letter, '')}")
            elif w.letter in self.words:
                raise BlockError(w.col, f"{w.letter} appears twice in one block")
            else:
                self.words[w.letter] = w

    @staticmethod
    def _code(w: Word, table: dict[int, Code], found: dict[str, tuple[int, Word]]) -> None:
        key = code_key(w.value) if w.letter == "G" else None
        if w.letter == "M" and w.value == w.value.to_integral_value():
            key = int(w.value)
        if w.letter == "G" and key in REFUSED_G:
            raise BlockError(w.col, f"{w.text}: {REFUSED_G[key]}")
        for (first, last), why in REFUSED_M.items() if w.letter == "M" else ():
            if key is not None and first <= key <= last:
                raise BlockError(w.col, f"{w.text}: {why}")
        if key is None or key not in table or w.value * 10 != int(w.value * 10):
            raise BlockError(w.col, f"{w.text} is unsupported")
        group = table[key].group
        if group in found:
            raise BlockError(w.col, f"{found[group][1].text} and {w.text} are in the same "
                                     f"modal group ({group})")
        found[group] = key, w

    def code(self, group: str) -> int | None:
        return self.g[group][0] if group in self.g else None
