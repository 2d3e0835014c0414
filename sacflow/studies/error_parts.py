"""A limit from the parts of the error: the one-at-a-time sequences added up.

A `together` sequence refines the cells, the layers and the increments at once. When their
errors have opposite signs and different orders, the sum follows no single power of h and the
sequence has no Richardson limit (:mod:`sacflow.studies.richardson`: "diverging" or
"oscillating") even though each parameter, refined alone, converges. With errors that add,

    f(h_1, …, h_n) = f* + Σ_k C_k h_k^(p_k),

the sequence k refines h_k alone from the study's base b, the others held at b_j, and its
Richardson limit is K_k = f* + Σ_{j≠k} C_j b_j^(p_j). The base's own value is
f_b = f* + Σ_j C_j b_j^(p_j), so that

    f* = Σ_k K_k − (n − 1) f_b,

the same assumption of errors that add as the window's correction of
:mod:`sacflow.studies.certify`. Its uncertainty is the sum of the parts' grid convergence
indices, the limits' errors added at their worst, plus the model's own *misfit*: the largest
distance between a level off every one-at-a-time line (a finer `together` level, the shipped
discretisation) and what the model predicts there, f* + Σ_k C_k h_k^(p_k) with each C_k
drawn through its sequence's finest level. The misfit holds what the model leaves out: terms
in two parameters at once, and parts whose order changes below their finest level.

The functions take numbers, not tables: the pipeline (``pipelines/convergence_certify.py``)
reads the study's summaries and levels.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from sacflow.studies.richardson import MONOTONE, UNCHANGED

__all__ = ["ModelCheck", "Part", "PartsLimit", "parts_limit", "predicted_value"]


@dataclass(frozen=True)
class Part:
    """One parameter refined alone from the base: its sequence's Richardson analysis.

    Attributes
    ----------
    behaviour : str
        The sequence's behaviour (:class:`sacflow.studies.richardson.Extrapolation`).
    limit, uncertainty, order : float
        K_k, its grid convergence index and the observed order p_k.
    finest_value, finest_step : float
        The finest level's value and step, through which C_k is drawn.
    """

    behaviour: str
    limit: float
    uncertainty: float
    order: float
    finest_value: float
    finest_step: float

    @property
    def converges(self) -> bool:
        """Whether the part has a limit: monotone with a finite one, or unchanged."""
        return self.behaviour == UNCHANGED or (
            self.behaviour == MONOTONE and math.isfinite(self.limit)
            and math.isfinite(self.uncertainty))

    def error_at(self, step: float) -> float:
        """C_k h^(p_k) with C_k = (f_fine − K_k) / h_fine^(p_k): the part's error at ``step``.

        Zero for an unchanged part, and for one converged at its medium level (order ∞) at or
        below its finest step.
        """
        if self.behaviour == UNCHANGED or self.finest_value == self.limit:
            return 0.0
        if math.isinf(self.order):
            return 0.0 if step <= self.finest_step else math.nan
        return (self.finest_value - self.limit) * (step / self.finest_step) ** self.order


@dataclass(frozen=True)
class ModelCheck:
    """A level off the one-at-a-time lines: its steps (one per part) and computed value."""

    steps: Mapping[str, float]
    value: float


@dataclass(frozen=True)
class PartsLimit:
    """f* from the parts, its uncertainty and what makes it up.

    Attributes
    ----------
    limit : float
        f* = Σ_k K_k − (n − 1) f_b.
    uncertainty : float
        ``parts_uncertainty + misfit``.
    parts_uncertainty : float
        Σ_k U_k.
    misfit : float
        The largest |f − f̂| over the checks (0 without any).
    base_errors : dict of str to float
        Each part's share of the base's error, f_b − K_k.
    discrepancies : tuple of float
        f − f̂ at each check, in their order.
    """

    limit: float
    uncertainty: float
    parts_uncertainty: float
    misfit: float
    base_errors: dict[str, float]
    discrepancies: tuple[float, ...]


def predicted_value(limit: float, parts: Mapping[str, Part], steps: Mapping[str, float]) -> float:
    """f̂ = f* + Σ_k C_k h_k^(p_k): the additive model at one level (module docstring)."""
    return limit + sum(part.error_at(float(steps[name])) for name, part in parts.items())


def parts_limit(base_value: float, parts: Mapping[str, Part],
                checks: Sequence[ModelCheck] = ()) -> PartsLimit | None:
    """Return f* and its uncertainty from the parts (module docstring), or None.

    Parameters
    ----------
    base_value
        f_b, the quantity at the base every part refines from.
    parts
        Each parameter's sequence, refined alone from the base (two or more).
    checks
        Levels off the one-at-a-time lines, to measure the model's misfit.

    Returns
    -------
    PartsLimit or None
        None when a part has no limit (it oscillates or diverges) or a value is not finite:
        the parts then say nothing the `together` sequence does not.

    Raises
    ------
    ValueError
        With fewer than two parts, or a check without a step for every part.
    """
    if len(parts) < 2:
        raise ValueError(f"a limit from the parts needs two parts or more, got {len(parts)}")
    for check in checks:
        missing = sorted(set(parts) - set(check.steps))
        if missing:
            raise ValueError(f"a check needs a step for every part; it has none for {missing}")
    if not math.isfinite(base_value) or not all(p.converges for p in parts.values()):
        return None
    limit = sum(p.limit for p in parts.values()) - (len(parts) - 1) * base_value
    spread = sum(p.uncertainty for p in parts.values())
    discrepancies = tuple(c.value - predicted_value(limit, parts, c.steps) for c in checks)
    if not all(math.isfinite(d) for d in discrepancies):
        return None
    misfit = max((abs(d) for d in discrepancies), default=0.0)
    return PartsLimit(limit=limit, uncertainty=spread + misfit, parts_uncertainty=spread,
                      misfit=misfit,
                      base_errors={name: base_value - p.limit for name, p in parts.items()},
                      discrepancies=discrepancies)
