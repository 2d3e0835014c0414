"""How flat the largest equivalent plastic strain is, around the cell that holds it.

The convergence study certifies the largest εp of a run and its depth
(:func:`sacflow.compare.fields.refined_peak`: a parabola through the largest cell value and its
two neighbours along each axis). Where the maximum is flat, its value is well defined but its
place is not: a change δ of the relative value moves the vertex of a parabola of relative
curvature κ = −f''/f by √(2δ/κ), however fine the grid. :func:`peak_shape` measures that
flatness on a finished run's field, so that an error of the depth can be read as the error of
εp that it stands for:

* the depth parabola through the column of the largest cell (its vertex, and the relative drop
  of εp at any other depth, :meth:`PeakShape.drop_at`);
* the maximum's distance from the load axis (below an indentation it lies on a ring near the
  contact's edge);
* how much the ring's value varies round the axis at the maximum's layer: over the cells whose
  distance from the axis is within half a cell of the maximum's, (largest − smallest) / largest.
  On a square grid a ring's cells sit at different places relative to the ring, so its largest
  cell, and with it the depth read there, is the grid's choice among nearly equal values.

:func:`plastic_extent` measures where a run flows at all: the share of its box's cells with
εp > 0 and the smallest box about the load axis that holds them, against the box. Finer cells
confined to a sub-box of the flow would save work only in proportion to what that sub-box
leaves out.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sacflow.compare.core import cell_bounds
from sacflow.compare.fields import refined_peak

__all__ = ["PeakShape", "PlasticExtent", "peak_shape", "plastic_extent"]


@dataclass(frozen=True)
class PeakShape:
    """The shape of a field's maximum (see the module docstring); lengths in metres.

    ``value`` and ``depth`` are :func:`~sacflow.compare.fields.refined_peak`'s; ``radius`` is
    the largest cell's distance from the load axis; ``layer`` its layer thickness;
    ``above`` and ``below`` the relative differences (f − f₀) / f₀ of the cells one layer
    shallower and deeper in its column; ``curvature`` the relative curvature −f''/f of the
    parabola through them at its vertex [1/m²] (its vertex is ``depth``); ``ring_spread`` the
    relative spread of the cell values round the axis at the maximum's layer.
    """

    value: float
    depth: float
    radius: float
    layer: float
    above: float
    below: float
    curvature: float
    ring_spread: float

    def drop_at(self, depth: float) -> float:
        """Relative fall of the depth parabola from its vertex at ``depth`` [m] (≥ 0)."""
        return 0.5 * self.curvature * (depth - self.depth) ** 2


def peak_shape(field: np.ndarray, x1: np.ndarray, x2: np.ndarray, x3: np.ndarray,
               axis: tuple[float, float] = (0.0, 0.0)) -> PeakShape:
    """Measure the maximum of a cell-centred field on (x1, x2, x3) (uniform spacings).

    Parameters
    ----------
    field : ndarray
        Cell values, shape (len(x1), len(x2), len(x3)); NaN (cells outside the plastic box)
        ignored.
    x1, x2, x3 : ndarray
        Cell-centre coordinates [m]; x3 is the depth.
    axis : tuple of float
        (x1, x2) of the load axis [m].

    Raises
    ------
    ValueError
        When the largest cell lies in the first or last layer: no parabola through its column.
    """
    values = np.asarray(field, dtype=float)
    value, where = refined_peak(values, (x1, x2, x3))
    i, j, k = np.unravel_index(int(np.nanargmax(values)), values.shape)
    if not 0 < k < len(x3) - 1:
        raise ValueError(f"the largest value lies in layer {k} of {len(x3)}: no layer on "
                         "both sides of it")
    above, peak, below = (float(v) for v in values[i, j, k - 1:k + 2])
    layer = float(x3[1] - x3[0])
    # the parabola through the three (uniform layers): f'' and its vertex value; the largest
    # cell is its column's largest, so it is concave or flat (second ≤ 0)
    second = above - 2.0 * peak + below
    vertex_value = peak - (above - below) ** 2 / (8.0 * second) if second < 0.0 else peak
    radii = np.hypot(np.asarray(x1)[:, None] - axis[0], np.asarray(x2)[None, :] - axis[1])
    radius = float(radii[i, j])
    half_cell = 0.5 * float(max(x1[1] - x1[0], x2[1] - x2[0]))
    ring = values[..., k][np.abs(radii - radius) <= half_cell]
    ring = ring[np.isfinite(ring)]
    return PeakShape(
        value=float(value), depth=float(where[2]), radius=radius,
        layer=layer, above=above / peak - 1.0, below=below / peak - 1.0,
        curvature=max(-second, 0.0) / (layer * layer * vertex_value),
        ring_spread=float((ring.max() - ring.min()) / ring.max()))


@dataclass(frozen=True)
class PlasticExtent:
    """Where a field is positive, against its box (see :func:`plastic_extent`); metres.

    ``share`` is the share of the box's cells with a positive value; ``half_width`` the half
    side of the smallest square about the load axis, to the outer faces of its cells, that holds
    them, and ``box_half_width`` the box's own (to its outermost faces, the larger of x1 and
    x2); ``depth`` the depth of the deepest such cell's lower face below the box's top face,
    and ``box_depth`` the box's.
    """

    share: float
    half_width: float
    box_half_width: float
    depth: float
    box_depth: float

    @property
    def volume_share(self) -> float:
        """Volume of the square sub-box that holds the positive cells, over the box's."""
        return (self.half_width / self.box_half_width) ** 2 * self.depth / self.box_depth


def _reach(centres: np.ndarray, dim: str, centre: float, hit: np.ndarray) -> tuple[float, float]:
    """Farthest outer face from ``centre`` of the ``hit`` cells along ``dim``, and of all cells.

    Uniform cells (:func:`~sacflow.compare.core.cell_bounds`): each face half a spacing from
    its centre.
    """
    x = np.asarray(centres, dtype=float)
    low, high = cell_bounds(x, dim)
    half = 0.5 * (high - low) / x.size
    return float(np.abs(x[hit] - centre).max() + half), float(max(centre - low, high - centre))


def plastic_extent(field: np.ndarray, x1: np.ndarray, x2: np.ndarray, x3: np.ndarray,
                   axis: tuple[float, float] = (0.0, 0.0)) -> PlasticExtent:
    """Measure the cells of a cell-centred field that are positive (εp > 0: they flowed).

    Parameters
    ----------
    field : ndarray
        Cell values, shape (len(x1), len(x2), len(x3)); NaN (cells outside the plastic box)
        count as not positive.
    x1, x2, x3 : ndarray
        Cell-centre coordinates [m], uniform spacings; x3 is the depth.
    axis : tuple of float
        (x1, x2) of the load axis [m].

    Raises
    ------
    ValueError
        When no cell is positive.
    """
    values = np.asarray(field, dtype=float)
    positive = np.nan_to_num(values, nan=0.0) > 0.0
    if not positive.any():
        raise ValueError("no cell of the field is positive")
    lateral = [_reach(x1, "x1", axis[0], positive.any(axis=(1, 2))),
               _reach(x2, "x2", axis[1], positive.any(axis=(0, 2)))]
    deepest, box_depth = _reach(x3, "x3", cell_bounds(x3, "x3")[0], positive.any(axis=(0, 1)))
    return PlasticExtent(
        share=float(positive.mean()),
        half_width=max(width for width, _ in lateral),
        box_half_width=max(box for _, box in lateral),
        depth=deepest, box_depth=box_depth)
