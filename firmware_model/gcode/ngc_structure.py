"""The O-word structure of an RS-274/NGC program, read before it runs: subroutines, loops and
conditionals as a tree of :class:`Structure` nodes, each unclosed or misplaced statement an
:class:`NgcError` (:mod:`k37.firmware_model.gcode.ngc` runs the tree)."""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from k37.firmware_model.gcode.lex import LexError, NgcLine, OStatement

__all__ = ["MAX_STRUCTURE_DEPTH", "Builder", "NgcError", "Structure", "Sub", "o_name"]

#: Most nested O-word structures in the source.
MAX_STRUCTURE_DEPTH = 64
#: A line that is an O-word statement (whether or not it reads).
_O_LINE = re.compile(r"[ \t]*(/[ \t]*)?([nN][0-9. \t]*)?[oO]")


class NgcError(Exception):
    """An error that stops the program: (line, col, message)."""

    def __init__(self, line: int, col: int, message: str):
        super().__init__(message)
        self.line, self.col, self.message = line, col, message


@dataclass
class Structure:
    """One node of the program's tree: a line of words, a control statement or a structure
    with its body."""

    line: int  # index into the lines
    kind: str  # "line", a control keyword (call, return, break, continue) or a structure
    label: str = ""
    body: list[Structure] = field(default_factory=list)
    branches: list[tuple[int, list[Structure]]] = field(default_factory=list)  # if/elseif
    end: int = 0  # the closing line (do: its while)


@dataclass
class Sub:
    """A subroutine: its ``sub`` line, its body and its ``endsub`` line."""

    line: int
    body: list[Structure]
    end: int


_OPENERS = {"while": "endwhile", "repeat": "endrepeat", "if": "endif", "else": "endif",
            "do": "while", "sub": "endsub"}
_CLOSERS = {"endwhile", "endrepeat", "endif", "endsub", "elseif", "else"}


def o_name(label: str) -> str:
    """An O-word's name as messages write it (``o100``, ``o<name>``)."""
    return f"o{label}"


class Builder:
    """Reads the lines into the main program's :class:`Structure` nodes (:meth:`body` from
    the first line) and the subroutines (``subs``), checking that every structure closes."""

    def __init__(self, lines: list[NgcLine | LexError], texts: list[str]):
        self.lines = lines
        self.texts = texts
        self.subs: dict[str, Sub] = {}
        self.i = 0

    def o(self, i: int) -> OStatement | None:
        line = self.lines[i]
        return line.o if isinstance(line, NgcLine) else None

    def fail(self, i: int, message: str, col: int = 1) -> NgcError:
        return NgcError(i + 1, col, message)

    def body(self, opener: OStatement | None, depth: int, loops: tuple[str, ...],
             in_sub: bool, opened: int = 0) -> list[Structure]:
        """Nodes up to the statement closing ``opener`` (left at self.i) or the end."""
        if depth > MAX_STRUCTURE_DEPTH:
            raise self.fail(self.i, f"O-word structures nested more than "
                                    f"{MAX_STRUCTURE_DEPTH} deep")
        nodes: list[Structure] = []
        while self.i < len(self.lines):
            o = self.o(self.i)
            line = self.lines[self.i]
            if isinstance(line, LexError) and _O_LINE.match(self.texts[self.i]):
                raise self.fail(self.i, line.message, line.col)
            if o is None:
                nodes.append(Structure(self.i, "line"))
                self.i += 1
                continue
            k = o.keyword
            if k in _CLOSERS or (k == "while" and opener is not None
                                 and opener.keyword == "do" and o.label == opener.label):
                if opener is None or o.label != opener.label or not self.closes(opener, k):
                    what = (f"does not close {o_name(opener.label)} {opener.keyword}"
                            if opener is not None else "has no opening statement")
                    raise self.fail(self.i, f"{o_name(o.label)} {k} {what}", o.col)
                return nodes
            nodes.append(self.statement(o, depth, loops, in_sub))
        if opener is not None:
            raise self.fail(opened, f"{o_name(opener.label)} {opener.keyword} is not "
                                        f"closed: {o_name(opener.label)} {_OPENERS[opener.keyword]}"
                                        f" missing")
        return nodes

    @staticmethod
    def closes(opener: OStatement, keyword: str) -> bool:
        if opener.keyword == "if":
            return keyword in ("elseif", "else", "endif")
        return _OPENERS[opener.keyword] == keyword

    def statement(self, o: OStatement, depth: int, loops: tuple[str, ...],
                  in_sub: bool) -> Structure:
        start = self.i
        self.i += 1
        k = o.keyword
        if k in ("call", "return", "break", "continue"):
            if k in ("break", "continue") and o.label not in loops:
                raise self.fail(start, f"{o_name(o.label)} {k} is not inside an "
                                       f"{o_name(o.label)} loop", o.col)
            if k == "return" and not in_sub:
                raise self.fail(start, f"{o_name(o.label)} return outside a subroutine", o.col)
            return Structure(start, k, o.label)
        if k == "sub":
            if depth > 0 or in_sub:
                raise self.fail(start, f"{o_name(o.label)} sub inside another structure: "
                                       f"subroutines are defined at the top level", o.col)
            body = self.body(o, depth + 1, (), True, start)
            if o.label in self.subs:
                raise self.fail(start, f"{o_name(o.label)} sub is defined twice (first at "
                                       f"line {self.subs[o.label].line + 1})", o.col)
            self.subs[o.label] = Sub(start, body, self.i)
            self.i += 1
            return Structure(start, "sub", o.label)
        inner = (*loops, o.label) if k in ("while", "do", "repeat") else loops
        node = Structure(start, k, o.label)
        if k == "if":
            cond = start
            while True:
                branch = self.body(o, depth + 1, inner, in_sub, start)
                closing = self.o(self.i)
                assert closing is not None
                node.branches.append((cond, branch))
                cond = self.i
                self.i += 1
                if closing.keyword == "endif":
                    break
                if closing.keyword == "else":
                    node.body = self.body(OStatement(o.label, "else", (), o.col), depth + 1,
                                          inner, in_sub, start)
                    closing = self.o(self.i)
                    if closing is None or closing.keyword != "endif":
                        raise self.fail(self.i, f"{o_name(o.label)} if: only endif may follow "
                                                f"its else")
                    self.i += 1
                    break
            node.end = self.i - 1
            return node
        node.body = self.body(o, depth + 1, inner, in_sub, start)
        node.end = self.i
        self.i += 1
        return node
