"""The G-code lexer: one source line to its words.

A word is an ASCII letter (either case) and a number: an optional sign and ASCII digits with
an optional decimal point. Spaces and tabs may stand anywhere between words and inside a
word (between its letter, sign and digits: ``X 1 2.5`` is X12.5), as RS-274/NGC allows.
Comments ``( ... )`` (not nested, closed on their line) and ``; ...`` are skipped, and a
``/`` first on a line (block delete) is ignored: the block-delete switch is off, as in
LinuxCNC's ``rs274``. Any other character, including other Unicode spaces and non-ASCII
digits, is an error naming it; ``O``, ``#`` and ``[`` (RS-274/NGC's subroutines, parameters
and expressions) are refused with the way to run them.
"""

from __future__ import annotations

import re
import unicodedata
from dataclasses import dataclass
from decimal import Decimal

from firmware_model.gcode.words import NGC_ONLY

__all__ = ["NGC_HINT", "LexError", "Word", "words_of"]

#: How to run what only RS-274/NGC has.
NGC_HINT = ("an RS-274/NGC construct: run it with `k37 run --frontend linuxcnc` (LinuxCNC's "
            "interpreter rs274: apt-get install linuxcnc-uspace)")

_BLANK = " \t\r"
_NUMBER = re.compile(r"[ \t]*([+-]?[ \t]*"
                     r"(?:[0-9][0-9 \t]*(?:\.[0-9 \t]*)?|\.[ \t]*[0-9][0-9 \t]*))")


@dataclass(frozen=True)
class Word:
    """A word: its letter (upper case), its text as normalised (``X-1.5``), its value and
    the column of its letter (from 1)."""

    letter: str
    text: str
    value: Decimal
    col: int


class LexError(ValueError):
    """A character the lexer cannot read; ``col`` from 1."""

    def __init__(self, col: int, message: str):
        super().__init__(message)
        self.col = col
        self.message = message


def _describe(c: str) -> str:
    name = unicodedata.name(c, "")
    return f"{c!r} (U+{ord(c):04X}{' ' + name if name else ''})"


def _bad(c: str, col: int) -> LexError:
    if c in NGC_ONLY or c.upper() in NGC_ONLY:
        return LexError(col, f"{NGC_ONLY[c.upper()]}: {NGC_HINT}")
    if c.isspace():
        return LexError(col, f"unexpected white space {_describe(c)}: only spaces and tabs "
                             f"separate words")
    if c.isdigit() or unicodedata.category(c) == "Nd":
        return LexError(col, f"unexpected character {_describe(c)}: numbers take ASCII "
                             f"digits 0-9")
    return LexError(col, f"unexpected character {_describe(c)}")


def words_of(text: str) -> list[Word]:
    """The words of one line, comments removed. Raises :class:`LexError`."""
    words = []
    pos = 0
    stripped = text.lstrip(_BLANK)
    if stripped.startswith("/"):
        pos = len(text) - len(stripped) + 1
    while pos < len(text):
        c = text[pos]
        if c in _BLANK:
            pos += 1
        elif c == ";":
            break
        elif c == "(":
            close = text.find(")", pos)
            if close < 0:
                raise LexError(pos + 1, "comment '(' is not closed on its line")
            if "(" in text[pos + 1:close]:
                raise LexError(text.index("(", pos + 1) + 1, "nested comment '('")
            pos = close + 1
        elif c.isascii() and c.isalpha() and c.upper() not in NGC_ONLY:
            m = _NUMBER.match(text, pos + 1)
            if m is None:
                after = text[pos + 1:].lstrip(" \t")
                if after and (not after[0].isascii() or after[0] in NGC_ONLY):
                    raise _bad(after[0], len(text) - len(after) + 1)
                raise LexError(pos + 1, f"word {c.upper()} has no number")
            number = re.sub(r"[ \t]", "", m.group(1))
            words.append(Word(c.upper(), c.upper() + number, Decimal(number), pos + 1))
            pos = m.end()
        else:
            raise _bad(c, pos + 1)
    return words
