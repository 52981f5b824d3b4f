"""The G-code lexer: one source line to its words, parameter settings, O-word and comments.

Lines are read as LinuxCNC's interpreter reads them (RS-274/NGC). Spaces and tabs may stand
anywhere outside comments and are dropped (``X 1 2.5`` is X12.5, ``#<tool dia>`` is
``#<tooldia>``); letters are read in either case. Comments ``( ... )`` (not nested, closed
on their line) and ``; ...`` are kept apart (``(MSG,...)`` and ``(DEBUG,...)`` are messages,
see :mod:`k37.firmware_model.gcode.ngc`), and a ``/`` first on a line (block delete) is ignored:
the block-delete switch is off, as in LinuxCNC's ``rs274``.

A word is a letter and a value: a number (an optional sign, ASCII digits with an optional
decimal point), a parameter (``#1``, ``##1``, ``#[1+1]``, ``#<name>``), an expression in
brackets, a unary function (``SIN[..]``, ``ATAN[..]/[..]``, ``EXISTS[#<name>]``) or a sign
before one of these (:mod:`k37.firmware_model.gcode.expr`). ``@`` and ``^`` are the polar
radius and angle. ``#n = value`` and ``#<name> = value`` set parameters; ``O`` first on a
line (after an optional ``N`` word) is an O-word statement (``o100 while [...]``,
``o<name> call [1] [2]``, ``o#2 call``), or alone on its line a program number (``O1000``,
``O0000(MY GCODE)``), read and ignored as LinuxCNC and Fanuc controls do.

Any other character, including other Unicode spaces and non-ASCII digits, is an error naming
it and its column (:class:`LexError`).
"""

from __future__ import annotations

import re
import unicodedata
from dataclasses import dataclass
from decimal import Decimal
from typing import NamedTuple

from k37.firmware_model.gcode.expr import (
    FUNCTIONS,
    PRECEDENCE,
    Binary,
    Call,
    ExprError,
    Named,
    Negate,
    Node,
    Number,
    Numbered,
)

__all__ = ["O_KEYWORDS", "Assignment", "Comment", "LexError", "NgcLine", "OStatement",
           "Word", "WordValue", "read_line"]

_BLANK = " \t\r"
_NO_BLANKS = str.maketrans("", "", _BLANK)
_NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)")
#: A line of words each written as a letter and a number, blanks only between words (most
#: lines), upper case: read in one pass.
_PLAIN_WORD = re.compile(r"([A-NP-Z])(" + _NUMBER.pattern + ")")
_PLAIN_LINE = re.compile(f"(?:[{_BLANK}]*{_PLAIN_WORD.pattern})*[{_BLANK}]*")
#: Deepest nesting of brackets and functions in one value.
MAX_NESTING = 64
#: O-word keywords and how many bracketed values each takes: (least, most).
O_KEYWORDS: dict[str, tuple[int, int]] = {
    "sub": (0, 0), "endsub": (0, 1), "call": (0, 30), "return": (0, 1),
    "do": (0, 0), "while": (1, 1), "endwhile": (0, 0), "repeat": (1, 1), "endrepeat": (0, 0),
    "if": (1, 1), "elseif": (1, 1), "else": (0, 0), "endif": (0, 0),
    "break": (0, 0), "continue": (0, 0),
}
_FUNCTION_NAMES = (*FUNCTIONS, "atan", "exists")
_O_NUMBER = re.compile(r"[+-]?[0-9]+")
_N_BEFORE_O = re.compile(r"n[0-9]+(?:\.[0-9]*)?(?=o)")


class Word(NamedTuple):
    """A word: its letter (upper case), its text as normalised (``X-1.5``; a computed value:
    the letter and the value), its value and the column of its letter (from 1)."""

    letter: str
    text: str
    value: Decimal
    col: int


class LexError(ValueError):
    """A line the lexer cannot read; ``col`` from 1."""

    def __init__(self, col: int, message: str):
        super().__init__(message)
        self.col = col
        self.message = message


