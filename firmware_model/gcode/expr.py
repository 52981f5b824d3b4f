"""RS-274/NGC expressions: the nodes a line's values are read into, and their evaluation.

A value in a line is a number, a parameter (``#1``, ``##2``, ``#[1+2]``, ``#<name>``), an
expression in brackets, a unary function (``SIN[30]``, ``ATAN[1]/[2]``, ``EXISTS[#<x>]``) or a
sign before one of these; :mod:`k37.firmware_model.gcode.lex` reads it into the nodes below and
:meth:`Node.value` evaluates it, as LinuxCNC's interpreter does:

* binary operators by precedence, each level left to right: ``**``; ``*``, ``/``, ``MOD``;
  ``+``, ``-``; ``EQ NE GT GE LT LE``; ``AND OR XOR`` (``2 ** 3 ** 2`` is 64). ``EQ`` and
  ``NE`` compare within 0.0001 (LinuxCNC's TOLERANCE_EQUAL); ``MOD`` is never negative for a
  positive divisor; logic operators give 1 or 0 (non-zero is true);
* trigonometry in degrees (``ACOS``, ``ASIN``, ``ATAN`` return degrees); ``FIX`` rounds down,
  ``FUP`` up, ``ROUND`` halves away from zero.

Every failure (division by zero, an argument out of a function's domain, an undefined
parameter, a result that is not finite) is an :class:`ExprError` naming the column.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Protocol

__all__ = ["BINARY", "FUNCTIONS", "PRECEDENCE", "Binary", "Call", "DomainError", "ExprError",
           "Named", "Negate", "Node", "Number", "Numbered", "Parameters"]

#: LinuxCNC's fuzz for EQ and NE.
TOLERANCE_EQUAL = 0.0001


class ExprError(ValueError):
    """An expression that cannot be read or evaluated; ``col`` from 1."""

    def __init__(self, col: int, message: str):
        super().__init__(message)
        self.col = col
        self.message = message


class Parameters(Protocol):
    """What an expression reads: numbered and named parameters."""

    def numbered(self, number: int, col: int) -> float: ...

    def named(self, name: str, col: int) -> float: ...

    def exists(self, name: str) -> bool: ...


def finite(value: float, col: int) -> float:
    if math.isnan(value) or math.isinf(value):
        raise ExprError(col, "the value is not a finite number")
    return value


def integer(value: float, col: int, what: str) -> int:
    """A value that must be an integer (within LinuxCNC's 0.0001)."""
    nearest = round(value)
    if abs(value - nearest) >= TOLERANCE_EQUAL:
        raise ExprError(col, f"{what} must be an integer, not {value:g}")
    return int(nearest)


class Node:
    """An expression; ``col``: where it starts in its line."""

    __slots__ = ("col",)

    def __init__(self, col: int):
        self.col = col

    def value(self, params: Parameters) -> float:
        raise NotImplementedError


class Number(Node):
    __slots__ = ("number", "text")

    def __init__(self, col: int, text: str):
        super().__init__(col)
        self.text = text
        self.number = float(text)

    def value(self, params: Parameters) -> float:
        return finite(self.number, self.col)


class Numbered(Node):
    """``#n``: ``index`` is itself a value (``##1``, ``#[1+2]``)."""

    __slots__ = ("index",)

    def __init__(self, col: int, index: Node):
        super().__init__(col)
        self.index = index

    def number(self, params: Parameters) -> int:
        return integer(self.index.value(params), self.col, "a parameter number")

    def value(self, params: Parameters) -> float:
        return params.numbered(self.number(params), self.col)


class Named(Node):
    """``#<name>``: ``name`` lower case, without blanks, as LinuxCNC reads it."""

    __slots__ = ("name",)

    def __init__(self, col: int, name: str):
        super().__init__(col)
        self.name = name

    def value(self, params: Parameters) -> float:
        return params.named(self.name, self.col)


class Negate(Node):
    __slots__ = ("operand",)

    def __init__(self, col: int, operand: Node):
        super().__init__(col)
        self.operand = operand

    def value(self, params: Parameters) -> float:
        return -self.operand.value(params)


class DomainError(ValueError):
    """An operation or function outside its domain (the node adds its column)."""


def _divide(a: float, b: float) -> float:
    if b == 0:
        raise DomainError("division by zero")
    return a / b


def _modulo(a: float, b: float) -> float:
    if b == 0:
        raise DomainError("MOD by zero")
    result = math.fmod(a, b)
    return result + abs(b) if result < 0 else result


def _power(a: float, b: float) -> float:
    if a < 0 and math.floor(b) != b:
        raise DomainError(f"{a:g} ** {b:g}: a negative number to a non-integer power")
    if a == 0 and b < 0:
        raise DomainError("0 to a negative power (division by zero)")
    try:
        return math.pow(a, b)
    except OverflowError:
        raise DomainError(f"{a:g} ** {b:g} is too large") from None


def _truth(x: bool) -> float:
    return 1.0 if x else 0.0


#: The binary operators (as LinuxCNC reads them, lower case) and what they compute.
BINARY: dict[str, Callable[[float, float], float]] = {
    "**": _power,
    "*": lambda a, b: a * b,
    "/": _divide,
    "mod": _modulo,
    "+": lambda a, b: a + b,
    "-": lambda a, b: a - b,
    "eq": lambda a, b: _truth(abs(a - b) < TOLERANCE_EQUAL),
    "ne": lambda a, b: _truth(abs(a - b) >= TOLERANCE_EQUAL),
    "gt": lambda a, b: _truth(a > b),
    "ge": lambda a, b: _truth(a >= b),
    "lt": lambda a, b: _truth(a < b),
    "le": lambda a, b: _truth(a <= b),
    "and": lambda a, b: _truth(a != 0 and b != 0),
    "or": lambda a, b: _truth(a != 0 or b != 0),
    "xor": lambda a, b: _truth((a != 0) != (b != 0)),
}

#: Operator precedence (higher binds tighter), LinuxCNC's.
PRECEDENCE = {"**": 6, "*": 5, "/": 5, "mod": 5, "+": 4, "-": 4,
              **dict.fromkeys(("eq", "ne", "gt", "ge", "lt", "le"), 3),
              **dict.fromkeys(("and", "or", "xor"), 2)}


class Binary(Node):
    __slots__ = ("left", "op", "right")

    def __init__(self, col: int, op: str, left: Node, right: Node):
        super().__init__(col)
        self.op, self.left, self.right = op, left, right

    def value(self, params: Parameters) -> float:
        a = self.left.value(params)
        b = self.right.value(params)
        try:
            return finite(BINARY[self.op](a, b), self.col)
        except DomainError as e:
            raise ExprError(self.col, str(e)) from None


def _domain(name: str, ok: Callable[[float], bool], f: Callable[[float], float],
            why: str) -> Callable[[float], float]:
    def call(x: float) -> float:
        if not ok(x):
            raise DomainError(f"{name}[{x:g}]: {why}")
        return f(x)
    return call


def _round(x: float) -> float:
    return float(math.floor(x + 0.5) if x >= 0 else math.ceil(x - 0.5))


def _exp(x: float) -> float:
    try:
        return math.exp(x)
    except OverflowError:
        raise DomainError(f"EXP[{x:g}] is too large") from None


#: The unary functions (lower case) of one value; ATAN (two) and EXISTS (a name) apart.
FUNCTIONS: dict[str, Callable[[float], float]] = {
    "abs": abs,
    "acos": _domain("ACOS", lambda x: -1 <= x <= 1, lambda x: math.degrees(math.acos(x)),
                    "the argument must be within -1..1"),
    "asin": _domain("ASIN", lambda x: -1 <= x <= 1, lambda x: math.degrees(math.asin(x)),
                    "the argument must be within -1..1"),
    "cos": lambda x: math.cos(math.radians(x)),
    "exp": _exp,
    "fix": lambda x: float(math.floor(x)),
    "fup": lambda x: float(math.ceil(x)),
    "round": _round,
    "ln": _domain("LN", lambda x: x > 0, math.log, "the argument must be positive"),
    "sin": lambda x: math.sin(math.radians(x)),
    "sqrt": _domain("SQRT", lambda x: x >= 0, math.sqrt, "the argument must not be negative"),
    "tan": lambda x: math.tan(math.radians(x)),
}


class Call(Node):
    """A unary function: ``args`` one value, or two for ATAN (``ATAN[y]/[x]``); EXISTS
    has ``name``."""

    __slots__ = ("args", "function", "name")

    def __init__(self, col: int, function: str, args: tuple[Node, ...], name: str = ""):
        super().__init__(col)
        self.function, self.args, self.name = function, args, name

    def value(self, params: Parameters) -> float:
        if self.function == "exists":
            return _truth(params.exists(self.name))
        if self.function == "atan":
            y, x = (a.value(params) for a in self.args)
            return math.degrees(math.atan2(y, x))
        x = self.args[0].value(params)
        try:
            return finite(FUNCTIONS[self.function](x), self.col)
        except DomainError as e:
            raise ExprError(self.col, str(e)) from None
