"""Plain containers passed from the solver to the store: no xarray, no I/O.

The solver yields one :class:`State` per load increment; :mod:`sacflow.store` is the only module
that turns it into labelled data (DESIGN §4). All arrays are float64 in SI units on the body-fixed
grid described by :class:`GridCoords`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["COMPONENTS", "GridCoords", "State", "SCALAR_FIELDS", "SURFACE_FIELDS", "VOLUME_FIELDS"]

#: Tensor component order of every (..., 6) array (seed appendix 1 order).
COMPONENTS: tuple[str, ...] = ("11", "22", "33", "12", "13", "23")

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
    "segment",
)
#: Surface fields, arrays of shape (nx1, nx2).
SURFACE_FIELDS: tuple[str, ...] = (
    "pressure",
    "gap",
    "geometry",
    "residual_displacement",
    "surface_displacement",
)
#: Volume fields, arrays of shape (nx1, nx2, nx3) or (nx1, nx2, nx3, 6).
VOLUME_FIELDS: tuple[str, ...] = (
    "plastic_strain",
    "equivalent_plastic_strain",
    "residual_stress",
    "stress",
    "von_mises",
    "yield_stress",
)


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

    Scalars follow :data:`SCALAR_FIELDS`; ``surface`` maps names of :data:`SURFACE_FIELDS` to
    (nx1, nx2) arrays; ``volume`` maps names of :data:`VOLUME_FIELDS` to arrays, and is empty on
    steps where volume output is skipped (Output.volume_every).
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
    surface: dict[str, np.ndarray] = field(default_factory=dict)
    volume: dict[str, np.ndarray] = field(default_factory=dict)

    def scalars(self) -> dict[str, float | int | bool]:
        """Return the per-step scalars as a dict keyed by :data:`SCALAR_FIELDS`."""
        return {name: getattr(self, name) for name in SCALAR_FIELDS}