class WordValue(NamedTuple):
    """A word whose value is an expression (``X[1+2]``, ``Y#1``), before evaluation; a word
    written as a number is read as its :class:`Word`."""

    letter: str
    node: Node
    col: int


@dataclass(frozen=True)
class Assignment:
    """``#target = node``: target a :class:`Numbered` or :class:`Named` node."""

    target: Numbered | Named
    node: Node
    col: int


@dataclass(frozen=True)
class OStatement:
    """``o<label> keyword [args]``: label ``100`` or ``<name>`` (lower case). A ``call``'s
    number may be computed (``o#2 call``, ``o[100+#1] call``): ``label_node`` is its value,
    ``label`` its text."""

    label: str
    keyword: str
    args: tuple[Node, ...]
    col: int
    label_node: Node | None = None


@dataclass(frozen=True)
class Comment:
    """A parenthesised comment: ``kind`` msg, debug or print (else empty), ``text`` after
    the comma, as written."""

    kind: str
    text: str
    col: int


class NgcLine(NamedTuple):
    """One line as read: its words, its parameter settings, its O-word and its comments."""

    words: tuple[Word | WordValue, ...] = ()
    assignments: tuple[Assignment, ...] = ()
    o: OStatement | None = None
    comments: tuple[Comment, ...] = ()

    @property
    def empty(self) -> bool:
        return not (self.words or self.assignments or self.o or self.comments)


def _describe(c: str) -> str:
    name = unicodedata.name(c, "")
    return f"{c!r} (U+{ord(c):04X}{' ' + name if name else ''})"


def _bad(c: str, col: int) -> LexError:
    if c.isspace():
        return LexError(col, f"unexpected white space {_describe(c)}: only spaces and tabs "
                             f"separate words")
    if c.isdigit() or unicodedata.category(c) == "Nd":
        return LexError(col, f"unexpected character {_describe(c)}: numbers take ASCII "
                             f"digits 0-9")
    return LexError(col, f"unexpected character {_describe(c)}")


def _comment(body: str, col: int) -> Comment:
    head, comma, rest = body.partition(",")
    kind = head.strip(_BLANK).lower()
    if comma and kind in ("msg", "debug", "print"):
        return Comment(kind, rest, col)
    return Comment("", body, col)


def _clean(text: str) -> tuple[str, list[int], list[Comment]]:
    """The line without blanks and comments, lower case; the column of each character kept;
    the comments."""
    if text.isascii() and not any(c in text for c in "(;/") and text.translate(
            _NO_BLANKS).isprintable():  # most lines: words and blanks only
        kept = [k for k, c in enumerate(text, 1) if c not in _BLANK]
        return text.translate(_NO_BLANKS).lower(), kept, []
    chars: list[str] = []
    cols: list[int] = []
    comments: list[Comment] = []
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
            comments.append(_comment(text[pos + 1:close], pos + 1))
            pos = close + 1
        elif c.isascii() and c.isprintable():
            chars.append(c.lower())
            cols.append(pos + 1)
            pos += 1
        else:
            raise _bad(c, pos + 1)
    return "".join(chars), cols, comments


