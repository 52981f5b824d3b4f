"""Reference model of :mod:`k37.hdl.k3701.datapaths.helix`: a helix's third axis, a DDA on the arc's
own steps (:class:`HelixPath`)."""

from __future__ import annotations

from k37.hdl.k3701.block import BlockError, check_coord
from k37.hdl.k3701.datapaths.model.linear import Dda

__all__ = ["HelixPath"]

class HelixPath:
    """A helix's third axis: ``ze`` moves spread over the arc's ``n`` steps (a DDA on the arc's
    steps, so it ends exactly with the arc). Needs |ze| <= n: at most one move per step."""

    def __init__(self, ze: int, n: int):
        check_coord("Ze", ze)
        if abs(ze) > n:
            raise BlockError(f"the helix's third axis moves {abs(ze)} LSB in {n} arc steps: "
                             f"more than one per step")
        self.sign = (ze > 0) - (ze < 0)
        self.dda = Dda(abs(ze), n)

    def peek(self) -> int:
        return self.sign if self.dda.peek() else 0

    def advance(self) -> int:
        return self.sign if self.dda.advance() else 0
