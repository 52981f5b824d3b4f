"""Reference model of :class:`k37.hdl.feed.decel_control.DecelControl`, the FP budget gate
(``docs/chips/decel.md``).

The host loads the number of feed pulses a block needs; input pulses pass and count the
remaining budget down until it is 0, then the gate is closed (spent) and the accel/decel
circuit behind it drains, so the interpolator gets exactly the loaded count. The host can also
hold the gate closed at once (stop feed) and open it again; the budget is kept meanwhile.
"""

from __future__ import annotations

import numpy as np

from k37.hdl.feed.rates import BUDGET_WIDTH

__all__ = ["DecelControlModel"]


class DecelControlModel:
    """Cycle model at the register ports: :meth:`step` returns ``out``, then clocks.

    ``hold`` is the CTRL hold bit as the chip sees it in the current cycle.
    """

    def __init__(self):
        self.remaining = 0
        self.hold = False

    @property
    def spent(self) -> bool:
        return self.remaining == 0

    def step(self, inp: bool, load: int | None = None) -> bool:
        """One cycle; ``load`` is a budget whose commit is seen in this cycle (BUDGET w_stb).

        A load takes effect in its own cycle: a pulse of that cycle counts against it.
        """
        if load is not None:
            if not 0 <= load < (1 << BUDGET_WIDTH):
                raise ValueError(f"budget must be in 0..2**{BUDGET_WIDTH}-1, not {load!r}")
            self.remaining = load
        passed = bool(inp) and not self.hold and self.remaining > 0
        self.remaining -= passed
        return passed

    def run(self, inp: np.ndarray) -> np.ndarray:
        """Many cycles without loads or hold changes, equal to calling :meth:`step` per cycle."""
        inp = np.asarray(inp, dtype=bool)
        if self.hold:
            return np.zeros_like(inp)
        out = inp & (np.cumsum(inp, dtype=np.int64) <= self.remaining)
        self.remaining -= int(np.count_nonzero(out))
        return out