class _Reader:
    def __init__(self, text: str):
        self.line, self.cols, self.comments = _clean(text)
        self.end_col = len(text) + 1
        self.i = 0
        self.depth = 0

    def col(self, i: int | None = None) -> int:
        i = self.i if i is None else i
        return self.cols[i] if i < len(self.cols) else self.end_col

    def peek(self, n: int = 0) -> str:
        i = self.i + n
        return self.line[i] if i < len(self.line) else ""

    def expect(self, c: str, what: str) -> None:
        if self.peek() != c:
            found = f"'{self.peek()}'" if self.peek() else "the end of the line"
            raise LexError(self.col(), f"expected {what}, found {found}")
        self.i += 1

    def number(self) -> Number | None:
        m = _NUMBER.match(self.line, self.i)
        if m is None:
            return None
        node = Number(self.col(), m.group())
        self.i = m.end()
        return node

    def letters(self) -> str:
        start = self.i
        while self.peek().isalpha():
            self.i += 1
        return self.line[start:self.i]

    def value(self) -> Node:
        """LinuxCNC's read_real_value."""
        c, col = self.peek(), self.col()
        if c == "[":
            return self.expression()
        if c == "#":
            return self.parameter()
        if c in "+-" and c and self.peek(1) and not self.peek(1).isdigit() and self.peek(1) != ".":
            self.i += 1
            operand = self.nested(self.value)
            return operand if c == "+" else Negate(col, operand)
        if c.isalpha():
            return self.function()
        node = self.number()
        if node is None:
            found = f"'{c}'" if c else "the end of the line"
            raise LexError(col, f"expected a value (a number, #, [ or a function), found "
                                f"{found}")
        return node

    def nested(self, read):
        self.depth += 1
        if self.depth > MAX_NESTING:
            raise LexError(self.col(), f"values nested more than {MAX_NESTING} deep")
        try:
            return read()
        finally:
            self.depth -= 1

    def expression(self) -> Node:
        """``[value {operator value}]`` by LinuxCNC's precedence, each level left to right."""
        self.expect("[", "'['")
        values = [self.nested(self.value)]
        ops: list[tuple[str, int]] = []
        while True:
            op_col = self.col()
            op = self.operator()
            if op == "]":
                break
            while ops and PRECEDENCE[ops[-1][0]] >= PRECEDENCE[op]:
                right = values.pop()
                name, at = ops.pop()
                values.append(Binary(at, name, values.pop(), right))
            ops.append((op, op_col))
            values.append(self.nested(self.value))
        while ops:
            right = values.pop()
            name, at = ops.pop()
            values.append(Binary(at, name, values.pop(), right))
        return values[0]

    def operator(self) -> str:
        c = self.peek()
        if c == "*" and self.peek(1) == "*":
            self.i += 2
            return "**"
        if c and c in "*/+-]":
            self.i += 1
            return c
        col = self.col()
        name = self.letters()
        if name in PRECEDENCE:
            return name
        for op in PRECEDENCE:  # an operator before a function: [1 lt sin[30]]
            if op.isalpha() and name.startswith(op) and name[len(op):] in _FUNCTION_NAMES:
                self.i -= len(name) - len(op)
                return op
        if not c:
            raise LexError(col, "expression not closed: ']' missing")
        raise LexError(col, f"unknown operator '{name or c}' in an expression")

    def function(self) -> Node:
        col = self.col()
        name = self.letters()
        if name not in _FUNCTION_NAMES:
            raise LexError(col, f"unknown function '{name.upper()}'")
        if self.peek() != "[":
            raise LexError(self.col(), f"{name.upper()} takes its argument in brackets")
        if name == "exists":
            self.i += 1
            if self.peek() != "#" or self.peek(1) != "<":
                raise LexError(self.col(), "EXISTS takes a named parameter: EXISTS[#<name>]")
            target = self.parameter()
            self.expect("]", "']' after EXISTS's parameter")
            return Call(col, "exists", (), name=target.name)
        first = self.nested(self.expression)
        if name != "atan":
            return Call(col, name, (first,))
        if self.peek() != "/":
            raise LexError(self.col(), "ATAN takes two values: ATAN[y]/[x]")
        self.i += 1
        return Call(col, "atan", (first, self.nested(self.expression)))

    def parameter(self) -> Named | Numbered:
        col = self.col()
        self.expect("#", "'#'")
        if self.peek() == "<":
            close = self.line.find(">", self.i)
            if close < 0:
                raise LexError(col, "named parameter not closed: '>' missing")
            name = self.line[self.i + 1:close]
            if not name:
                raise LexError(col, "named parameter without a name: #<>")
            self.i = close + 1
            return Named(col, name)
        return Numbered(col, self.nested(self.value))

    def o_statement(self) -> OStatement | None:
        """The line's O-word statement; None for a program number (``O1000``, ``O0000``
        followed by a comment: LinuxCNC and Fanuc controls read the line and do nothing)."""
        col = self.col()
        self.i += 1
        label_node: Node | None = None
        start = self.i
        if self.peek() == "<":
            close = self.line.find(">", self.i)
            if close < 0 or close == self.i + 1:
                raise LexError(col, "O-word name not closed: o<name>")
            label = self.line[self.i:close + 1]
            self.i = close + 1
        elif self.peek() in ("#", "["):
            label_node = self.value()
            label = self.line[start:self.i]
        else:
            m = _O_NUMBER.match(self.line, self.i)
            if m is None:
                raise LexError(col, "an O-word needs a number or a <name>: o100, o<name>")
            label = str(int(m.group()))
            self.i = m.end()
        keyword_col = self.col()
        keyword = self.letters()
        if not keyword and not self.peek():
            return None
        if keyword not in O_KEYWORDS:
            raise LexError(keyword_col, f"unknown O-word keyword '{keyword}' (sub, endsub, "
                                        f"call, return, if, elseif, else, endif, while, "
                                        f"endwhile, do, repeat, endrepeat, break, continue; "
                                        f"o{label} alone on its line is a program number)")
        if label_node is not None and keyword != "call":
            raise LexError(col, f"o{label} {keyword}: only a call takes a computed O-word "
                                f"number")
        if label.startswith("-"):
            raise LexError(col, f"o{label} {keyword}: an O-word number is not negative")
        args = []
        while self.peek() == "[":
            args.append(self.expression())
        least, most = O_KEYWORDS[keyword]
        if self.peek():
            raise LexError(self.col(), f"unexpected '{self.peek()}' after o{label} {keyword}")
        if not least <= len(args) <= most:
            wanted = "no value" if most == 0 else ("one value [..]" if least == most
                                                   else f"at most {most} values [..]")
            raise LexError(keyword_col, f"o{label} {keyword} takes {wanted}")
        return OStatement(label, keyword, tuple(args), col, label_node)

    def line_number(self) -> None:
        """Skips an ``N`` word before an O-word (``N10 o100 sub``)."""
        m = _N_BEFORE_O.match(self.line)
        if m is not None:
            self.i = m.end()

    def read(self) -> NgcLine:
        self.line_number()
        if self.peek() == "o":
            return NgcLine(o=self.o_statement(), comments=tuple(self.comments))
        self.i = 0
        words: list[Word | WordValue] = []
        assignments: list[Assignment] = []
        while self.i < len(self.line):
            c, col = self.peek(), self.col()
            if c == "#":
                target = self.parameter()
                self.expect("=", "'=' after the parameter (a setting: #1 = value)")
                assignments.append(Assignment(target, self.value(), col))
            elif c == "o":
                raise LexError(col, "an O-word must begin its line")
            elif c.isalpha() or c in "@^":
                self.i += 1
                words.append(self.word(c, col))
            else:
                raise _bad(c, col)
        return NgcLine(tuple(words), tuple(assignments), None, tuple(self.comments))

    def word(self, c: str, col: int) -> Word | WordValue:
        letter = c.upper()
        start = self.i
        if self.number() is not None:
            text = self.line[start:self.i]
            return Word(letter, letter + text, Decimal(text), col)
        nxt = self.peek()
        if nxt.isalpha():
            name = self.line[self.i:].split("[", 1)[0]
            if not any(name.startswith(f) and len(name) == len(f) for f in _FUNCTION_NAMES):
                raise LexError(col, f"word {letter} has no number")
        elif nxt not in ("[", "#", "+", "-"):
            raise LexError(col, f"word {letter} has no number")
        try:
            return WordValue(letter, self.value(), col)
        except LexError as e:
            if e.message.startswith("expected a value"):
                raise LexError(col, f"word {letter} has no number") from None
            raise


def read_line(text: str) -> NgcLine:
    """The words, parameter settings, O-word and comments of one line. Raises
    :class:`LexError`."""
    if text.isascii():
        upper = text.upper()
        if _PLAIN_LINE.fullmatch(upper):
            return NgcLine(tuple([Word._make((m[1], m[0], Decimal(m[2]), m.start() + 1))
                                  for m in _PLAIN_WORD.finditer(upper)]))
    try:
        return _Reader(text).read()
    except ExprError as e:  # pragma: no cover - reading builds nodes only
        raise LexError(e.col, e.message) from None
