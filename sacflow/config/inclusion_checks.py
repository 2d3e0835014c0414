"""Checks of a case's inhomogeneities against its grid: inside the box, resolved, apart.

The solver rasterises an inhomogeneity onto the body grid (the cells whose centre lies inside it;
for ``shape = "cells"`` the cells holding the listed points) and solves Eshelby's equivalent
eigenstrain on those cells with the body's cuboid operators. The region must therefore lie in
the cuboid box (laterally within the body grid, the contact window swept along the load path;
in depth above the box bottom, ``grid.depth`` or the automatic depth), be resolved by at least
:data:`MIN_CELLS_PER_SEMI_AXIS` cells per semi-axis along x1, x2 and x3, and share no cell with
another inhomogeneity. The checks of the three analytic shapes run with the case's validation
(:func:`check_inhomogeneities`); those of a cells file where storage reads it
(:func:`cells_problem`). Each message names the field and the fix.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from sacflow.config.base import MAX_CELLS, field_error
from sacflow.config.inclusions import SIZE_FIELDS, Inhomogeneity
from sacflow.config.materials import Elastic
from sacflow.solver.layout import auto_depth, layer_centres

if TYPE_CHECKING:
    from sacflow.config.case import Case

__all__ = [
    "MIN_CELLS_PER_SEMI_AXIS",
    "BodyCells",
    "body_cells",
    "box_depth",
    "cells_problem",
    "check_inhomogeneities",
    "contains",
    "region_cells",
]

#: Least number of cells per semi-axis of a sphere, ellipsoid or cuboid, along each of x1, x2,
#: x3: below it the rasterised region (cells whose centre lies inside) is a few cells whose
#: shape and volume differ from the region's by tens of percent.
MIN_CELLS_PER_SEMI_AXIS = 2.0
_AXES = ("x1", "x2", "x3")


def box_depth(case: Case) -> float:
    """Depth of the cuboid box [m]: ``grid.depth``, or sized on the Hertz field (auto_depth)."""
    if case.grid.depth is not None:
        return case.grid.depth
    from sacflow.config.hardening_laws import hardening_from_schema  # it imports the schema

    body = case.body
    law = None if isinstance(body.hardening, Elastic) else hardening_from_schema(body.hardening)
    hertz = case.hertz()
    return auto_depth(law, hertz.a, hertz.p0, body.nu, case.solver.plastic_margin)


class BodyCells:
    """Cell centres of a case's body grid (as the solver lays them out) and their sizes [m]."""

    def __init__(self, x1: np.ndarray, x2: np.ndarray, x3: np.ndarray,
                 size: tuple[float, float, float]) -> None:
        self.centres = (x1, x2, x3)
        self.size = size

    def bounds(self, axis: int) -> tuple[float, float]:
        """Lowest and highest face of the grid along ``axis`` (0, 1, 2) [m]."""
        c, h = self.centres[axis], 0.5 * self.size[axis]
        return float(c[0] - h), float(c[-1] + h)


def body_cells(case: Case) -> BodyCells:
    """Return the cell centres of the body grid of ``case`` (:class:`BodyCells`).

    Laid out as :class:`sacflow.solver.simulation.Simulation` lays them: the window's cells
    around the load position, swept along the load path, and ``grid.nz`` layers down to
    :func:`box_depth`.
    """
    from sacflow.config.solver_inputs import case_body_grid  # it imports the case schema

    grid = case_body_grid(case)
    (dx1, dx2), depth = case.cell_size(), box_depth(case)
    nx, ny = grid.window
    x1 = (np.arange(grid.body[0]) - grid.origin[0] - nx / 2 + 0.5) * dx1
    x2 = (np.arange(grid.body[1]) - grid.origin[1] - ny / 2 + 0.5) * dx2
    dz = depth / grid.nz
    return BodyCells(x1, x2, layer_centres(grid.nz, dz), (dx1, dx2, dz))


