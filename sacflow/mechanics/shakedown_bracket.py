r"""The shakedown limit of steady Hertz rolling bracketed: certified Melan floor, kinematic ceiling.

:func:`rolling_bracket` runs Melan's optimiser (:func:`~sacflow.mechanics.shakedown.
rolling_shakedown_bound`), then

* **certifies** its residual field everywhere (:mod:`sacflow.mechanics.shakedown_certificate`):
  M bounds σ_vM(σ̂ + ρ) at every load offset, point and depth, so λ = σ_Y/M (per unit peak
  pressure) is proved safe; it lies below the optimiser's value at the samples by the certified
  margin;
* computes the **kinematic-hardening ceiling** (:mod:`sacflow.mechanics.shakedown_ceiling`) on
  the optimiser's samples: no residual field whatever proves more.

The perfectly plastic shakedown limit lies in [lower, ceiling]; the gap is what the residual
class, the optimiser and the certificate leave open, and (for the sphere) the difference
between perfect plasticity and kinematic hardening itself. Lengths in contact radii a.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from sacflow.mechanics.hertz import hertz_subsurface_stress, line_contact_stress
from sacflow.mechanics.shakedown import (
    MelanBound,
    knot_intervals,
    rolling_samples,
    rolling_shakedown_bound,
)
from sacflow.mechanics.shakedown_ceiling import KinematicCeiling, kinematic_ceiling
from sacflow.mechanics.shakedown_certificate import (
    CertifiedMaximum,
    ElasticField,
    breakpoints,
    certified_maximum,
    far_field_bound,
)
from sacflow.mechanics.steady_residual import FieldClass, SteadyResidualField

__all__ = ["CERTIFICATE", "ShakedownBracket", "certify", "rolling_bracket"]

#: Settings of the certificate: cells per knot interval inside the residual box; load offsets
#: |t| ≤ ``track`` in cells of the same size; then cells growing by ``growth`` out to
#: ``reach`` (in a) along the track, across it and in depth; refinement ``levels``; cells are
#: refined while their bound exceeds the sampled maximum by more than ``tolerance``.
CERTIFICATE: dict[str, float] = {"cells_per_knot": 2, "track": 4.0, "growth": 1.5,
                                 "reach": 40.0, "levels": 10, "tolerance": 5e-4}


@dataclass(frozen=True)
class ShakedownBracket:
    """Result of :func:`rolling_bracket`; load factors per unit peak pressure over σ_Y.

    Attributes
    ----------
    lower : float
        Certified Melan lower bound σ_Y / M (module docstring of
        :mod:`sacflow.mechanics.shakedown_certificate`).
    sampled : float
        The optimiser's factor, yield checked at its samples only (``melan.load_factor``).
    ceiling : float
        Kinematic-hardening ceiling (an upper bound of the shakedown limit).
    ceiling_low : float
        The ceiling with the balls' upper radii: how exactly the balls were found.
    inside, outside, residual_alone : CertifiedMaximum or float
        The certificate's parts: the box of cells, the far-field bound beyond it, the
        certified sup of σ_vM(ρ) (the unloaded state).
    melan : MelanBound
        The optimiser's result.
    """

    lower: float
    sampled: float
    ceiling: float
    ceiling_low: float
    inside: CertifiedMaximum
    outside: float
    residual_alone: CertifiedMaximum
    melan: MelanBound

    @property
    def gap(self) -> float:
        """Relative width of the bracket, ceiling / lower − 1."""
        return self.ceiling / self.lower - 1.0

    @property
    def margin(self) -> float:
        """What the certificate takes off the sampled factor, sampled / lower − 1."""
        return self.sampled / self.lower - 1.0


def _elastic(contact: Literal["point", "line"], nu: float) -> ElasticField:
    """σ̂(t, x2, x3) per unit p0 of the Hertz contact (a = 1) at scattered points."""
    if contact == "line":
        return lambda t, x2, x3: line_contact_stress(t, x3, 1.0, 1.0, nu)
    return lambda t, x2, x3: hertz_subsurface_stress(t, x2, x3, 1.0, 1.0, nu)


def certify(contact: Literal["point", "line"], nu: float, field: SteadyResidualField,
            coefficients: NDArray[np.float64], target: float,
            settings: dict[str, float] | None = None
            ) -> tuple[float, CertifiedMaximum, float, CertifiedMaximum]:
    """Certified sup of σ_vM(σ̂ + ρ) everywhere, per unit p0 (module docstring).

    Returns the bound M and its parts: inside the box of cells, outside it, and the sup of
    σ_vM(ρ) alone. ``target`` is the sampled maximum (cells above it × (1 + tolerance) are
    refined).
    """
    s = {**CERTIFICATE, **(settings or {})}
    cells = int(s["cells_per_knot"])
    n2, n3 = field.intervals
    reach, growth = s["reach"], s["growth"]
    t_faces = breakpoints(-s["track"], s["track"],
                          round(2 * s["track"] * n3 / field.depth) * cells, reach, growth)
    z_faces = breakpoints(0.0, field.depth, n3 * cells, reach, growth)
    if contact == "line":
        y_faces = np.zeros(1)
    else:
        y_faces = breakpoints(-field.half_width, field.half_width, n2 * cells, reach, growth)
    threshold = target * (1.0 + s["tolerance"])
    levels = int(s["levels"])
    inside = certified_maximum(_elastic(contact, nu), field, coefficients,
                               (t_faces, y_faces, z_faces), threshold, levels, s["tolerance"])
    alone = certified_maximum(None, field, coefficients, (np.zeros(1), y_faces, z_faces),
                              threshold, levels, s["tolerance"])
    outside = alone.bound + far_field_bound(contact, nu, reach)
    return max(inside.bound, outside), inside, outside, alone


def rolling_bracket(
    contact: Literal["point", "line"], nu: float = 0.3, *, kind: FieldClass = "full",
    half_width: float = 3.0, depth: float = 3.0, sample_step: float = 1.0 / 12.0,
    knot_step: float = 0.25, track: float = 3.0, certificate: dict[str, float] | None = None,
    ceiling_step: float | None = None,
) -> ShakedownBracket:
    """Certified Melan lower bound and kinematic ceiling of steady Hertz rolling.

    Parameters as :func:`~sacflow.mechanics.shakedown.rolling_shakedown_bound`;
    ``certificate`` overrides entries of :data:`CERTIFICATE`; the ceiling is computed on
    samples ``ceiling_step`` apart (default ``sample_step``) over the same ranges (finer
    samples can only lower it towards the exact ceiling).
    """
    melan = rolling_shakedown_bound(contact, nu, kind=kind, half_width=half_width, depth=depth,
                                    sample_step=sample_step, knot_step=knot_step, track=track)
    elastic, x2, x3 = rolling_samples(contact, nu, half_width, depth,
                                      ceiling_step or sample_step, track)
    ceiling: KinematicCeiling = kinematic_ceiling(elastic)
    field = SteadyResidualField(x2[:1], x3[:1], half_width, depth,
                                knot_intervals(half_width, depth, knot_step), kind)
    bound, inside, outside, alone = certify(contact, nu, field, melan.coefficients,
                                            1.0 / melan.load_factor, certificate)
    return ShakedownBracket(lower=1.0 / bound, sampled=melan.load_factor,
                            ceiling=ceiling.load_factor, ceiling_low=ceiling.load_factor_low,
                            inside=inside, outside=outside, residual_alone=alone, melan=melan)
