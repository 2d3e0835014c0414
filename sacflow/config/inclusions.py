"""Elastic inhomogeneities of body 1: ``[[body.inhomogeneity]]`` (issue #33).

An inhomogeneity is a region of body 1 with its own elastic constants (a non-metallic inclusion
of a bearing steel: alumina, titanium nitride, manganese sulphide; a cavity as the limit of a
vanishing modulus). The solver replaces it by the equivalent eigenstrain of Eshelby's method
(Mura, *Micromechanics of Defects in Solids*, §22), ε* = (S* − S) : σ on its cells, S and S* the
compliances of the matrix and of the inhomogeneity. Its shape is a sphere (``radius``), an
ellipsoid with axes along x1, x2, x3 (``semi_axes``), a cuboid (``half_sides``), or a set of
cells read from a file (``cells``, read by :mod:`sacflow.storage.inclusion_cells_file`). The
inhomogeneity stays elastic whatever the body's hardening law: per-inhomogeneity hardening is
refused with a message saying so. The checks that need the grid (inside the cuboid box,
resolved by enough cells, no overlap) are in :mod:`sacflow.config.inclusion_checks`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

from pydantic import Field, model_validator

from sacflow.config.base import FiniteFloat, Model, PoissonRatio, PositiveFloat, field_error

__all__ = ["SIZE_FIELDS", "Inhomogeneity"]

#: The size field each shape takes (``cells``: the file of cell centres).
SIZE_FIELDS: dict[str, str] = {
    "sphere": "radius",
    "ellipsoid": "semi_axes",
    "cuboid": "half_sides",
    "cells": "cells",
}


class Inhomogeneity(Model):
    """One elastic inhomogeneity of body 1 (an entry of ``[[body.inhomogeneity]]``)."""

    shape: Literal["sphere", "ellipsoid", "cuboid", "cells"] = Field(
        description="sphere (radius), ellipsoid with axes along x1, x2, x3 (semi_axes), cuboid "
        "(half_sides), or cells (a file of cell centres)"
    )
    centre: tuple[FiniteFloat, FiniteFloat, FiniteFloat] | None = Field(
        None,
        description="centre (x1, x2, x3) [m], body frame, x3 the depth below the surface "
        "(positive); not with shape = \"cells\"",
    )
    radius: PositiveFloat | None = Field(None, description="sphere radius [m]")
    semi_axes: tuple[PositiveFloat, PositiveFloat, PositiveFloat] | None = Field(
        None, description="ellipsoid semi-axes (a1, a2, a3) along x1, x2, x3 [m]"
    )
    half_sides: tuple[PositiveFloat, PositiveFloat, PositiveFloat] | None = Field(
        None, description="cuboid half-sides along x1, x2, x3 [m]"
    )
    cells: Path | None = Field(
        None,
        description="file of the region's cell centres: three columns x1 x2 x3 [m] (relative to "
        "the case file); each point marks the body cell that contains it",
    )
    E: PositiveFloat = Field(
        description="Young's modulus of the inhomogeneity [Pa], > 0; for a cavity give a small "
        "one (1e-3 of the body's): with E = 0 the equivalent eigenstrain is unbounded"
    )
    nu: PoissonRatio = Field(description="Poisson's ratio of the inhomogeneity")

    @model_validator(mode="before")
    @classmethod
    def _no_own_hardening(cls, data: Any) -> Any:
        if isinstance(data, dict) and "hardening" in data:
            raise field_error(
                "hardening",
                "an inhomogeneity has no hardening law of its own: it stays elastic (E, nu), "
                "the body's hardening applies to the matrix only; remove it",
            )
        return data

    @model_validator(mode="after")
    def _check_size(self) -> Inhomogeneity:
        wanted = SIZE_FIELDS[self.shape]
        if getattr(self, wanted) is None:
            raise field_error(wanted, f'required for shape = "{self.shape}"; add it')
        for name in SIZE_FIELDS.values():
            if name != wanted and getattr(self, name) is not None:
                raise field_error(name, f'not used by shape = "{self.shape}" (it takes '
                                  f"{wanted}); remove it")
        if self.shape == "cells":
            if self.centre is not None:
                raise field_error("centre", 'not used by shape = "cells" (the file gives the '
                                  "cell centres); remove it")
            return self
        if self.centre is None:
            raise field_error("centre", f'required for shape = "{self.shape}"; add centre = '
                              "[x1, x2, x3] [m], x3 the depth")
        depth, half_height = self.centre[2], self.semi_axes_m()[2]
        if depth - half_height < 0.0:
            raise field_error(
                "centre",
                f"the inhomogeneity reaches above the surface: centre depth x3 = {depth:.4g} m "
                f"is less than its half-height {half_height:.4g} m along x3; put it deeper "
                "(x3 is positive into the body)",
            )
        return self

    def semi_axes_m(self) -> tuple[float, float, float]:
        """Semi-axes (a1, a2, a3) [m]: the radius three times, the half-sides; zeros for cells."""
        if self.radius is not None:
            return (self.radius, self.radius, self.radius)
        size = self.semi_axes or self.half_sides
        return (0.0, 0.0, 0.0) if size is None else (size[0], size[1], size[2])