def contains(item: Inhomogeneity, points: np.ndarray) -> np.ndarray:
    """Tell which of ``points`` (..., 3) [m] lie in a sphere, ellipsoid or cuboid (surface in)."""
    assert item.centre is not None  # guaranteed by validation (not for cells)
    scaled = (points - np.array(item.centre)) / np.array(item.semi_axes_m())
    if item.shape == "cuboid":
        return np.asarray((np.abs(scaled) <= 1.0).all(axis=-1))
    return np.asarray((scaled * scaled).sum(axis=-1) <= 1.0)


def region_cells(item: Inhomogeneity, cells: BodyCells,
                 points: np.ndarray | None = None) -> set[tuple[int, int, int]]:
    """Return the indices (i1, i2, i3) of the body cells an inhomogeneity occupies.

    A sphere, ellipsoid or cuboid: the cells whose centre lies inside it (on its surface
    included); ``cells``: the cells holding the points ``points`` (k, 3) [m].
    """
    if item.shape == "cells":
        if points is None or len(points) == 0:
            return set()
        index = _cell_index(points, cells)
        return {(int(a), int(b), int(c)) for a, b, c in index}
    found: set[tuple[int, int, int]] = set()
    near = _near(item, cells)
    for i in near[0]:
        centres = _slice_centres(cells, i, near[1], near[2])
        inside = contains(item, centres)
        found |= {(int(i), int(near[1][b]), int(near[2][c]))
                  for b, c in zip(*np.nonzero(inside), strict=True)}
    return found


def _cell_index(points: np.ndarray, cells: BodyCells) -> np.ndarray:
    """Index (k, 3) of the body cell holding each of ``points`` (k, 3) [m]."""
    low = np.array([cells.bounds(k)[0] for k in range(3)])
    return np.floor((points - low) / np.array(cells.size)).astype(int)


def _near(item: Inhomogeneity, cells: BodyCells) -> list[np.ndarray]:
    """Per axis, the indices of the cell centres within the item's bounding box."""
    assert item.centre is not None  # guaranteed by validation (not for cells)
    semi = item.semi_axes_m()
    return [np.nonzero(np.abs(cells.centres[k] - item.centre[k]) <= semi[k])[0]
            for k in range(3)]


def _slice_centres(cells: BodyCells, i: int, j: np.ndarray, k: np.ndarray) -> np.ndarray:
    """Centres (len(j), len(k), 3) [m] of the cells (i, j, k) of one x1 slice."""
    x2, x3 = np.meshgrid(cells.centres[1][j], cells.centres[2][k], indexing="ij")
    return np.stack([np.full(x2.shape, cells.centres[0][i]), x2, x3], axis=-1)


def _overlap(first: Inhomogeneity, second: Inhomogeneity, cells: BodyCells) -> bool:
    """Tell whether two spheres, ellipsoids or cuboids share a cell (its centre in both).

    Only the cells in both bounding boxes are looked at, one x1 slice at a time.
    """
    a, b = _near(first, cells), _near(second, cells)
    both = [np.intersect1d(a[k], b[k]) for k in range(3)]
    if any(n.size == 0 for n in both):
        return False
    for i in both[0]:
        centres = _slice_centres(cells, i, both[1], both[2])
        if (contains(first, centres) & contains(second, centres)).any():
            return True
    return False


def check_inhomogeneities(case: Case) -> None:
    """Check each sphere, ellipsoid and cuboid of ``case``: in the box, resolved, apart.

    Inhomogeneities of ``shape = "cells"`` are checked where their file is read
    (:func:`cells_problem`). Raises :func:`~sacflow.config.base.field_error` naming the field.
    """
    items = case.body.inhomogeneity
    if not items:
        return
    cells = body_cells(case)
    checked: list[int] = []
    for index, item in enumerate(items):
        if item.shape == "cells":
            continue
        where = f"body.inhomogeneity.{index}"
        _check_inside(item, cells, where)
        _check_resolved(case, item, cells, where)
        for other in checked:
            if _overlap(items[other], item, cells):
                raise field_error(
                    f"{where}.centre",
                    f"overlaps body.inhomogeneity.{other}: cells of both; move them apart or "
                    "merge them into one",
                )
        checked.append(index)


