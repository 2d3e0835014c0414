"""Plain containers passed from the solver to the store: no xarray, no I/O.

The solver yields one :class:`State` per load increment; the storage layer alone turns it into
labelled data (:mod:`sacflow.storage.run_variables` holds the one table of dimensions, units and
long names; :mod:`sacflow.storage.run_layout` writes it). All arrays are float64 in SI units on
the body-fixed grid described by :class:`GridCoords`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sacflow.mechanics.stress_measures import COMPONENTS  # the (..., 6) order, re-exported

__all__ = [
    "COMPONENTS",
    "OPTIONAL_RESTART_FIELDS",
    "TRACTION_COMPONENTS",
    "RESTART_FIELDS",
    "GridCoords",
    "INCLUSION_FIELDS",
    "INCLUSION_SCALARS",
    "MeasuredSurface",
    "State",
    "SCALAR_FIELDS",
    "SURFACE_FIELDS",
    "VOLUME_FIELDS",
]

#: Components of the surface shear traction (``shear_traction``): along x1 and along x2.
TRACTION_COMPONENTS: tuple[str, ...] = ("1", "2")

#: Per-step scalars, in the order the store writes them.
SCALAR_FIELDS: tuple[str, ...] = (
    "load",
    "approach",
    "load_x1",
    "load_x2",
    "contact_area",
    "max_pressure",
    "contact_iterations",
    "plasticity_iterations",
    "converged",
    "contact_converged",
    "plasticity_converged",
    "coupling_converged",
    "contact_residual",
    "plasticity_residual",
    "coupling_residual",
    "segment",
    "pass",
    "substeps",
)
#: Surface fields, arrays of shape (nx1, nx2), or (nx1, nx2, 2) for the shear traction.
SURFACE_FIELDS: tuple[str, ...] = (
    "pressure",
    "shear_traction",
    "gap",
    "geometry",
    "residual_displacement",
    "surface_displacement",
)
#: Volume fields, arrays of shape (nx1, nx2, nx3) or (nx1, nx2, nx3, 6).
VOLUME_FIELDS: tuple[str, ...] = (
    "plastic_strain",
    "equivalent_plastic_strain",
    "backstress",
    "residual_stress",
    "stress",
    "von_mises",
    "yield_stress",
)

#: Volume fields of a body with elastic inhomogeneities only: the equivalent eigenstrain of
#: Eshelby's method, (nx1, nx2, nx3, 6), zero outside the inhomogeneities, and the phase of
#: each cell, (nx1, nx2, nx3) integers (0 the matrix, k the k-th inhomogeneity of the case).
INCLUSION_FIELDS: tuple[str, ...] = ("equivalent_eigenstrain", "phase")
#: Per-step scalars of a body with elastic inhomogeneities only: the Krylov iterations of the
#: equivalent-eigenstrain solves of the step (summed over its fixed-point iterations).
INCLUSION_SCALARS: tuple[str, ...] = ("inclusion_iterations",)

#: What the solver needs to go on after a step (true resume), each stored with the step:
#: the body's internal variables (plastic strain tensor, equivalent plastic strain), the residual
#: surface displacement and the contact pressure (the warm start of the next contact solve),
#: all on the body grid, named as the output fields they equal. The residual stress is not
#: among them: it is recomputed from the plastic strain (one operator application).
RESTART_FIELDS: tuple[str, ...] = (
    "plastic_strain",
    "equivalent_plastic_strain",
    "residual_displacement",
    "pressure",
)
#: Internal variables of some bodies only, kept with the step when the solver has them: the
#: backstress of kinematic hardening, the equivalent eigenstrain of elastic inhomogeneities
#: (the warm start of the next step's; a resume without it re-solves it from zero).
OPTIONAL_RESTART_FIELDS: tuple[str, ...] = ("backstress", "equivalent_eigenstrain")


@dataclass(frozen=True)
class GridCoords:
    """Cell-centre coordinates of the body-fixed grid [m].

    ``x1``, ``x2`` are the surface cell centres (body frame), ``x3`` the centres of the cuboid
    layers (depth, positive into the body). Volume fields are stored on (x1, x2, x3); cells outside
    the plastic box where a field was not computed hold NaN.
    """

    x1: np.ndarray
    x2: np.ndarray
    x3: np.ndarray

    @property
    def shape(self) -> tuple[int, int, int]:
        """(nx1, nx2, nx3)."""
        return (self.x1.size, self.x2.size, self.x3.size)


@dataclass
class State:
    """One converged load increment.

    Scalars follow :data:`SCALAR_FIELDS`: each loop's final residual (contact: relative gap
    error; plasticity: relative fixed-point residual of the plastic strain increment; coupling:
    relative change of the residual surface displacement) and whether it met its tolerance;
    ``converged`` is all three; ``pass_index`` (stored as ``pass``) the rolling pass the step
    belongs to (:class:`~sacflow.solver.layout.StepPlan`); ``substeps`` the sub-increments the step
    was
    solved in (1, or more after a cutback: :meth:`sacflow.solver.simulation.Simulation.run`).
    ``surface``
    maps names of :data:`SURFACE_FIELDS` to (nx1, nx2) arrays; ``volume`` maps names of
    :data:`VOLUME_FIELDS` to arrays, and is empty on steps where volume output is skipped
    (Output.volume_every; repeated rolling stores it at the end of every pass too).
    ``restart`` maps the names of :data:`RESTART_FIELDS` to the solver's state after the step
    and ``first_contact_offset`` is the initial-gap offset of the first contact [m] (the origin
    of the approach): with them a run goes on after this step without replaying it (empty for
    simulations that cannot). ``inclusion_iterations`` (:data:`INCLUSION_SCALARS`) counts the
    GMRES iterations of the equivalent-eigenstrain solves of the step (0 without elastic
    inhomogeneities); the volume fields of a body with inhomogeneities add
    :data:`INCLUSION_FIELDS`.
    """

    step: int
    segment: int
    load: float
    approach: float
    load_x1: float
    load_x2: float
    contact_area: float
    max_pressure: float
    contact_iterations: int
    plasticity_iterations: int
    converged: bool = True
    contact_converged: bool = True
    plasticity_converged: bool = True
    coupling_converged: bool = True
    contact_residual: float = 0.0
    plasticity_residual: float = 0.0
    coupling_residual: float = 0.0
    surface: dict[str, np.ndarray] = field(default_factory=dict)
    volume: dict[str, np.ndarray] = field(default_factory=dict)
    restart: dict[str, np.ndarray] = field(default_factory=dict)
    first_contact_offset: float | None = None
    pass_index: int = 0
    substeps: int = 1
    inclusion_iterations: int = 0

    def scalars(self) -> dict[str, float | int | bool]:
        """Return the per-step scalars as a dict keyed by :data:`SCALAR_FIELDS`."""
        return {name: getattr(self, _ATTRIBUTE.get(name, name)) for name in SCALAR_FIELDS}


#: State attribute of a scalar whose name is a Python keyword.
_ATTRIBUTE = {"pass": "pass_index"}


@dataclass(frozen=True)
class MeasuredSurface:
    """A measured surface: heights [m] on the grid ``x1`` × ``x2`` [m], shape (nx1, nx2)."""

    x1: np.ndarray
    x2: np.ndarray
    height: np.ndarray
