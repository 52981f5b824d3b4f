"""Parameter checks and limits, each limit defined once by the block that has it.

A :class:`Limit` is the range a parameter must lie in, with its unit. The block checks its
own constructor's arguments with it, and the job loader checks the job's keys with the same
object, so both refuse the same values in the same words: ``accel_bits must be in 4..24, not
2``, ``kp must be > 0 and < 1000000 1/s (32-bit gain at clock_hz), not 2000000.0``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

__all__ = ["Limit", "positive_int"]


def _text(bound: float) -> str:
    """A bound as a person would write it: 1000000 rather than 1e+06."""
    if float(bound).is_integer() and abs(bound) < 1e16:
        return str(int(bound))
    return f"{bound:.10g}"


@dataclass(frozen=True)
class Limit:
    """A number's range: ``low`` and ``high`` (None: unbounded), each inclusive unless open.

    ``integer``: only integers (a float with an integral value is taken as one). ``unit``
    follows the bounds in messages; ``note`` says what they follow from (e.g. ``clock_hz``).
    """

    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    integer: bool = False
    unit: str = ""
    note: str = ""

    def __contains__(self, value: float) -> bool:
        above = self.low is None or (value > self.low if self.low_open else value >= self.low)
        below = self.high is None or (value < self.high if self.high_open else value <= self.high)
        return above and below

    def describe(self) -> str:
        """The range in words: ``in 8..16``, ``> 0 and < 1000000 1/s (clock_hz)``."""
        closed = not (self.low_open or self.high_open)
        if self.integer and closed and self.low is not None and self.high is not None:
            text = f"in {_text(self.low)}..{_text(self.high)}"
        else:
            parts = []
            if self.low is not None:
                parts.append(f"{'>' if self.low_open else '>='} {_text(self.low)}")
            if self.high is not None:
                parts.append(f"{'<' if self.high_open else '<='} {_text(self.high)}")
            text = " and ".join(parts) or ("an integer" if self.integer else "a number")
        if self.unit:
            text += f" {self.unit}"
        return f"{text} ({self.note})" if self.note else text

    def check(self, name: str, value: object) -> int | float:
        """``value`` if it lies in the range (an int if ``integer``, else a float).

        Raises
        ------
        TypeError
            ``value`` is not a number (or not an integer), naming ``name``.
        ValueError
            ``value`` is not finite or out of range, naming ``name`` and the range.
        """
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            kind = "an integer" if self.integer else "a number"
            raise TypeError(f"{name} must be {kind}, not {value!r}")
        if not math.isfinite(value):
            raise ValueError(f"{name} must be finite, not {value!r}")
        if self.integer and not float(value).is_integer():
            raise TypeError(f"{name} must be an integer, not {value!r}")
        if value not in self:
            raise ValueError(f"{name} must be {self.describe()}, not {value!r}")
        return int(value) if self.integer else float(value)

    def scaled(self, factor: float, unit: str, note: str | None = None) -> Limit:
        """The same range in another unit, ``factor`` of it per unit of this one (and another
        ``note``, if given)."""
        return replace(self, unit=unit, note=self.note if note is None else note,
                       low=None if self.low is None else self.low * factor,
                       high=None if self.high is None else self.high * factor)


def positive_int(name: str, value: object, minimum: int = 1) -> int:
    """Return ``value`` if it is an integer >= ``minimum``; else raise naming ``name``."""
    if not isinstance(value, int) or isinstance(value, bool):
        raise TypeError(f"{name} must be an integer, not {value!r}")
    if value < minimum:
        raise ValueError(f"{name} must be at least {minimum}, not {value!r}")
    return value
