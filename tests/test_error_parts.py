"""The limit from the parts of the error (:mod:`sacflow.studies.error_parts`).

A manufactured error f = f* + Σ_k C_k h_k^(p_k) with parts of opposite signs and different
orders: refined together it has no Richardson limit, refined one parameter at a time each
sequence converges, and the parts give f* back. With a term in two parameters at once the
model misses, and its misfit must then cover the distance to the true limit.
"""

from __future__ import annotations

import math

import pytest

from sacflow.studies.error_parts import ModelCheck, Part, parts_limit, predicted_value
from sacflow.studies.richardson import MONOTONE, OSCILLATING, extrapolate_steps

TRUE_LIMIT = 371.86
#: Each part's constant and order: a lateral error of order 6 that dies fast, a layers error of
#: order 2 and an increments error of order 1 of the other sign, which cancel near h = 1/4.
TERMS = {"lateral": (-26.0, 6.0), "layers": (1.0, 2.0), "increments": (-0.25, 1.0)}
BASE = {"lateral": 0.5, "layers": 0.5, "increments": 1.0}
STEPS = (1.0, 0.5, 0.25, 1.0 / 6.0)


def manufactured(steps: dict[str, float], cross: float = 0.0) -> float:
    """f* plus each term at its step, plus ``cross`` h_layers h_increments."""
    value = TRUE_LIMIT + sum(c * steps[k] ** p for k, (c, p) in TERMS.items())
    return value + cross * steps["layers"] * steps["increments"]


def one_at_a_time(cross: float = 0.0) -> dict[str, Part]:
    """Each parameter refined alone from :data:`BASE` over :data:`STEPS`, the finest three fitted
    as the study does."""
    parts = {}
    for name in TERMS:
        steps = [h for h in STEPS if h <= BASE[name]] if name != "increments" else list(STEPS)
        values = [manufactured({**BASE, name: h}, cross) for h in steps]
        fit = extrapolate_steps(values, steps)
        parts[name] = Part(fit.behaviour, fit.limit, fit.uncertainty, fit.order, values[-1],
                           steps[-1])
    return parts


def together_checks(cross: float = 0.0) -> list[ModelCheck]:
    """The `together` levels finer than the base: off every one-at-a-time line."""
    return [ModelCheck({k: h for k in TERMS}, manufactured({k: h for k in TERMS}, cross))
            for h in (0.25, 1.0 / 6.0)]


def test_the_manufactured_error_refined_together_has_no_limit():
    """The premise: the sum of the parts follows no single power of h."""
    values = [manufactured({k: h for k in TERMS}) for h in STEPS]
    assert extrapolate_steps(values, STEPS).behaviour != MONOTONE


def test_the_parts_give_the_limit_back_where_the_errors_add():
    found = parts_limit(manufactured(BASE), one_at_a_time(), together_checks())
    assert found is not None
    assert found.limit == pytest.approx(TRUE_LIMIT, rel=1e-12)
    assert found.misfit == pytest.approx(0.0, abs=1e-9)
    shares = {k: c * BASE[k] ** p for k, (c, p) in TERMS.items()}
    for name, share in shares.items():
        assert found.base_errors[name] == pytest.approx(share, rel=1e-9, abs=1e-12)


def test_the_model_predicts_a_level_off_the_lines():
    parts = one_at_a_time()
    limit = sum(p.limit for p in parts.values()) - 2 * manufactured(BASE)
    steps = {"lateral": 0.4, "layers": 0.25, "increments": 0.5}
    assert predicted_value(limit, parts, steps) == pytest.approx(manufactured(steps), rel=1e-12)


def test_a_term_in_two_parameters_shows_as_misfit_that_covers_the_limit():
    cross = 0.02
    found = parts_limit(manufactured(BASE, cross), one_at_a_time(cross), together_checks(cross))
    assert found is not None
    assert found.misfit > 1e-4
    assert abs(found.limit - TRUE_LIMIT) <= found.uncertainty
    assert found.uncertainty == pytest.approx(found.parts_uncertainty + found.misfit)


def test_a_part_without_a_limit_gives_none():
    parts = one_at_a_time()
    parts["layers"] = Part(OSCILLATING, math.nan, 0.1, math.nan, 1.0, 0.25)
    assert parts_limit(manufactured(BASE), parts, together_checks()) is None


def test_a_check_must_step_every_part():
    with pytest.raises(ValueError, match="increments"):
        parts_limit(1.0, one_at_a_time(), [ModelCheck({"lateral": 0.25, "layers": 0.25}, 1.0)])
    with pytest.raises(ValueError, match="two parts"):
        parts_limit(1.0, {"lateral": one_at_a_time()["lateral"]})
