"""Reference model of :class:`k37.hdl.board.sigma_delta.SigmaDelta`.

A first-order sigma-delta modulator: a ``width``-bit accumulator adds the input word every
cycle, and the carry out of that addition is the output bit of the next cycle. Over cycles
1..T the output is high exactly ``floor(sum of the words / 2**width)`` times (accumulator
cleared at reset), so the pin's mean is ``word / 2**width`` of the supply with no long-term
error, and the bit stream changes as often as the word allows (the noise sits at high
frequencies, where an RC low pass removes it).
"""

from __future__ import annotations

from k37.hdl.common.params import positive_int

__all__ = ["SigmaDeltaModel"]


class SigmaDeltaModel:
    """One modulator: :meth:`step` takes the word of a cycle and returns that cycle's bit."""

    def __init__(self, width: int = 16):
        self.width = positive_int("width", width)
        self.reset()

    def reset(self) -> None:
        self.acc = 0
        self.out = 0

    def step(self, word: int) -> int:
        """The output bit of this cycle; ``word`` (0..2**width - 1) is added at its end."""
        if not 0 <= word < 1 << self.width:
            raise ValueError(f"word must be in 0..{(1 << self.width) - 1}, not {word!r}")
        bit = self.out
        total = self.acc + word
        self.acc, self.out = total & ((1 << self.width) - 1), total >> self.width
        return bit
