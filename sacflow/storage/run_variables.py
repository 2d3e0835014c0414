"""The run files' variable table: names, dimensions, units, long names and netCDF types.

Computation and metadata are separate layers: the numerical core hands bare arrays over in a
:class:`~sacflow.solver.state.State`, and the storage layer attaches dims, units and long names
from :data:`VARIABLES`, the one place this metadata lives (:mod:`sacflow.storage.run_layout`
turns it into a netCDF file; :mod:`sacflow.compare` reuses it for the units of compared
fields).

A run file has the dimensions ``step`` (unlimited), ``x1``, ``x2``, ``x3``, ``component``
(``11 22 33 12 13 23``) and, when it stores the shear traction, ``direction`` (``1 2``).

:data:`VARIABLES` are those of every run; :data:`INHOMOGENEITY_VARIABLES` those of a body with
elastic inhomogeneities only (the equivalent eigenstrain, the phase of each cell, the Krylov
iterations per step), not in the default selection (:func:`selected_fields`), so the file of a
homogeneous run is as it was before they existed; :data:`RUN_VARIABLES` holds both, the table
the writer and the readers look a name up in.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import NamedTuple

from sacflow.solver.state import COMPONENTS, TRACTION_COMPONENTS, GridCoords

__all__ = [
    "COORDINATES",
    "INHOMOGENEITY_VARIABLES",
    "PHASE_FILL",
    "RUN_VARIABLES",
    "SCALAR",
    "SURFACE",
    "SURFACE_VECTOR",
    "TENSOR",
    "VARIABLES",
    "VOLUME",
    "Variable",
    "dimension_sizes",
    "selected_fields",
]

#: Dimensions of a per-step scalar.
SCALAR = ("step",)
#: Dimensions of a surface field.
SURFACE = ("step", "x1", "x2")
#: Dimensions of a surface vector (the shear traction's two components).
SURFACE_VECTOR = ("step", "x1", "x2", "direction")
#: Dimensions of a scalar volume field.
VOLUME = ("step", "x1", "x2", "x3")
#: Dimensions of a symmetric tensor volume field (six, :data:`~sacflow.solver.state.COMPONENTS`).
TENSOR = ("step", "x1", "x2", "x3", "component")


class Variable(NamedTuple):
    """Layout and CF metadata of one stored variable."""

    dims: tuple[str, ...]
    units: str
    long_name: str
    dtype: str = "f8"  # netCDF type; "bool" is stored as i1 flags


#: Every stored variable: dims, units, long name, netCDF type; the one place run metadata lives.
VARIABLES: dict[str, Variable] = {
    # per-step scalars
    "load": Variable(SCALAR, "N", "applied normal load"),
    "approach": Variable(
        SCALAR, "m",
        "rigid-body approach of the counter-body since first contact (at zero load: where it "
        "touches the deformed surface, the residual print depth after unloading)"),
    "load_x1": Variable(SCALAR, "m", "load position along x1 (body frame)"),
    "load_x2": Variable(SCALAR, "m", "load position along x2 (body frame)"),
    "contact_area": Variable(SCALAR, "m2", "contact area"),
    "max_pressure": Variable(SCALAR, "Pa", "maximum contact pressure"),
    "contact_iterations": Variable(SCALAR, "1", "elastic contact iterations", "i4"),
    "plasticity_iterations": Variable(SCALAR, "1", "plasticity iterations", "i4"),
    "converged": Variable(SCALAR, "1", "every loop of the increment met its tolerance", "bool"),
    "contact_converged": Variable(SCALAR, "1", "the contact solve met its tolerance", "bool"),
    "plasticity_converged": Variable(
        SCALAR, "1", "the plastic strain fixed point met its tolerance", "bool"),
    "coupling_converged": Variable(
        SCALAR, "1", "the contact-plasticity coupling met its tolerance", "bool"),
    "contact_residual": Variable(
        SCALAR, "1", "final relative gap error of the contact solve"),
    "plasticity_residual": Variable(
        SCALAR, "1", "final relative residual of the plastic strain increment"),
    "coupling_residual": Variable(
        SCALAR, "1", "final relative change of the residual surface displacement"),
    "segment": Variable(SCALAR, "1", "index of the load path segment", "i4"),
    "pass": Variable(SCALAR, "1", "rolling pass of the step, from 0", "i4"),
    "substeps": Variable(
        SCALAR, "1", "sub-increments the step was solved in (1: the step itself; more: it was "
        "cut back after not converging)", "i4"),
    # surface fields
    "pressure": Variable(SURFACE, "Pa", "contact pressure"),
    "shear_traction": Variable(
        SURFACE_VECTOR, "Pa", "shear traction on the surface of body 1 (components along x1, x2)"
    ),
    "gap": Variable(SURFACE, "m", "gap between the surfaces"),
    "geometry": Variable(SURFACE, "m", "initial gap including surface features"),
    "residual_displacement": Variable(
        SURFACE, "m", "normal surface displacement due to plastic strain, positive into the body"
    ),
    "surface_displacement": Variable(SURFACE, "m", "normal surface displacement"),
    # volume fields
    "plastic_strain": Variable(TENSOR, "1", "plastic strain tensor"),
    "equivalent_plastic_strain": Variable(VOLUME, "1", "equivalent plastic strain"),
    "backstress": Variable(TENSOR, "Pa", "backstress tensor of kinematic hardening"),
    "residual_stress": Variable(TENSOR, "Pa", "residual stress tensor"),
    "stress": Variable(TENSOR, "Pa", "stress tensor (contact pressure and residual)"),
    "von_mises": Variable(VOLUME, "Pa", "von Mises equivalent stress"),
    "yield_stress": Variable(VOLUME, "Pa", "current yield stress"),
}
#: Variables of a body with elastic inhomogeneities only (``[[body.inhomogeneity]]``).
INHOMOGENEITY_VARIABLES: dict[str, Variable] = {
    "inclusion_iterations": Variable(
        SCALAR, "1", "Krylov iterations of the equivalent-eigenstrain solves of the step", "i4"),
    "equivalent_eigenstrain": Variable(
        TENSOR, "1", "equivalent eigenstrain of Eshelby's method in the inhomogeneities"),
    "phase": Variable(
        VOLUME, "1", "phase of the cell: 0 the matrix, k the k-th inhomogeneity (from 1)", "i1"),
}
#: Every variable a run file may hold, in the order files store them: the lookup table.
RUN_VARIABLES: dict[str, Variable] = {**VARIABLES, **INHOMOGENEITY_VARIABLES}
#: Fill value of ``phase`` on steps where the volume fields are not stored (read back as NaN).
PHASE_FILL = -1
#: Coordinate variables: dims, units, long name, type.
COORDINATES: dict[str, Variable] = {
    "step": Variable(("step",), "1", "load increment index", "i4"),
    "x1": Variable(("x1",), "m", "surface cell centre along x1 (body frame)"),
    "x2": Variable(("x2",), "m", "surface cell centre along x2 (body frame)"),
    "x3": Variable(("x3",), "m", "depth of the cuboid centre, positive into the body"),
    "component": Variable(("component",), "1", "tensor component", "str"),
    "direction": Variable(("direction",), "1", "surface direction of a traction component",
                          "str"),
}


def selected_fields(fields: Iterable[str] | None) -> list[str]:
    """Return the stored variables asked for, in table order.

    None selects :data:`VARIABLES` (a homogeneous body's); names may be any of
    :data:`RUN_VARIABLES`.

    Raises
    ------
    ValueError
        Naming the unknown fields and the known ones.
    """
    if fields is None:
        return list(VARIABLES)
    fields = set(fields)
    unknown = fields - set(RUN_VARIABLES)
    if unknown:
        raise ValueError(f"unknown output fields {sorted(unknown)}; known: {list(RUN_VARIABLES)}")
    return [name for name in RUN_VARIABLES if name in fields]


def dimension_sizes(coords: GridCoords) -> dict[str, int]:
    """Return the length of every fixed dimension on the grid ``coords``."""
    return dict(zip(("x1", "x2", "x3"), coords.shape, strict=True), component=len(COMPONENTS),
                direction=len(TRACTION_COMPONENTS))
