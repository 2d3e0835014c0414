"""The two bodies and their surfaces: body 1, the counter-body, surfaces, friction, initial state.

Body 1 is the elastic-plastic half-space (its material in :mod:`sacflow.config.materials`); the
counter-body is rigid or elastic, a sphere or an ellipsoid. The surface of body 1 is smooth,
dented or measured (a file, read by :mod:`sacflow.storage.surface_file`); a shear traction
(``[friction]``) acts on the contact; a chained case starts from a stored run's state
(``initial_state``, read by :mod:`sacflow.storage.initial_state_file`). Body 1 may hold elastic
inhomogeneities (``[[body.inhomogeneity]]``, :mod:`sacflow.config.inclusions`).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Literal

from pydantic import Field, field_validator, model_validator

from sacflow.config.base import (
    FiniteFloat,
    Model,
    NonNegativeFloat,
    PoissonRatio,
    PositiveFloat,
    Radius,
    field_error,
    unit_vector,
)
from sacflow.config.inclusions import Inhomogeneity, check_own_hardening
from sacflow.config.materials import HardeningLaw, InitialHardening, InitialResidualStress

__all__ = [
    "Body",
    "Counterbody",
    "Dent",
    "Dented",
    "Friction",
    "InitialState",
    "Measured",
    "Smooth",
    "Surface",
]


class Body(Model):
    """The elastic-plastic half-space (body 1)."""

    E: PositiveFloat = Field(description="Young's modulus of the body [Pa]")
    nu: PoissonRatio = Field(description="Poisson's ratio of the body")
    radii: tuple[Radius, Radius] = Field(
        (math.inf, math.inf),
        description="principal radii of curvature along x1, x2 [m] (inf = flat)",
    )
    hardening: HardeningLaw = Field(description="hardening law of the body, chosen by 'law'")
    initial_residual_stress: InitialResidualStress | None = Field(
        None, description="residual stress before any contact, σ11 and σ22 vs depth"
    )
    initial_hardening: InitialHardening | None = Field(
        None, description="equivalent plastic strain before any contact vs depth"
    )
    inhomogeneity: tuple[Inhomogeneity, ...] = Field(
        (),
        description="inhomogeneities of the body ([[body.inhomogeneity]]): regions with "
        "their own E and nu, solved by Eshelby's equivalent inclusion method; elastic unless "
        "given a hardening law of their own",
    )

    @model_validator(mode="after")
    def _check_initial(self) -> Body:
        if self.initial_hardening is not None and self.hardening.law == "elastic":
            raise field_error("initial_hardening", "an elastic body has no hardening; remove it "
                              "or give a plastic law")
        check_own_hardening(self.hardening, self.inhomogeneity)
        return self


class Counterbody(Model):
    """The counter-body: rigid or elastic, a sphere (``radius``) or an ellipsoid (``radii``)."""

    kind: Literal["rigid", "elastic"] = Field(description="rigid or elastic counter-body")
    E: PositiveFloat | None = Field(None, description="Young's modulus of the counterbody [Pa]")
    nu: PoissonRatio | None = Field(None, description="Poisson's ratio of the counterbody")
    radius: Radius | None = Field(None, description="sphere radius [m]")
    radii: tuple[Radius, Radius] | None = Field(
        None, description="principal radii of curvature along x1, x2 [m] (ellipsoid)"
    )

    @model_validator(mode="after")
    def _check_counterbody(self) -> Counterbody:
        if (self.radius is None) == (self.radii is None):
            raise field_error("radius", "give exactly one of radius (sphere) or radii (ellipsoid)")
        for name in ("E", "nu"):
            given = getattr(self, name) is not None
            if self.kind == "elastic" and not given:
                raise field_error(name, f'required when kind = "elastic"; add counterbody.{name}')
            if self.kind == "rigid" and given:
                raise field_error(
                    name,
                    f'not allowed when kind = "rigid"; remove counterbody.{name} '
                    'or set kind = "elastic"',
                )
        return self

    @property
    def principal_radii(self) -> tuple[float, float]:
        """Principal radii of curvature (R1, R2) along x1, x2 [m]."""
        if self.radii is not None:
            return self.radii
        assert self.radius is not None  # guaranteed by validation
        return (self.radius, self.radius)


# --------------------------------------------------------------------------- surfaces
class Smooth(Model):
    """Smooth surfaces: the gap is the quadratic Hertz geometry only."""

    kind: Literal["smooth"] = "smooth"


class Dent(Model):
    """A dent on body 1: profile A cos(2π r/w) exp(-decay r²/w²), a hollow of depth A."""

    depth: PositiveFloat = Field(description="dent amplitude A [m]")
    width: PositiveFloat = Field(description="dent width w [m]")
    decay: PositiveFloat = Field(13.0, description="decay coefficient of the envelope")
    x1: FiniteFloat = Field(0.0, description="dent centre along x1 [m] (body frame)")
    x2: FiniteFloat = Field(0.0, description="dent centre along x2 [m] (body frame)")


class Dented(Model):
    """A smooth surface with one or more dents."""

    kind: Literal["dented"] = "dented"
    dents: tuple[Dent, ...] = Field(min_length=1, description="the dents on body 1")


class Measured(Model):
    """A measured surface read from a file (x1, x2, height grid)."""

    kind: Literal["measured"] = "measured"
    path: Path = Field(description="surface file (relative to the config file)")
    format: Literal["auto", "netcdf", "text"] = Field(
        "auto", description="file format; auto: netCDF for .nc files, else x1 x2 height columns"
    )
    variable: str = Field("height", description="name of the height variable in a netCDF file")


Surface = Annotated[Smooth | Dented | Measured, Field(discriminator="kind")]


# --------------------------------------------------------------------------- surface traction
class Friction(Model):
    """Shear traction q = μ p on the contact, along one direction (full sliding).

    The traction acts on the surface of body 1 (the half-space) along ``direction``: where the
    counter-body slides over body 1 with velocity v (relative to body 1), friction drags body
    1's surface along v, so ``direction`` = v / |v|. In rolling, μ is the traction
    coefficient Q/P and q = μ p everywhere in the contact (the full-slip limit of tractive
    rolling); ``direction`` along the rolling direction means the counter-body drags body 1's
    surface forward (its own surface moves faster than body 1's). The normal-tangential
    coupling is neglected: the tangential traction does not change the contact pressure,
    exact when the pair's Dundurs constant β is 0 (elastically similar bodies, as steel on
    steel; Johnson, Contact Mechanics, 1985, §5.1, §7.1); against a rigid counter-body
    (|β| = (1 − 2ν)/(2(1 − ν)) = 0.29 for ν = 0.3) an approximation.
    """

    coefficient: NonNegativeFloat = Field(
        description="friction (or traction) coefficient μ = q / p, >= 0"
    )
    direction: tuple[FiniteFloat, FiniteFloat] = Field(
        (1.0, 0.0),
        description="direction (d1, d2) of the shear traction on body 1 in the surface plane, "
        "normalised",
    )

    @field_validator("direction")
    @classmethod
    def _normalise(cls, value: tuple[float, float]) -> tuple[float, float]:
        return unit_vector(value)



class InitialState(Model):
    """Start from a state stored by another run (a dent made by an indentation, then rolled).

    The plastic strain tensor and the equivalent plastic strain of the stored step are taken
    (interpolated onto this case's body grid when the grids differ); the residual stress and the
    residual surface displacement follow from them on this grid. The run file records the
    source's case id and step.
    """

    run: Path = Field(description="run file of the source (relative to the case file)")
    step: int = Field(
        -1, description="which stored step: 0, 1, ... from the first, -1, -2, ... from the last"
    )
    offset: tuple[FiniteFloat, FiniteFloat] = Field(
        (0.0, 0.0), description="shift of the source's body frame in this case's frame [m]"
    )

