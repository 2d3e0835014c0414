"""Elastic inhomogeneities of body 1: ``[[body.inhomogeneity]]`` (issue #33).

An inhomogeneity is a region of body 1 with its own elastic constants (a non-metallic inclusion
of a bearing steel: alumina, titanium nitride, manganese sulphide; a cavity as the limit of a
vanishing modulus). The solver replaces it by the equivalent eigenstrain of Eshelby's method
(Mura, *Micromechanics of Defects in Solids*, §22), ε* = (S* − S) : σ on its cells, S and S* the
compliances of the matrix and of the inhomogeneity. Its shape is a sphere (``radius``), an
ellipsoid with axes along x1, x2, x3 (``semi_axes``), a cuboid (``half_sides``), or a set of
cells read from a file (``cells``, read by :mod:`sacflow.storage.inclusion_cells_file`). An
inhomogeneity stays elastic unless it has a ``hardening`` table of its own (the laws of
``body.hardening``; ``law = "elastic"`` is the same as none): its cells then carry their own
plastic strain, returned with that law and their own shear modulus
(:mod:`sacflow.solver.own_hardening`); such a table needs a plastic body, and a kinematic part
needs the body's (the backstress is the body's field). The checks that need the grid (inside
the cuboid box, resolved by enough cells, no overlap) are in
:mod:`sacflow.config.inclusion_checks`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import Field, field_validator, model_validator

from sacflow.config.base import FiniteFloat, Model, PoissonRatio, PositiveFloat, field_error
from sacflow.config.materials import Elastic, HardeningLaw

__all__ = ["SIZE_FIELDS", "Inhomogeneity", "check_own_hardening"]

#: The size field each shape takes (``cells``: the file of cell centres).
SIZE_FIELDS: dict[str, str] = {
    "sphere": "radius",
    "ellipsoid": "semi_axes",
    "cuboid": "half_sides",
    "cells": "cells",
}


class Inhomogeneity(Model):
    """One inhomogeneity of body 1 (an entry of ``[[body.inhomogeneity]]``)."""

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

    hardening: HardeningLaw | None = Field(
        None,
        description="the inhomogeneity's own hardening law, chosen by 'law' as body.hardening "
        "(absent or law = \"elastic\": it stays elastic); needs a plastic body, and a "
        "kinematic part needs the body's",
    )

    @field_validator("hardening", mode="after")
    @classmethod
    def _elastic_is_none(cls, value: HardeningLaw | None) -> HardeningLaw | None:
        """``law = "elastic"`` is no hardening of its own: the same case as without the table."""
        return None if isinstance(value, Elastic) else value

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


def check_own_hardening(body_hardening: HardeningLaw,
                        items: tuple[Inhomogeneity, ...]) -> None:
    """Refuse an inhomogeneity's own hardening in an elastic body, or its backstress alone.

    The plastic fields, the box sizing and the stored variables of a run follow the body's law
    (an elastic body stores no plastic strain); the backstress is a field of the body, there
    only with the body's kinematic hardening. Raises :func:`~sacflow.config.base.field_error`
    naming ``inhomogeneity.<i>.hardening``.
    """
    body_kinematic = getattr(body_hardening, "kinematic", None) is not None
    for index, item in enumerate(items):
        own = item.hardening
        if own is None:
            continue
        where = f"inhomogeneity.{index}.hardening"
        if isinstance(body_hardening, Elastic):
            raise field_error(where, "an inhomogeneity's own hardening needs a plastic body: "
                              "give body.hardening a plastic law (a perfectly_plastic one with "
                              "a yield stress the matrix never reaches keeps it elastic) or "
                              "remove it")
        if getattr(own, "kinematic", None) is not None and not body_kinematic:
            raise field_error(f"{where}.kinematic", "the backstress is the body's field: add "
                              "[body.hardening.kinematic] or remove this one")