def _check_inside(item: Inhomogeneity, cells: BodyCells, where: str) -> None:
    """Refuse a region reaching beyond the body grid along x1, x2 or below the box bottom."""
    assert item.centre is not None  # guaranteed by validation
    for k, axis in enumerate(_AXES):
        low, high = cells.bounds(k)
        if k == 2:
            low = 0.0
        c, a = item.centre[k], item.semi_axes_m()[k]
        if c - a >= low and c + a <= high:
            continue
        fix = ("deepen the cuboid box (grid.depth, with grid.nz to keep the layers thin) or "
               "put it shallower" if k == 2 else
               "move it, or widen the window (grid.half_width or grid.extent)")
        raise field_error(
            f"{where}.centre",
            f"the inhomogeneity spans {axis} = {c - a:.4g} ... {c + a:.4g} m, beyond the "
            f"cuboid box ({axis} = {low:.4g} ... {high:.4g} m); {fix}",
        )


def _check_resolved(case: Case, item: Inhomogeneity, cells: BodyCells, where: str) -> None:
    """Refuse a region with fewer than MIN_CELLS_PER_SEMI_AXIS cells per semi-axis."""
    size_field = f"{where}.{SIZE_FIELDS[item.shape]}"
    for k, axis in enumerate(_AXES):
        a, h = item.semi_axes_m()[k], cells.size[k]
        if a / h >= MIN_CELLS_PER_SEMI_AXIS:
            continue
        scale = MIN_CELLS_PER_SEMI_AXIS * h / a
        if k == 2:
            refine = f"grid.nz >= {_needed(case.grid.nz, scale)} (or a shallower grid.depth)"
        else:
            name = ("grid.nx", "grid.ny")[k]
            refine = f"{name} >= {_needed(getattr(case.grid, name[5:]), scale)}"
        raise field_error(
            size_field,
            f"only {a / h:.3g} cells of {h:.3g} m per semi-axis along {axis} (need "
            f"{MIN_CELLS_PER_SEMI_AXIS:g}): refine the grid ({refine}) or enlarge the "
            "inhomogeneity",
        )


def _needed(count: int, scale: float) -> str:
    """Return the cell count ``count × scale`` rounded up, or the limit (:data:`MAX_CELLS`)."""
    need = count * scale
    return str(math.ceil(need)) if need <= MAX_CELLS else f"{MAX_CELLS} (the most a grid holds)"


def cells_problem(case: Case, index: int, points: np.ndarray) -> str | None:
    """Say what is wrong with the points of inhomogeneity ``index``'s cells file (None: nothing).

    ``points`` (k, 3) [m] must lie in the cuboid box (as :func:`check_inhomogeneities` says
    for the analytic shapes) and share no cell with another inhomogeneity. Returns one problem
    line naming ``body.inhomogeneity.<index>.cells``.
    """
    where = f"body.inhomogeneity.{index}.cells"
    cells = body_cells(case)
    for k, axis in enumerate(_AXES):
        low, high = cells.bounds(k)
        low = 0.0 if k == 2 else low
        outside = (points[:, k] < low) | (points[:, k] > high)
        if outside.any():
            return (f"{where}: {int(outside.sum())} of its {len(points)} points lie beyond the "
                    f"cuboid box along {axis} ({low:.4g} ... {high:.4g} m); move them, or "
                    "widen the window (grid.half_width, grid.extent) or deepen the box "
                    "(grid.depth)")
    held = _cell_index(points, cells)
    centres = np.stack([cells.centres[k][np.clip(held[:, k], 0, cells.centres[k].size - 1)]
                        for k in range(3)], axis=-1)
    for other, item in enumerate(case.body.inhomogeneity):
        if other != index and item.shape != "cells" and contains(item, centres).any():
            return (f"{where}: its cells overlap body.inhomogeneity.{other}; move them apart "
                    "or merge them into one")
    return None
