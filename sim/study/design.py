"""Experimental designs: which combinations of factor levels a study runs.

* ``grid``: every combination (full factorial).
* Orthogonal arrays ``L4``, ``L8``, ``L9``, ``L16``, ``L27`` (Taguchi's names): ``L<n>`` has
  n runs; in every pair of its columns each pair of levels occurs equally often, so each
  factor's main effect is estimated over a balanced set of the others. They are built as
  Rao's linear arrays over the Galois field GF(q): the runs are the vectors u of GF(q)^k, the
  columns the vectors c of GF(q)^k whose first non-zero entry is 1, and the level of run u in
  column c is the dot product u.c: L4(2^3), L8(2^7), L16(2^15) (q = 2), L9(3^4), L27(3^13)
  (q = 3), L16(4^5) (q = 4). ``L16`` is the four-level array when the factors have four
  levels, else the two-level one. The columns are those of the standard tables up to their
  order and level names; a study's factors take the first columns.
* ``random``: ``runs`` combinations drawn with ``seed`` (uniform over the grid, with
  replacement).

:func:`design` returns the runs as tuples of level indices, one per factor.
"""

from __future__ import annotations

import itertools
import random

__all__ = ["ARRAYS", "DESIGNS", "DesignError", "design", "orthogonal_array"]

#: The orthogonal arrays: name -> the (levels q, base dimension k) pairs it exists for.
ARRAYS = {"L4": ((2, 2),), "L8": ((2, 3),), "L9": ((3, 2),), "L16": ((4, 2), (2, 4)),
          "L27": ((3, 3),)}
#: Every design name.
DESIGNS = ("grid", *ARRAYS, "random")

# GF(4) as {0, 1, a, a+1} = {0, 1, 2, 3}: addition is XOR, multiplication by this table.
_GF4_MUL = ((0, 0, 0, 0), (0, 1, 2, 3), (0, 2, 3, 1), (0, 3, 1, 2))


class DesignError(ValueError):
    """A design that cannot hold the study's factors."""


def _add(q: int, a: int, b: int) -> int:
    return a ^ b if q == 4 else (a + b) % q


def _mul(q: int, a: int, b: int) -> int:
    return _GF4_MUL[a][b] if q == 4 else a * b % q


def orthogonal_array(q: int, k: int) -> list[tuple[int, ...]]:
    """Rao's linear orthogonal array over GF(q) (q in 2, 3, 4): q^k runs, (q^k - 1)/(q - 1)
    columns of levels 0..q-1, strength 2."""
    if q not in (2, 3, 4):
        raise DesignError(f"no GF({q}) array here (2, 3 or 4 levels)")
    vectors = list(itertools.product(range(q), repeat=k))
    columns = [c for c in vectors if any(c) and c[next(i for i, x in enumerate(c) if x)] == 1]
    rows = []
    for u in vectors:
        row = []
        for c in columns:
            level = 0
            for a, b in zip(u, c, strict=True):
                level = _add(q, level, _mul(q, a, b))
            row.append(level)
        rows.append(tuple(row))
    return rows


def design(name: str, levels: list[int], *, runs: int | None = None,
           seed: int = 0) -> list[tuple[int, ...]]:
    """The runs of design ``name`` for factors with ``levels`` levels each, as level indices.

    An orthogonal array needs every factor to have its level count q and at most as many
    factors as it has columns; ``random`` needs ``runs``.
    """
    if name == "grid":
        return list(itertools.product(*(range(n) for n in levels)))
    if name == "random":
        if runs is None or runs < 1:
            raise DesignError("design = \"random\" needs runs = N (N >= 1)")
        rng = random.Random(seed)
        return [tuple(rng.randrange(n) for n in levels) for _ in range(runs)]
    if name not in ARRAYS:
        raise DesignError(f"unknown design {name!r}; designs are {', '.join(DESIGNS)}")
    fitting = [(q, k) for q, k in ARRAYS[name] if set(levels) == {q}]
    if not fitting:
        offered = " or ".join(f"{q}" for q, _ in ARRAYS[name])
        raise DesignError(f"design {name} needs every factor to have {offered} levels; the "
                          f"factors have {', '.join(map(str, levels))}")
    q, k = fitting[0]
    array = orthogonal_array(q, k)
    if len(levels) > len(array[0]):
        raise DesignError(f"design {name} ({q} levels) has {len(array[0])} columns: too few "
                          f"for {len(levels)} factors")
    return [row[:len(levels)] for row in array]
