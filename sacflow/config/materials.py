"""Materials of body 1: hardening laws, kinematic hardening, initial residual stress and hardening.

The hardening-law models (``body.hardening``, chosen by ``law``) say what a user may write;
:func:`sacflow.config.hardening_laws.hardening_from_schema` builds the runtime law of
:mod:`sacflow.mechanics.hardening` from what they accept. The initial profiles
(``body.initial_residual_stress``, ``body.initial_hardening``) describe the body before any
contact, varying with depth only.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

from pydantic import Field, model_validator

from sacflow.config.base import (
    FiniteFloat,
    Model,
    NonNegativeFloat,
    PositiveFloat,
    field_error,
    strictly_increasing,
)

__all__ = [
    "DepthProfile",
    "Elastic",
    "HardeningLaw",
    "InitialHardening",
    "InitialResidualStress",
    "KinematicHardening",
    "Linear",
    "PerfectlyPlastic",
    "Swift",
    "Tabular",
]


class DepthProfile(Model):
    """Depth dependence of the yield stress: σ_Y(εp, x3) = factor(x3) · σ_Y(εp).

    Linear interpolation between the points, constant beyond the first and last depth.
    """

    depth: tuple[NonNegativeFloat, ...] = Field(
        min_length=1, description="depths x3 of the profile points [m], strictly increasing"
    )
    factor: tuple[PositiveFloat, ...] = Field(
        min_length=1, description="yield-stress factors at those depths (1 = unchanged)"
    )

    @model_validator(mode="after")
    def _check_points(self) -> DepthProfile:
        if len(self.factor) != len(self.depth):
            raise field_error("factor", "must have one value per depth")
        if not strictly_increasing(self.depth):
            raise field_error("depth", "must be strictly increasing")
        return self


#: Stress components an initial residual stress profile may not have: with σ(x3) alone, the
#: equilibrium ∂σ_i3/∂x3 = 0 and the free surface σ_i3(0) = 0 force σ33 = σ13 = σ23 = 0.
_NOT_INITIAL_STRESS = ("s33", "s13", "s23")


class InitialResidualStress(Model):
    """An initial residual stress varying with depth only (case hardening, shot peening).

    ``σ11(x3)``, ``σ22(x3)`` interpolated linearly between the points, constant beyond the first
    and last depth; every other component 0. Laterally uniform, it is in equilibrium with a free
    surface exactly when σ33 = σ13 = σ23 = 0 (∂σ_i3/∂x3 = 0 and σ_i3 = 0 at x3 = 0); it adds to
    the stress of the yield check at every step and to the stored ``stress`` and
    ``residual_stress``, and displaces no surface point (no change of the contact geometry).
    """

    depth: tuple[NonNegativeFloat, ...] = Field(
        min_length=1, description="depths x3 of the profile points [m], strictly increasing"
    )
    s11: tuple[FiniteFloat, ...] = Field(
        min_length=1, description="residual stress σ11 at those depths [Pa] (compression < 0)"
    )
    s22: tuple[FiniteFloat, ...] = Field(
        min_length=1, description="residual stress σ22 at those depths [Pa] (compression < 0)"
    )

    @model_validator(mode="before")
    @classmethod
    def _only_in_plane(cls, data: Any) -> Any:
        if isinstance(data, dict):
            for key in _NOT_INITIAL_STRESS:
                if key in data:
                    raise ValueError(
                        f"{key} is not allowed: a stress varying with depth only is in "
                        "equilibrium with the free surface only if σ33 = σ13 = σ23 = 0; "
                        "give s11 and s22 only"
                    )
            if "s12" in data:
                raise ValueError("s12 is not supported: give the profile in its principal "
                                 "axes x1, x2 (s11, s22)")
        return data

    @model_validator(mode="after")
    def _check_points(self) -> InitialResidualStress:
        for name in ("s11", "s22"):
            if len(getattr(self, name)) != len(self.depth):
                raise field_error(name, "must have one value per depth")
        if not strictly_increasing(self.depth):
            raise field_error("depth", "must be strictly increasing")
        return self


class InitialHardening(Model):
    """An initial equivalent plastic strain varying with depth: a work-hardened layer.

    It raises the yield stress through the hardening law (σ_Y(p0(x3))) without a plastic strain
    tensor, hence without residual stress of its own; linear between the points, constant beyond
    the first and last depth.
    """

    depth: tuple[NonNegativeFloat, ...] = Field(
        min_length=1, description="depths x3 of the profile points [m], strictly increasing"
    )
    equivalent_plastic_strain: tuple[NonNegativeFloat, ...] = Field(
        min_length=1, description="equivalent plastic strain p at those depths (plain strain)"
    )

    @model_validator(mode="after")
    def _check_points(self) -> InitialHardening:
        if len(self.equivalent_plastic_strain) != len(self.depth):
            raise field_error("equivalent_plastic_strain", "must have one value per depth")
        if not strictly_increasing(self.depth):
            raise field_error("depth", "must be strictly increasing")
        return self


class Elastic(Model):
    """No plasticity: the body stays elastic."""

    law: Literal["elastic"] = "elastic"


class KinematicHardening(Model):
    """Kinematic hardening: a backstress X that moves the yield surface (Armstrong–Frederick).

    dX = 2/3 C dεp − γ X dp (Armstrong & Frederick 1966; Chaboche 1989 for its combination with
    isotropic hardening); γ = 0 is linear kinematic hardening (Prager 1956, Ziegler 1959). Under
    uniaxial plastic flow the uniaxial backstress 3/2 X11 saturates at C/γ. The yield function
    becomes sqrt(3/2 (s − X):(s − X)) − σ_Y(p): the isotropic law still sets the surface's size.
    """

    modulus: NonNegativeFloat = Field(description="kinematic hardening modulus C [Pa]")
    recall: NonNegativeFloat = Field(
        0.0, description="dynamic recall γ (dimensionless); 0: linear (Prager–Ziegler)"
    )


class _Plastic(Model):
    """Base of the plastic laws: the rules every law shares.

    Whatever these models accept, :func:`sacflow.config.hardening_laws.hardening_from_schema`
    builds and the return mapping runs with (σ_Y finite, positive and non-decreasing in εp).
    The runtime laws of :mod:`sacflow.mechanics.hardening` check the same rules themselves, in
    plain code, so that the numerical layers need no configuration.
    """

    depth_profile: DepthProfile | None = Field(
        None, description="optional depth dependence of the yield stress (surface hardening)"
    )
    kinematic: KinematicHardening | None = Field(
        None, description="optional kinematic hardening (backstress) combined with the law"
    )

    def initial_yield_stress(self) -> float:
        """σ_Y(εp = 0) [Pa], before any depth factor."""
        raise NotImplementedError

    @model_validator(mode="after")
    def _check_scaled_yield(self) -> _Plastic:
        profile, y0 = self.depth_profile, self.initial_yield_stress()
        if profile is None or not 0.0 < y0 < math.inf:  # the law's own check reports y0
            return self
        if not (0.0 < y0 * min(profile.factor) and y0 * max(profile.factor) < math.inf):
            raise field_error(
                "depth_profile.factor",
                f"factor times the initial yield stress ({y0:g} Pa) must stay a finite "
                "positive stress; use factors of order 1",
            )
        return self


class Swift(_Plastic):
    """Swift law σ_Y = B (C + εp)^n, εp in ``strain_unit`` (the seed uses micro-strain).

    The initial yield stress σ_Y(0) = B C^n must be a finite positive stress, so C > 0 (C = 0
    would mean yield at zero stress with an infinite initial hardening slope).
    """

    law: Literal["swift"] = "swift"
    B: PositiveFloat = Field(description="Swift stress coefficient B [Pa]")
    C: PositiveFloat = Field(
        description="Swift strain offset C, in strain_unit (> 0: σ_Y(0) = B C^n is the initial "
        "yield stress)"
    )
    n: float = Field(gt=0, lt=1, description="Swift hardening exponent n")
    strain_unit: Literal["strain", "microstrain"] = Field(
        description='unit of εp and C in the Swift law ("microstrain": σ_Y = B (C + 1e6 εp)^n)'
    )

    def initial_yield_stress(self) -> float:
        """σ_Y(0) = B C^n [Pa]."""
        return self.B * self.C**self.n

    @model_validator(mode="after")
    def _check_initial_yield(self) -> Swift:
        y0 = self.initial_yield_stress()
        if not 0.0 < y0 < math.inf:
            raise field_error(
                "B",
                f"the initial yield stress B C^n = {y0:g} Pa is not a finite positive stress; "
                "check the magnitudes of B [Pa] and C",
            )
        return self


class Linear(_Plastic):
    """Linear hardening σ_Y = σ_Y0 + H εp."""

    law: Literal["linear"] = "linear"
    yield_stress: PositiveFloat = Field(description="initial yield stress σ_Y0 [Pa]")
    modulus: NonNegativeFloat = Field(description="plastic hardening modulus H [Pa]")

    def initial_yield_stress(self) -> float:
        """σ_Y0 [Pa]."""
        return self.yield_stress


class PerfectlyPlastic(_Plastic):
    """No hardening: σ_Y constant."""

    law: Literal["perfectly_plastic"] = "perfectly_plastic"
    yield_stress: PositiveFloat = Field(description="yield stress σ_Y [Pa]")

    def initial_yield_stress(self) -> float:
        """σ_Y [Pa]."""
        return self.yield_stress


class Tabular(_Plastic):
    """Piecewise-linear measured hardening curve σ_Y(εp) through the given points.

    Beyond the last point the curve stays at the last stress (``beyond_last = "constant"``,
    the default: no hardening past what was measured, hardening modulus 0 there) or continues
    with the slope of the last segment (``"extrapolate"``).
    """

    law: Literal["tabular"] = "tabular"
    plastic_strain: tuple[NonNegativeFloat, ...] = Field(
        min_length=2, description="equivalent plastic strains, from 0, strictly increasing"
    )
    stress: tuple[PositiveFloat, ...] = Field(
        min_length=2, description="yield stresses at those strains [Pa], non-decreasing"
    )
    beyond_last: Literal["constant", "extrapolate"] = Field(
        "constant",
        description='yield stress beyond the last point: "constant" (default) keeps the last '
        'stress (hardening modulus 0); "extrapolate" continues the last segment\'s slope',
    )

    def initial_yield_stress(self) -> float:
        """σ_Y(0), the first stress [Pa]."""
        return self.stress[0]

    @model_validator(mode="after")
    def _check_curve(self) -> Tabular:
        if len(self.stress) != len(self.plastic_strain):
            raise field_error("stress", "must have one value per plastic_strain point")
        if self.plastic_strain[0] != 0.0:
            raise field_error("plastic_strain", "must start at 0 (the initial yield point)")
        if not strictly_increasing(self.plastic_strain):
            raise field_error("plastic_strain", "must be strictly increasing")
        if any(b < a for a, b in zip(self.stress, self.stress[1:], strict=False)):
            raise field_error("stress", "must be non-decreasing (no softening)")
        e, sig = self.plastic_strain, self.stress
        for i in range(len(e) - 1):
            if not (sig[i + 1] - sig[i]) / (e[i + 1] - e[i]) < math.inf:
                raise field_error(
                    "plastic_strain",
                    f"points {i} and {i + 1} are too close for their stress rise: the "
                    "hardening slope is not a finite number; space them further apart",
                )
        return self


HardeningLaw = Annotated[
    Elastic | Swift | Linear | PerfectlyPlastic | Tabular, Field(discriminator="law")
]
