"""The RS-274/NGC language: parameters, O-word subroutines and loops, messages.

:func:`run` executes a program's lines as LinuxCNC's interpreter does and hands each line's
words, evaluated, to a :class:`Host` (the modal interpreter of
:mod:`k37.firmware_model.gcode.parser`), each word keeping its line and column:

* numbered parameters ``#1``-``#5000`` (zero until set), named ``#<x>`` (local to the
  subroutine call or the main program) and ``#<_x>`` (global); reading a named parameter
  never set is an error. The predefined parameters the host knows (``#5220``, ``#5420``,
  ``#<_x>``...) are read-only. The settings of a line take effect after the whole line is
  read, before its words act (``#1 = 2 #2 = #1`` sets #2 to #1's old value);
* O-words: ``sub``/``endsub``/``call`` (arguments to ``#1``-``#30``, which are the caller's
  again after the call; a subroutine anywhere in the file), ``return`` and ``endsub`` with
  a value to ``#<_value>``, ``while``/``endwhile``, ``do``/``while``, ``repeat``/
  ``endrepeat``, ``if``/``elseif``/``else``/``endif``, ``break``/``continue``; numbered
  (``o100``) and named (``o<name>``);
* ``(MSG,...)`` and ``(DEBUG,...)`` (``#`` parameters in DEBUG and PRINT replaced by their
  values, ``######`` if unset) are program events.

Bounds: at most :data:`MAX_BLOCKS` lines executed in one program and :data:`MAX_CALL_DEPTH`
nested calls; beyond, a clear error at the line. Errors in a line's values are reported
and the line skipped; an error in the program's structure or its control flow stops it. The
structure (subroutines, loops, conditionals) is read before the program runs, by
:mod:`k37.firmware_model.gcode.ngc_structure`.
"""

from __future__ import annotations

import contextlib
import re
from dataclasses import replace
from decimal import Decimal
from typing import Protocol

from k37.firmware_model.gcode.expr import ExprError, Named, Node, Numbered, finite
from k37.firmware_model.gcode.lex import LexError, NgcLine, OStatement, Word, WordValue, read_line
from k37.firmware_model.gcode.ngc_structure import Builder, NgcError, Structure, Sub, o_name

__all__ = ["MAX_BLOCKS", "MAX_CALL_DEPTH", "MAX_PARAMETER", "Host", "run"]

#: Most lines executed in one program (loops and calls counted each time).
MAX_BLOCKS = 1_000_000
#: Most nested subroutine calls.
MAX_CALL_DEPTH = 64
#: Most nested calls and structures being executed at once.
MAX_NESTING = 200
#: Highest numbered parameter a program sets (#5001 up are the interpreter's).
MAX_PARAMETER = 5000
#: Lines that are a controller's own command, not G-code (grbl's ``$`` and ``?``).
CONTROLLER_LINES = ("$", "?")


class Host(Protocol):
    """What runs the evaluated lines: the modal interpreter."""

    ended: bool

    def execute(self, line: int, words: list[Word]) -> None:
        """Run one line's words (reporting its own errors through :meth:`error`)."""

    def error(self, line: int, col: int, message: str) -> None:
        """Report an error; the program goes on (the host may stop it by raising)."""

    def note(self, line: int, text: str) -> None: ...

    def message(self, line: int, kind: str, text: str) -> None: ...

    def predefined(self, key: int | str, col: int) -> float | None:
        """A predefined parameter's value; None: not predefined; raises
        :class:`~k37.firmware_model.gcode.expr.ExprError` for one that is unsupported."""

    def enter_call(self) -> None:
        """A subroutine call begins (its context for M70-M73)."""

    def leave_call(self) -> None:
        """The subroutine called last returns."""


# -- parameters --------------------------------------------------------------------------------

class _Parameters:
    """Numbered, named local (a stack of scopes) and global parameters."""

    def __init__(self, host: Host):
        self.host = host
        self.numbers: dict[int, float] = {}
        self.scopes: list[dict[str, float]] = [{}]
        self.globals: dict[str, float] = {"_value": 0.0, "_value_returned": 0.0}
        self.depth = 0  # nested calls

    def numbered(self, number: int, col: int) -> float:
        if not 1 <= number <= MAX_PARAMETER:
            value = self.host.predefined(number, col) if number > MAX_PARAMETER else None
            if value is None:
                raise ExprError(col, f"parameter #{number} is out of range "
                                     f"(#1-#{MAX_PARAMETER}, and the interpreter's)")
            return value
        return self.numbers.get(number, 0.0)

    def named(self, name: str, col: int) -> float:
        if name.startswith("_"):
            if name in self.globals:
                return self.globals[name]
            if name == "_call_level":
                return float(self.depth)
            value = self.host.predefined(name, col)
            if value is not None:
                return value
        elif name in self.scopes[-1]:
            return self.scopes[-1][name]
        raise ExprError(col, f"parameter #<{name}> is not set")

    def exists(self, name: str) -> bool:
        if name.startswith("_"):
            if name in self.globals:
                return True
            try:
                return self.host.predefined(name, 1) is not None
            except ExprError:
                return False
        return name in self.scopes[-1]

    def set(self, target: Numbered | Named, value: float) -> None:
        if isinstance(target, Named):
            name = target.name
            if name.startswith("_"):
                if name not in self.globals and (name == "_call_level"
                                                 or _is_predefined(self.host, name)):
                    raise ExprError(target.col, f"#<{name}> is the interpreter's: it cannot "
                                                f"be set")
                self.globals[name] = value
            else:
                self.scopes[-1][name] = value
            return
        number = target.number(self)
        if not 1 <= number <= MAX_PARAMETER:
            if _is_predefined(self.host, number):
                raise ExprError(target.col, f"#{number} is the interpreter's: setting it "
                                            f"(offsets, tool data) is unsupported")
            raise ExprError(target.col, f"parameter #{number} is out of range "
                                        f"(#1-#{MAX_PARAMETER})")
        self.numbers[number] = value


