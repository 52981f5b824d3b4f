"""What a study's table says about a metric: main effects and a second-order response surface.

* Main effects: the metric's mean at each level of each factor (over the runs at that level;
  balanced over the other factors in an orthogonal array).
* Response surface, the motion-errors paper's eqs (14)-(20): the second-order polynomial regression
  y = b0 + sum_i b_i x_i + sum_i b_ii x_i^2 + sum_{i<j} b_ij x_i x_j, fitted by least squares
  (eq (18): b = (X'X)^-1 X'y) on coded factors x_i = (level - centre) / half-range, each in
  [-1, 1]; the stationary point where every derivative is zero (eq (20)), in the factors'
  own units. Eq (15) as extracted has lost its squared terms and its cross terms' bounds;
  eqs (16) and (19), which write the model out for four factors, have them, and are used.
  The fit needs at least as many runs as terms (1 + 2k + k(k-1)/2: 15 for four factors,
  which an L16 run allows, as in the motion-errors paper).
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["AnalysisError", "Surface", "effects_figure", "main_effects", "response_surface",
           "surface_needs", "surface_terms"]


class AnalysisError(ValueError):
    """A metric or factor set the table cannot be analysed for."""


def _column(rows: Sequence[dict[str, str]], name: str) -> np.ndarray:
    try:
        return np.array([float(r[name]) for r in rows])
    except KeyError:
        raise AnalysisError(f"no column {name!r} in the table") from None
    except ValueError:
        raise AnalysisError(f"column {name!r} is not numeric in every run (a failed run, or a "
                            f"figure a run does not have)") from None


def main_effects(rows: Sequence[dict[str, str]], factors: Sequence[str],
                 metric: str) -> dict[str, list[tuple[float, float]]]:
    """For each factor, (level, mean of ``metric`` over the runs at that level)."""
    y = _column(rows, metric)
    out = {}
    for factor in factors:
        x = _column(rows, factor)
        out[factor] = [(float(level), float(y[x == level].mean())) for level in np.unique(x)]
    return out


@dataclass(frozen=True)
class Surface:
    """A fitted second-order response surface (coded factors, see the module docstring)."""

    factors: tuple[str, ...]
    terms: tuple[str, ...]
    coefficients: tuple[float, ...]
    r_squared: float
    centre: tuple[float, ...]
    half_range: tuple[float, ...]
    stationary: tuple[float, ...] | None

    def predict(self, levels: Sequence[float]) -> float:
        """The fitted metric at ``levels`` (the factors' own units)."""
        x = (np.asarray(levels, float) - self.centre) / self.half_range
        return float(_design_matrix(x[None, :])[0] @ np.asarray(self.coefficients))

    @property
    def kind(self) -> str:
        """What the stationary point is: ``minimum``, ``maximum`` or ``saddle`` (the signs of
        the quadratic part's eigenvalues)."""
        signs = np.sign(np.linalg.eigvalsh(_quadratic(np.asarray(self.coefficients),
                                                      len(self.factors))))
        return "minimum" if (signs > 0).all() else "maximum" if (signs < 0).all() else "saddle"


def _quadratic(beta: np.ndarray, k: int) -> np.ndarray:
    """B of y = b0 + b.x + x'Bx: b_ii on the diagonal and b_ij / 2 off it."""
    quad = np.diag(beta[1 + k:1 + 2 * k])
    for n, (i, j) in enumerate(itertools.combinations(range(k), 2)):
        quad[i, j] = quad[j, i] = beta[1 + 2 * k + n] / 2
    return quad


def _design_matrix(x: np.ndarray) -> np.ndarray:
    k = x.shape[1]
    columns = [np.ones(len(x)), *(x[:, i] for i in range(k)), *(x[:, i] ** 2 for i in range(k)),
               *(x[:, i] * x[:, j] for i, j in itertools.combinations(range(k), 2))]
    return np.column_stack(columns)


def surface_terms(factors: Sequence[str]) -> tuple[str, ...]:
    """The terms of eq (19) over ``factors``: 1 + 2k + k(k-1)/2 of them."""
    return ("1", *factors, *(f"{f}^2" for f in factors),
            *(f"{a}*{b}" for a, b in itertools.combinations(factors, 2)))


def surface_needs(rows: Sequence[dict[str, str]], factors: Sequence[str]) -> str | None:
    """What the runs lack for eq (19) over ``factors`` (as many runs as terms, three levels
    of each factor), in words; None if the surface can be fitted."""
    terms = surface_terms(factors)
    k = len(factors)
    if len(rows) < len(terms):
        return (f"a second-order surface over {k} factors has {len(terms)} terms: "
                f"{len(rows)} runs are too few; it needs at least {len(terms)} runs and three "
                f"levels of each factor (an L16 or L27 design), or fewer factors (--factors)")
    two = [f for f in factors if len(np.unique(_column(rows, f))) < 3]
    if two:
        return (f"factor {two[0]} has fewer than three levels: its squared term cannot be "
                f"estimated (a design with three levels or more per factor, or --factors "
                f"without it)")
    return None


def response_surface(rows: Sequence[dict[str, str]], factors: Sequence[str],
                     metric: str) -> Surface:
    """Fit eq (19) of ``metric`` over ``factors`` (each with at least three levels for its
    squared term to be estimable; :func:`surface_needs` says what is missing)."""
    k = len(factors)
    terms = surface_terms(factors)
    needs = surface_needs(rows, factors)
    if needs is not None:
        raise AnalysisError(needs)
    raw = np.column_stack([_column(rows, f) for f in factors])
    lo, hi = raw.min(axis=0), raw.max(axis=0)
    centre, half = (lo + hi) / 2, (hi - lo) / 2
    x = (raw - centre) / half
    y = _column(rows, metric)
    design = _design_matrix(x)
    beta, *_ = np.linalg.lstsq(design, y, rcond=None)
    residual = y - design @ beta
    total = float(((y - y.mean()) ** 2).sum())
    r2 = 1 - float((residual**2).sum()) / total if total else 1.0
    # eq (20): grad = b + 2 B x = 0
    try:
        point = np.linalg.solve(2 * _quadratic(beta, k), -beta[1:1 + k])
        stationary = tuple(float(v) for v in centre + half * point)
    except np.linalg.LinAlgError:
        stationary = None
    return Surface(tuple(factors), terms, tuple(float(v) for v in beta), r2,
                   tuple(map(float, centre)), tuple(map(float, half)), stationary)


def effects_figure(effects: dict[str, list[tuple[float, float]]], metric: str,
                   title: str) -> Figure:
    """One panel per factor: the metric's mean at each of its levels."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(3.2 * len(effects), 3.4), layout="constrained")
    axes = fig.subplots(1, len(effects), sharey=True, squeeze=False)[0]
    for ax, (factor, points) in zip(axes, effects.items(), strict=True):
        levels, means = zip(*points, strict=True)
        ax.plot(levels, means, "o-")
        ax.set(xlabel=factor, title=factor)
    axes[0].set_ylabel(f"mean {metric}")
    fig.suptitle(title, parse_math=False)
    return fig
