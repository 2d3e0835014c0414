"""The phase of each cell of the body grid: the matrix, or one of the elastic inhomogeneities.

A cell belongs to an inhomogeneity when its centre is inside the region (sphere, ellipsoid with
axes along x1, x2, x3, cuboid), or, for a region given as a set of points, when it contains one
of them. The phase field is the input of Eshelby's equivalent inclusion method
(:mod:`sacflow.solver.inclusion`): a staircase approximation of the region on the cuboids of the
eigenstrain operator, as in the semi-analytical literature (Zhou, Keer & Wang, Int. J. Numer.
Meth. Engng 79 (2009) 1009; Leroux, Fulleringer & Nélias, Int. J. Solids Struct. 47 (2010)
2243).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from sacflow.solver.inputs import Inhomogeneity

__all__ = ["MATRIX", "phase_field", "region_mask"]

#: Phase of the cells of the matrix (the inhomogeneities are 1, 2, ... in the order given).
MATRIX = 0


def region_mask(inhomogeneity: Inhomogeneity, x1: np.ndarray, x2: np.ndarray,
                x3: np.ndarray) -> np.ndarray:
    """Cells (n1, n2, nz) of the grid of cell centres ``x1``, ``x2``, ``x3`` [m] in the region.

    Sphere and ellipsoid: ``Σ ((x_i − c_i) / a_i)² <= 1`` at the cell centre; cuboid:
    ``|x_i − c_i| <= a_i`` for the three axes; ``cells``: the cells containing the listed points
    (the grid's cells are centred on ``x1``, ``x2``, ``x3``, uniformly spaced).

    Raises
    ------
    ValueError
        When a listed point is outside the grid, or ``cells`` lists none.
    """
    shape = (x1.size, x2.size, x3.size)
    if inhomogeneity.shape == "cells":
        return _cells_mask(inhomogeneity.cells, (x1, x2, x3), shape)
    axes = [np.asarray(x, dtype=float) - c for x, c in zip((x1, x2, x3), inhomogeneity.centre,
                                                           strict=True)]
    d1, d2, d3 = (a / s for a, s in zip(axes, inhomogeneity.semi_axes, strict=True))
    if inhomogeneity.shape == "cuboid":
        inside: np.ndarray = ((np.abs(d1) <= 1.0)[:, None, None]
                              & (np.abs(d2) <= 1.0)[None, :, None]
                              & (np.abs(d3) <= 1.0)[None, None, :])
        return inside
    radius = d1[:, None, None] ** 2 + d2[None, :, None] ** 2 + d3[None, None, :] ** 2
    inside = radius <= 1.0
    return inside


def _cells_mask(points: np.ndarray | None, centres: Sequence[np.ndarray],
                shape: tuple[int, int, int]) -> np.ndarray:
    """Cells containing ``points`` (k, 3) [m] on the uniform grid of cell ``centres``."""
    if points is None or np.size(points) == 0:
        raise ValueError("an inhomogeneity of shape 'cells' needs at least one point")
    pts = np.asarray(points, dtype=float).reshape(-1, 3)
    index = []
    for axis, x in enumerate(centres):
        step = float(x[1] - x[0]) if x.size > 1 else 2.0 * float(x[0])
        i = np.floor((pts[:, axis] - (x[0] - step / 2)) / step).astype(int)
        if (i < 0).any() or (i >= x.size).any():
            raise ValueError(f"a point of an inhomogeneity's cells is outside the grid along "
                             f"x{axis + 1}")
        index.append(i)
    mask = np.zeros(shape, dtype=bool)
    mask[index[0], index[1], index[2]] = True
    return mask


def phase_field(inhomogeneities: Sequence[Inhomogeneity], x1: np.ndarray, x2: np.ndarray,
                x3: np.ndarray) -> np.ndarray:
    """Phase of every cell, int8 (n1, n2, nz): :data:`MATRIX`, or k for the k-th inhomogeneity.

    Where regions overlap the later one wins.
    """
    phase = np.full((x1.size, x2.size, x3.size), MATRIX, dtype=np.int8)
    for k, inhomogeneity in enumerate(inhomogeneities, 1):
        phase[region_mask(inhomogeneity, x1, x2, x3)] = k
    return phase
