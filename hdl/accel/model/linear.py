"""Reference model of :class:`k37.hdl.accel.linear.AccelLinear`: linear accel/decel as a moving
average over the time constant T = 2**n / fa.

The output rate is the input rate averaged over the last T: a step of the input rate comes
out as a ramp of length T (trapezoidal velocity, the filters paper's "linear type"), and a
sinusoidal rate is scaled by ``sin(w T / 2) / (w T / 2)`` (the motion-errors paper's radius loss
``T^2 V^2 / (24 R)``).

The circuit: input pulses are counted in the open *bin*; every ``2**(n - bins_bits)``
additions the bin closes into a shift register of ``2**bins_bits`` bins, whose sum is the
window count ``x`` (the oldest bin leaves as the new one enters). On each addition the
accumulator becomes ``y <- (y + x) mod 2**n`` and its carry is owed as output pulses, sent one
per cycle from a pending counter, as in the exponential circuit. Every input pulse sits in
``x`` for exactly ``2**bins_bits`` bins of ``2**(n - bins_bits)`` additions, i.e. ``2**n``
additions, so it adds exactly ``2**n`` to the accumulator: one output pulse. No pulse is lost:
``inputs = outputs + open + bins + pending`` at every cycle, where ``bins`` counts the pulses
still in the shift register, and when the circuit has drained ``y`` is back where it began.

The bin timer runs only while the circuit holds pulses (the open bin or a live bin): a drained
circuit is static, and the first pulse into it starts a fresh bin.

Bidirectional (post-interpolation) use: counts are signed; the carry is the floor of
``(y + x) / 2**n`` and an output pulse carries pending's sign.
"""

from __future__ import annotations

from k37.hdl.accel.model.exponential import check_inp, check_params, sign, wrap
from k37.hdl.common.params import positive_int

__all__ = ["AccelLinearModel", "check_bins"]


def check_bins(n: int, bins_bits: int) -> None:
    """Refuse a bin count the window cannot have: ``0 <= bins_bits <= n``."""
    positive_int("bins_bits", bins_bits, 0)
    if bins_bits > n:
        raise ValueError(f"bins_bits must be at most n = {n}, not {bins_bits!r}")


class AccelLinearModel:
    """Cycle model. :meth:`step` returns the output of the current cycle, then clocks.

    Inputs and outputs are net pulses: 1 (or 0) unidirectional; +1, 0, -1 bidirectional.
    ``bins`` lists the closed bins, oldest first.
    """

    def __init__(self, n: int = 15, counter_width: int = 24, bidirectional: bool = False,
                 bins_bits: int = 4):
        check_params(n, counter_width, bidirectional)
        check_bins(n, bins_bits)
        self.n = n
        self.counter_width = counter_width
        self.bidirectional = bidirectional
        self.bins_bits = bins_bits
        self.x = 0
        self.y = 0
        self.pending = 0
        self.open = 0
        self.tick = 0
        self.live = 0
        self.bins = [0] * (1 << bins_bits)

    @property
    def active(self) -> bool:
        """The circuit holds pulses (open bin or a live bin): its bin timer runs."""
        return self.open != 0 or self.live != 0

    @property
    def idle(self) -> bool:
        """Drained and static: nothing held, nothing owed (y may keep a residue)."""
        return not self.active and self.pending == 0

    def _wrap(self, v: int) -> int:
        return wrap(v, self.counter_width, self.bidirectional)

    def step(self, inp: int, add: bool) -> int:
        """One cycle with input pulse ``inp`` and addition clock ``add``; returns the output."""
        check_inp(inp, self.bidirectional)
        out = sign(self.pending)
        carry = 0
        if add:
            total = self.y + self.x
            carry = total >> self.n
            self.y = total & ((1 << self.n) - 1)
            if self.active:
                if self.tick == (1 << (self.n - self.bins_bits)) - 1:
                    oldest = self.bins.pop(0)
                    self.bins.append(self.open)
                    self.x = self._wrap(self.x + self.open - oldest)
                    self.live = len(self.bins) if self.open != 0 else self.live - 1
                    self.open = 0
                    self.tick = 0
                else:
                    self.tick += 1
        self.open = self._wrap(self.open + inp)
        self.pending = self._wrap(self.pending - out + carry)
        return out