def _is_predefined(host: Host, key: int | str) -> bool:
    try:
        return host.predefined(key, 1) is not None
    except ExprError:
        return True


# -- execution ---------------------------------------------------------------------------------

class _Return(Exception):  # noqa: N818 - a subroutine's return, not an error
    def __init__(self, value: float | None):
        self.value = value


class _Jump(Exception):  # noqa: N818 - break and continue
    def __init__(self, label: str, kind: str):
        self.label, self.kind = label, kind


class _End(Exception):  # noqa: N818 - the program's end (M02/M30)
    pass


_DEBUG_PARAMETER = re.compile(r"#<([^>]*)>|#([0-9]+)")


class _Runner:
    def __init__(self, texts: list[str], host: Host):
        self.texts = texts
        self.host = host
        self.lines: list[NgcLine | LexError] = []
        for text in texts:
            try:
                self.lines.append(read_line(text) if self.is_gcode(text) else NgcLine())
            except LexError as e:
                self.lines.append(e)
        self.params = _Parameters(host)
        self.blocks = 0
        self.nesting = 0
        self.subs: dict[str, Sub] = {}

    @staticmethod
    def is_gcode(text: str) -> bool:
        stripped = text.strip(" \t\r")
        return stripped != "%" and not stripped.startswith(CONTROLLER_LINES)

    def run(self) -> None:
        builder = Builder(self.lines, self.texts)
        body = builder.body(None, 0, (), False)
        self.subs = builder.subs
        with contextlib.suppress(_End):
            self.body(body)

    def count(self, i: int) -> None:
        self.blocks += 1
        if self.blocks > MAX_BLOCKS:
            raise NgcError(i + 1, 1, f"more than {MAX_BLOCKS:,} lines executed (loops and "
                                     f"calls counted each time): the program is stopped "
                                     f"here (a loop that never ends?)")

    def value(self, i: int, node: Node) -> float:
        try:
            return node.value(self.params)
        except ExprError as e:
            raise NgcError(i + 1, e.col, e.message) from None

    def condition(self, i: int) -> bool:
        line = self.lines[i]
        assert isinstance(line, NgcLine) and line.o is not None
        return self.value(i, line.o.args[0]) != 0

    def body(self, nodes: list[Structure]) -> None:
        self.nesting += 1
        try:
            for node in nodes:
                self.node(node)
        finally:
            self.nesting -= 1

    def node(self, node: Structure) -> None:
        if self.nesting > MAX_NESTING:
            raise NgcError(node.line + 1, 1, f"calls and O-word structures nested more than "
                                             f"{MAX_NESTING} deep")
        self.count(node.line)
        kind = node.kind
        if kind == "line":
            self.line(node.line)
        elif kind == "sub":
            return
        elif kind == "if":
            for cond, branch in node.branches:
                if self.condition(cond):
                    self.body(branch)
                    break
            else:
                self.body(node.body)
        elif kind in ("while", "do", "repeat"):
            self.loop(node)
        elif kind == "call":
            self.call(node.line)
        elif kind == "return":
            o = self.statement(node.line)
            raise _Return(self.value(node.line, o.args[0]) if o.args else None)
        else:  # break, continue
            raise _Jump(node.label, kind)

    def statement(self, i: int) -> OStatement:
        line = self.lines[i]
        assert isinstance(line, NgcLine) and line.o is not None
        return line.o

    def loop(self, node: Structure) -> None:
        times = 0
        if node.kind == "repeat":
            times = int(self.value(node.line, self.statement(node.line).args[0]))
        while True:
            if node.kind == "while" and not self.condition(node.line):
                return
            if node.kind == "repeat":
                if times <= 0:
                    return
                times -= 1
            try:
                self.body(node.body)
            except _Jump as jump:
                if jump.label != node.label:
                    raise
                if jump.kind == "break":
                    return
            self.count(node.end)
            if node.kind == "do" and not self.condition(node.end):
                return

    def call(self, i: int) -> None:
        o = self.statement(i)
        if o.label_node is not None:
            number = self.value(i, o.label_node)
            if number != int(number) or number < 0:
                raise NgcError(i + 1, o.col, f"o{o.label} call: the O-word number "
                                             f"{_shown(number)} is not a whole number >= 0")
            o = replace(o, label=str(int(number)), label_node=None)
        sub = self.subs.get(o.label)
        if sub is None:
            raise NgcError(i + 1, o.col, f"{o_name(o.label)} call: the program has no "
                                         f"{o_name(o.label)} sub (subroutine files are not "
                                         f"searched)")
        if self.params.depth >= MAX_CALL_DEPTH:
            raise NgcError(i + 1, o.col, f"{o_name(o.label)} call: more than {MAX_CALL_DEPTH} "
                                         f"nested calls (a recursion that never ends?)")
        args = [self.value(i, a) for a in o.args]
        saved = {n: self.params.numbers.pop(n) for n in range(1, 31) if n in self.params.numbers}
        self.params.numbers.update({n + 1: v for n, v in enumerate(args)})
        self.params.scopes.append({})
        self.params.depth += 1
        self.host.enter_call()
        value: float | None = None
        try:
            self.body(sub.body)
            end = self.statement(sub.end)
            self.count(sub.end)
            value = self.value(sub.end, end.args[0]) if end.args else None
        except _Return as r:
            value = r.value
        except _Jump as jump:
            raise NgcError(i + 1, o.col, f"o{jump.label} {jump.kind} leaves the "
                                         f"subroutine") from None
        finally:
            self.host.leave_call()
            self.params.depth -= 1
            self.params.scopes.pop()
            for n in range(1, 31):
                self.params.numbers.pop(n, None)
            self.params.numbers.update(saved)
        self.params.globals["_value"] = 0.0 if value is None else value
        self.params.globals["_value_returned"] = 0.0 if value is None else 1.0

    def line(self, i: int) -> None:
        line = self.lines[i]
        stripped = self.texts[i].strip(" \t\r")
        if stripped.startswith(CONTROLLER_LINES):
            self.host.note(i + 1, f"{stripped[:1]!r} line (a controller's own command, as "
                                  f"grbl's settings and status): ignored")
            return
        if isinstance(line, LexError):
            self.host.error(i + 1, line.col, line.message)
            return
        if line.empty:
            return
        try:
            words = [w if type(w) is Word else self.word(w) for w in line.words]
            settings = [(a.target, finite(a.node.value(self.params), a.col))
                        for a in line.assignments]
            for target, value in settings:
                self.params.set(target, value)
        except ExprError as e:
            self.host.error(i + 1, e.col, e.message)
            return
        for comment in line.comments:
            if comment.kind == "msg":
                self.host.message(i + 1, "message", comment.text)
            elif comment.kind:
                self.host.message(i + 1, comment.kind, self.substitute(comment.text))
        if words:
            self.host.execute(i + 1, words)
            if self.host.ended:
                self.end_note(i)
                raise _End

    def word(self, w: WordValue) -> Word:
        """A word's value evaluated."""
        letter, node, col = w
        value = finite(node.value(self.params), col)
        if letter in "GM" and abs(value * 10 - round(value * 10)) < 1e-3:
            number = Decimal(round(value * 10)) / 10
        else:
            number = Decimal(repr(value))
        return Word(letter, letter + _shown(value), number, col)

    def substitute(self, text: str) -> str:
        def one(m: re.Match) -> str:
            try:
                if m.group(1) is not None:
                    value = self.params.named(m.group(1).lower().replace(" ", ""), 1)
                else:
                    value = self.params.numbered(int(m.group(2)), 1)
            except ExprError:
                return "######"
            return f"{value:f}"
        return _DEBUG_PARAMETER.sub(one, text)

    def end_note(self, i: int) -> None:
        for j in range(i + 1, len(self.texts)):
            stripped = self.texts[j].strip(" \t\r")
            if stripped and not stripped.startswith(("(", ";", "%")):
                # LinuxCNC stops at the program end; a file of several jobs runs the first
                self.host.note(j + 1, "the program ended (M02/M30) before this line: the "
                                      "rest of the file is ignored")
                return


def _shown(value: float) -> str:
    """A computed value as a word shows it (``X12.5``)."""
    if abs(value) >= 1e9:
        return f"{value:.6g}"
    text = f"{value:.6f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def run(texts: list[str], host: Host) -> None:
    """Execute a program's lines (``texts``, line 1 first) on ``host``. Raises
    :class:`~k37.firmware_model.gcode.ngc_structure.NgcError` for an error that stops the
    program; other errors go to ``host.error``. ``$``/``?`` lines are notes, ``%`` lines are
    skipped."""
    _Runner(texts, host).run()
