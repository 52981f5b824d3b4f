"""Reference model of :class:`k37.hdl.accel.exponential.AccelDecel` (``docs/chips/accel.md``).

The circuit of the filters paper's Fig. 2 (the system paper's circuit): input pulses count
the up/down counter x up; on each addition pulse the accumulator becomes ``y <- (y + x) mod
2**n`` and its carry ``c = (y + x) >> n`` is subtracted from x and owed as c output pulses,
which leave one per cycle from a pending-output counter. With additions at rate fa the
output rate follows ``fi (1 - exp(-t / tau))``, ``tau = 2**n / fa``, and decays with the
same tau when the input stops; no pulse is lost: inputs = outputs + x + pending at every
cycle.

Bidirectional (post-interpolation) use: x and pending are signed; the carry is the floor of
``(y + x) / 2**n`` (a borrow when x is negative) and an output pulse carries pending's sign.
"""

from __future__ import annotations

import numpy as np

from k37.hdl.common.params import positive_int

__all__ = ["AccelDecelModel", "check_inp", "check_params", "sign", "wrap"]


def check_params(n: int, counter_width: int, bidirectional: bool) -> None:
    """Refuse parameters the circuit cannot have, naming the bad one."""
    positive_int("n", n)
    positive_int("counter_width", counter_width, 2)
    if not isinstance(bidirectional, bool):
        raise TypeError(f"bidirectional must be a bool, not {bidirectional!r}")


def check_inp(inp: int, bidirectional: bool) -> None:
    """Refuse an input pulse the circuit cannot take: 0 or 1, or -1, 0, 1 bidirectional."""
    allowed = (-1, 0, 1) if bidirectional else (0, 1)
    if inp not in allowed:
        raise ValueError(f"inp must be one of {allowed}, not {inp!r}")


def sign(v: int) -> int:
    """-1, 0 or 1: the net output pulse a pending count sends."""
    return (v > 0) - (v < 0)


def wrap(v: int, width: int, signed: bool) -> int:
    """Counter arithmetic: ``width`` bits, two's complement when ``signed``."""
    v &= (1 << width) - 1
    if signed and v >> (width - 1):
        v -= 1 << width
    return v


class AccelDecelModel:
    """Cycle model. :meth:`step` returns the output of the current cycle, then clocks.

    Inputs and outputs are net pulses: 1 (or 0) unidirectional; +1, 0, -1 bidirectional
    (``inp_pos - inp_neg`` and ``out_pos - out_neg``).
    """

    def __init__(self, n: int = 15, counter_width: int = 24, bidirectional: bool = False):
        check_params(n, counter_width, bidirectional)
        self.n = n
        self.counter_width = counter_width
        self.bidirectional = bidirectional
        self.x = 0
        self.y = 0
        self.pending = 0

    @property
    def idle(self) -> bool:
        """Drained: nothing counted and nothing owed (y may keep a residue)."""
        return self.x == 0 and self.pending == 0

    def _wrap(self, v: int) -> int:
        return wrap(v, self.counter_width, self.bidirectional)

    def _check_inp(self, inp: int) -> None:
        check_inp(inp, self.bidirectional)

    def _add(self) -> int:
        """The addition: returns the carry, y and x updated (x without this cycle's input)."""
        total = self.y + self.x
        carry = total >> self.n
        self.y = total & ((1 << self.n) - 1)
        self.x -= carry
        return carry

    def step(self, inp: int, add: bool) -> int:
        """One cycle with input pulse ``inp`` and addition clock ``add``; returns the output."""
        self._check_inp(inp)
        out = sign(self.pending)
        carry = self._add() if add else 0
        self.x = self._wrap(self.x + inp)
        self.pending = self._wrap(self.pending - out + carry)
        return out

    def run(self, inp: np.ndarray, add: np.ndarray) -> np.ndarray:
        """Many cycles at once, equal to calling :meth:`step` per cycle (int8 outputs).

        Works from one addition to the next: between additions x only counts inputs and the
        pending pulses leave one per cycle, so only the addition cycles need arithmetic.
        """
        inp = np.asarray(inp, dtype=np.int8)
        add = np.asarray(add, dtype=bool)
        if inp.shape != add.shape or inp.ndim != 1:
            raise ValueError("inp and add must be 1-D arrays of the same length")
        for value in np.unique(inp):
            self._check_inp(int(value))
        cycles = len(inp)
        out = np.zeros(cycles, dtype=np.int8)
        counted = np.concatenate(([0], np.cumsum(inp, dtype=np.int64)))
        t = 0
        for ta in [*np.flatnonzero(add).tolist(), cycles]:
            # Cycles t..ta: pending pulses leave (the addition cycle still sends an old one).
            last = min(ta + 1, cycles)
            direction = sign(self.pending)
            k = min(abs(self.pending), last - t)
            out[t:t + k] = direction
            self.pending -= direction * k
            if ta == cycles:
                self.x = self._wrap(self.x + int(counted[cycles] - counted[t]))
                break
            self.x = self._wrap(self.x + int(counted[ta] - counted[t]))
            carry = self._add()
            self.x = self._wrap(self.x + int(inp[ta]))
            self.pending = self._wrap(self.pending + carry)
            t = ta + 1
        return out
