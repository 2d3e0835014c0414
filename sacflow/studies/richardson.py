"""Observed order of convergence and Richardson extrapolation of a refinement sequence.

A quantity f computed on levels of a discretisation whose parameter h (cell size, layer
thickness, load increment, inverse box depth) shrinks by a constant ratio r from one level to
the next behaves, in the asymptotic range, as f(h) = f∞ + C hᵖ. Three consecutive levels
f₁, f₂, f₃ (coarse to fine) then give (Richardson 1911; Roache, *Verification and Validation in
Computational Science and Engineering*, 1998, §5.4 and §5.9)

* the observed order p = ln((f₂ − f₁) / (f₃ − f₂)) / ln r,
* the extrapolated limit f∞ = f₃ + (f₃ − f₂) / (rᵖ − 1),
* the grid convergence index of the finest level GCI = F_s |f₃ − f₂| / (r^q − 1) with the
  safety factor F_s = 1.25 (Roache's value for a three-level study with an observed order) and
  q = min(p, formal order): a band about f₃ that holds the true limit with about 95 %
  confidence. No credit is taken for an observed order above the formal one (Roache 1998,
  §5.9; Eça & Hoekstra, J. Comput. Phys. 262 (2014) 104): such an order is a pre-asymptotic
  accident more often than a property of the scheme. It is the uncertainty reported here:
  unlike the spread between the limits of the observed and the formal order, it does not
  vanish when the observed order happens to equal the formal one.

Levels at steps h₁ > h₂ > h₃ without a constant ratio (:func:`extrapolate_steps`, e.g.
h = 1/3, 1/4, 1/5 of a coarsest level) give the order as the root of

    (f₂ − f₁) / (f₃ − f₂) = (h₁ᵖ − h₂ᵖ) / (h₂ᵖ − h₃ᵖ),

whose right side grows monotonically with p from ln(h₁/h₂) / ln(h₂/h₃) (Celik, Ghia, Roache,
Freitas, Coleman and Raad, J. Fluids Eng. 130 (2008) 078001, eqs. (3)–(5)), and the limit and
the GCI as above with r = h₂/h₃ of the finest pair. With a constant ratio both forms agree.

Sequences whose differences change sign ("oscillating") or grow ("diverging") have no order
and no limit; an oscillating one gets half the range of its last three levels as uncertainty
(Stern et al., J. Fluids Eng. 123 (2001) 793, §"oscillatory convergence"). With steps of
unequal ratios, "diverging" means that the differences shrink no faster than order 0 would.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from itertools import pairwise

from scipy.optimize import brentq

__all__ = [
    "GCI_SAFETY_FACTOR",
    "MONOTONE",
    "Extrapolation",
    "extrapolate",
    "extrapolate_steps",
    "observed_order",
    "observed_order_steps",
    "relative_errors",
    "richardson_limit",
    "step_for_error",
    "value_at_step",
]

#: Roache's safety factor of the grid convergence index for three levels and an observed order.
GCI_SAFETY_FACTOR = 1.25
#: Largest observed order :func:`extrapolate_steps` looks for (far beyond any scheme's: a root
#: above it is reported as this bound, as the limit then equals the finest level).
MAX_ORDER = 50.0
#: Differences below this fraction of the largest |value| of the sequence count as zero
#: (round-off of the solver's converged iterations, not discretisation).
NEGLIGIBLE_CHANGE = 1e-12

MONOTONE = "monotone"
OSCILLATING = "oscillating"
DIVERGING = "diverging"
UNCHANGED = "unchanged"


@dataclass(frozen=True)
class Extrapolation:
    """Richardson analysis of the last three levels of a sequence.

    Attributes
    ----------
    behaviour : str
        ``"monotone"`` (converging, an order and a limit), ``"oscillating"`` (the differences
        change sign), ``"diverging"`` (they grow) or ``"unchanged"`` (they vanish: the quantity
        does not depend on the refined parameter).
    order : float
        Observed order p of the last three levels (NaN unless monotone).
    limit : float
        Richardson limit f∞ with the observed order (the last value when unchanged; NaN when
        oscillating or diverging).
    uncertainty : float
        GCI of the finest level (monotone; with the observed order, or the formal one when
        lower), half the range of the last three levels
        (oscillating), 0 (unchanged), NaN (diverging).
    formal_limit : float
        Richardson limit with the formal order instead (NaN without one).
    previous_order : float
        Observed order of the three levels before the last (NaN with fewer than four levels):
        close to ``order`` in the asymptotic range.
    """

    behaviour: str
    order: float
    limit: float
    uncertainty: float
    formal_limit: float
    previous_order: float


def observed_order(coarse: float, medium: float, fine: float, ratio: float) -> float:
    """Return p = ln((f₂ − f₁) / (f₃ − f₂)) / ln r (NaN: differences of opposite sign or zero)."""
    first, second = medium - coarse, fine - medium
    if first * second <= 0.0:
        return math.nan
    return math.log(first / second) / math.log(ratio)


def observed_order_steps(values: Sequence[float], steps: Sequence[float]) -> float:
    """Return the order p of three levels at steps h₁ > h₂ > h₃ (module docstring).

    NaN when the differences have opposite signs or vanish, or when they shrink too slowly for
    any positive order (the ratio of the differences at most ln(h₁/h₂) / ln(h₂/h₃)).
    """
    (f1, f2, f3), (h1, h2, h3) = (tuple(float(v) for v in values),
                                  tuple(float(h) for h in steps))
    first, second = f2 - f1, f3 - f2
    if first * second <= 0.0:
        return math.nan
    target = first / second

    def gap(p: float) -> float:
        return (h1**p - h2**p) / (h2**p - h3**p) - target

    if target <= math.log(h1 / h2) / math.log(h2 / h3):
        return math.nan
    if gap(MAX_ORDER) <= 0.0:
        return MAX_ORDER
    return float(brentq(gap, 1e-9, MAX_ORDER, xtol=1e-12))


def richardson_limit(medium: float, fine: float, ratio: float, order: float) -> float:
    """f∞ = f₃ + (f₃ − f₂) / (rᵖ − 1), the limit of f = f∞ + C hᵖ through two levels."""
    return fine + (fine - medium) / (ratio**order - 1.0)


def extrapolate(values: Sequence[float], ratio: float,
                formal_order: float | None = None) -> Extrapolation:
    """Observed order, Richardson limit and uncertainty of a refinement sequence.

    Parameters
    ----------
    values : sequence of float
        The quantity on three or more levels, coarse to fine, each refined by ``ratio``.
    ratio : float
        Constant refinement ratio r > 1 of the discretisation parameter.
    formal_order : float, optional
        Order the scheme should have (2 for midpoint sampling in space); gives
        :attr:`Extrapolation.formal_limit`.

    Raises
    ------
    ValueError
        With fewer than three values, or a ratio not above 1.
    """
    if not ratio > 1.0:
        raise ValueError(f"the refinement ratio must exceed 1, got {ratio}")
    return extrapolate_steps(values, [ratio ** -k for k in range(len(values))], formal_order)


def extrapolate_steps(values: Sequence[float], steps: Sequence[float],
                      formal_order: float | None = None) -> Extrapolation:
    """:func:`extrapolate` for levels at any decreasing steps (module docstring).

    Parameters
    ----------
    values : sequence of float
        The quantity on three or more levels, coarse to fine.
    steps : sequence of float
        Each level's discretisation parameter h (relative to any reference), decreasing.
    formal_order : float, optional
        As for :func:`extrapolate`.

    Raises
    ------
    ValueError
        With fewer than three values, steps not one per value, or steps not positive and
        decreasing.
    """
    if len(values) < 3:
        raise ValueError(f"a convergence order needs three levels or more, got {len(values)}")
    if len(steps) != len(values):
        raise ValueError(f"one step per level: {len(steps)} steps for {len(values)} levels")
    h = [float(x) for x in steps]
    if not all(a > b > 0.0 for a, b in pairwise(h)):
        raise ValueError(f"the steps must be positive and decrease, got {list(steps)}")
    coarse, medium, fine = (float(v) for v in values[-3:])
    previous = (_order(values[-4:-1], h[-4:-1]) if len(values) >= 4 else math.nan)
    ratio = h[-2] / h[-1]
    scale = max(abs(float(v)) for v in values[-3:])
    first, second = medium - coarse, fine - medium
    negligible = NEGLIGIBLE_CHANGE * scale
    if abs(second) <= negligible and abs(first) <= negligible:
        return Extrapolation(UNCHANGED, math.nan, fine, 0.0, fine, previous)
    formal = (math.nan if formal_order is None
              else richardson_limit(medium, fine, ratio, formal_order))
    if abs(second) <= negligible:  # converged at the medium level already
        return Extrapolation(MONOTONE, math.inf, fine, 0.0, formal, previous)
    if first * second < 0.0:
        half_range = 0.5 * (max(coarse, medium, fine) - min(coarse, medium, fine))
        return Extrapolation(OSCILLATING, math.nan, math.nan, half_range, formal, previous)
    order = _order(values[-3:], h[-3:])
    if not order > 0.0:  # NaN, or differences that do not shrink
        return Extrapolation(DIVERGING, math.nan, math.nan, math.nan, formal, previous)
    limit = richardson_limit(medium, fine, ratio, order)
    gci_order = order if formal_order is None else min(order, formal_order)
    gci = GCI_SAFETY_FACTOR * abs(second) / (ratio**gci_order - 1.0)
    return Extrapolation(MONOTONE, order, limit, gci, formal, previous)


def _order(values: Sequence[float], steps: Sequence[float]) -> float:
    """Observed order of three levels: the closed form with a constant ratio, else the root."""
    (h1, h2, h3), (f1, f2, f3) = steps, values
    if math.isclose(h1 / h2, h2 / h3, rel_tol=1e-12):
        return observed_order(f1, f2, f3, h1 / h2)
    return observed_order_steps(values, steps)


def relative_errors(values: Sequence[float], limit: float) -> list[float]:
    """(f − f∞) / |f∞| of each value (NaN when the limit is unknown or zero)."""
    if not math.isfinite(limit) or limit == 0.0:
        return [math.nan for _ in values]
    return [(float(v) - limit) / abs(limit) for v in values]


def value_at_step(fine: float, limit: float, order: float, fine_step: float,
                  step: float) -> float:
    """f(h) = f∞ + (f₃ − f∞) (h / h₃)ᵖ: the model f∞ + C hᵖ through the finest level, at ``step``.

    What the Richardson analysis predicts for a level the sequence did not run (the check of a
    study: run that level and compare). NaN without a finite limit and a positive order.
    """
    if not (math.isfinite(limit) and order > 0.0 and fine_step > 0.0 and step > 0.0):
        return math.nan
    if math.isinf(order):  # converged at the medium level: every finer level is the limit
        return limit if step < fine_step else math.nan
    return limit + (fine - limit) * (step / fine_step) ** order


def step_for_error(fine: float, limit: float, order: float, fine_step: float,
                   target: float) -> float:
    """Return the step h at which :func:`value_at_step` is ``target`` × |f∞| away from the limit.

    h = h₃ (ε / |e₃|)^(1/p) with e₃ = (f₃ − f∞) / |f∞| the finest level's relative error and
    ε = ``target``: the discretisation a study predicts for a required accuracy (above h₃ when
    the finest level is already within it). Infinite when the finest level equals the limit;
    NaN without a finite nonzero limit and a positive order.
    """
    if not (math.isfinite(limit) and limit != 0.0 and order > 0.0 and fine_step > 0.0
            and target > 0.0):
        return math.nan
    error = abs(fine - limit) / abs(limit)
    if error == 0.0 or math.isinf(order):
        return math.inf
    return fine_step * (target / error) ** (1.0 / order)
