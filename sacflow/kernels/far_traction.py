r"""The surface traction beyond the box: its stress in the box, from a coarse, wider operator.

The eigenstrain operator (:mod:`sacflow.kernels.eigenstrain`) makes the half-space free of
traction by removing the normal traction ``t`` that the infinite-space cuboids and their images
leave on the surface, but only over the box's footprint: ``t`` does not end at the box sides
(it decays like ``r⁻³`` from the plastic zone). What lies beyond is missing from the residual
stress:

.. math::

    Δσ(x) = -\int_{S \setminus F} B(x - y;\, x_3)\, t(y)\, dy ,

``F`` the footprint, ``S`` the surface, ``B`` Boussinesq's stress of a unit normal force (the
sign: the traction is removed). On the press of the indentation-made dent (window 3 a) the
missing part is −0.62 % of σ11 on the axis at 0.5 a and −1.4 % at 2 a; a run's window sets it,
and no refinement of cells, layers or increments sees it (``docs/convergence.md``).

``t`` outside the footprint and ``Δσ`` inside the box are smooth at the scale of a few cells
(they are far from the plastic strain, or seen from a distance), so both are computed coarse:

1. the eigenstrain is averaged over super-cells of :math:`c_1 × c_2` cells (every layer kept);
2. an operator of super-cells on a footprint wider than the box by ``m`` super-cells on each
   side (:data:`MARGIN_SHARE` of the box's narrower side) gives ``t`` on that wider
   footprint, with zero strain around the box;
3. ``t`` inside the box's footprint is set to zero (the fine operator removes it) and Love's
   stresses of removing the rest are computed at the super-cells' centres;
4. they are interpolated linearly in x1 and x2 to the cells' centres (extrapolated over the
   outer half super-cell) and added to the fine residual stress.

Two approximations: the traction at distance ``r`` of the super-cells misses terms of order
``(c d / r)²`` (``c d`` a super-cell's side), and the linear interpolation of a field that
varies over the box's width. Beyond the wider footprint the traction is still left out; it
has fallen by the cube of the distance. The check: a box four times as wide at the fine cells
(``tests/test_far_traction.py``).

The residual surface displacement is exact without this (reciprocal theorem: no traction
enters it).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

__all__ = ["MARGIN_SHARE", "MAX_SUPER_CELL", "MIN_SUPER_CELLS", "FarTraction", "coarse_layout",
           "linear_weights", "super_cell"]

#: Largest super-cell side, in cells: along each axis the super-cells are the largest divisor
#: of the box's cells up to this that leaves at least :data:`MIN_SUPER_CELLS` across it (a
#: rolled box of 65 × 24 cells gets super-cells of 5 × 4). A square box of 8 c cells then has
#: a wider operator of ``9 / c²`` of its cells. On the 650 mN indentation's plastic strain
#: (80 × 80 × 48 cells, super-cells of 8) σ11 on the axis comes out within 0.05 % of a box
#: four times as wide, where the bare box misses 3.3 % at 2 a; super-cells of 16 (5 across)
#: left 0.14 % there.
MAX_SUPER_CELL = 8
#: Width of the margin on each side, as a share of the box's narrower side (then rounded up
#: to whole super-cells): the traction beyond it falls like the cube of the distance. A margin
#: of half the box left 0.16 % of σ11 at 2 a in that check.
MARGIN_SHARE = 1.0
#: Fewest super-cells across the box along an axis (fewer: smaller super-cells).
MIN_SUPER_CELLS = 6


def super_cell(n: int) -> int:
    """Return the super-cells' side (cells) along an axis of ``n`` cells.

    The largest divisor of ``n`` up to :data:`MAX_SUPER_CELL` that leaves
    :data:`MIN_SUPER_CELLS` super-cells; 1 if none does (a prime count: that axis keeps its
    cells, the wider operator is then three times the box's width of cells along it). The
    super-cells must tile the box: one that straddled the box's side would put the traction
    of its inner part beyond the side (tried: worse than the bare box there).
    """
    for c in range(MAX_SUPER_CELL, 1, -1):
        if n % c == 0 and n // c >= MIN_SUPER_CELLS:
            return c
    return 1


def coarse_layout(counts: Sequence[int], spacing: Sequence[float] = (1.0, 1.0)
                  ) -> tuple[tuple[int, int], tuple[int, int], tuple[int, int]]:
    """Return the super-cells' sides (cells), their counts over the box and the margins.

    The margin, the same width on every side, is :data:`MARGIN_SHARE` of the box's narrower
    side (a long box, a rolled track, is not widened by its length), in whole super-cells of
    each axis. ``counts`` are the box's cells (n1, n2), ``spacing`` their sizes (d1, d2).
    """
    n1, n2 = (int(n) for n in counts)
    d1, d2 = (float(d) for d in spacing)
    c1, c2 = super_cell(n1), super_cell(n2)
    width = MARGIN_SHARE * min(n1 * d1, n2 * d2)
    margins = (math.ceil(width / (c1 * d1) - 1e-9), math.ceil(width / (c2 * d2) - 1e-9))
    return (c1, c2), (n1 // c1, n2 // c2), margins


def linear_weights(n: int, c: int) -> np.ndarray:
    """Return the (n, n // c) matrix interpolating super-cell centres to cell centres.

    Cell ``i`` lies at ``u = (i + ½) / c − ½`` in units of super-cells from the first
    super-cell's centre; it takes ``1 − f`` of super-cell ``⌊u⌋`` and ``f`` of the next, the pair
    clamped to the row's ends (a linear extrapolation over the outer half super-cell).
    """
    coarse = n // c
    weights = np.zeros((n, coarse))
    if coarse == 1:
        weights[:, 0] = 1.0
        return weights
    u = (np.arange(n) + 0.5) / c - 0.5
    left = np.clip(np.floor(u).astype(int), 0, coarse - 2)
    f = u - left
    rows = np.arange(n)
    weights[rows, left] = 1.0 - f
    weights[rows, left + 1] = f
    return weights


class FarTraction:
    """The stress in the box of the surface traction beyond it (module notes).

    Parameters
    ----------
    shape : (int, int, int)
        Cuboids of the box along x1, x2, x3.
    spacing : (float, float, float)
        Cuboid size (d1, d2, d3) [m].
    E, nu : float
        Young's modulus [Pa] and Poisson's ratio.
    threads : int, optional
        Threads of the coarse operator.
    max_bytes : int, optional
        Memory budget of the coarse operator
        (:class:`~sacflow.kernels.eigenstrain.HalfSpaceEigenstrain`).

    Attributes
    ----------
    factor : (int, int)
        Super-cells' sides in cells along x1 and x2 (:func:`super_cell`).
    coarse : (int, int)
        Super-cells over the box along x1 and x2.
    margin : (int, int)
        Super-cells added on each side along x1 and x2 (:func:`coarse_layout`).
    """

    def __init__(self, shape: Sequence[int], spacing: Sequence[float], E: float, nu: float,
                 threads: int | None = None, max_bytes: int | None = None) -> None:
        from sacflow.kernels.eigenstrain import HalfSpaceEigenstrain

        n1, n2, n3 = (int(n) for n in shape)
        d1, d2, d3 = (float(d) for d in spacing)
        self.shape = (n1, n2, n3)
        self.factor, self.coarse, self.margin = coarse_layout((n1, n2), (d1, d2))
        (c1, c2), (m1, m2) = self.factor, self.margin
        self.operator = HalfSpaceEigenstrain(self.shape_for(self.shape, spacing),
                                             (c1 * d1, c2 * d2, d3), E, nu, threads=threads,
                                             max_bytes=max_bytes)
        self._weights = (linear_weights(n1, c1), linear_weights(n2, c2))
        self._box = (slice(m1, m1 + self.coarse[0]), slice(m2, m2 + self.coarse[1]))

    @staticmethod
    def shape_for(shape: Sequence[int], spacing: Sequence[float]) -> tuple[int, int, int]:
        """Return the coarse operator's shape for a box of ``shape`` with cells of ``spacing``.

        ``spacing`` is (d1, d2[, d3]); the memory estimate sizes the operator with it before it
        is built.
        """
        n1, n2, n3 = (int(n) for n in shape)
        _, (k1, k2), (m1, m2) = coarse_layout((n1, n2), tuple(spacing)[:2])
        return k1 + 2 * m1, k2 + 2 * m2, n3

    def stress(self, eps: np.ndarray) -> np.ndarray:
        """Stress [Pa] (n1, n2, n3, 6) in the box of removing the traction beyond it.

        Parameters
        ----------
        eps : ndarray (n1, n2, n3, 6)
            Eigenstrain per cuboid, as :class:`~sacflow.kernels.eigenstrain.HalfSpaceEigenstrain`.
        """
        n1, n2, n3 = self.shape
        c1, c2 = self.factor
        k1, k2 = self.coarse
        wide = np.zeros((*self.operator.shape, 6))
        wide[self._box] = np.asarray(eps).reshape(k1, c1, k2, c2, n3, 6).mean(axis=(1, 3))
        traction, _ = self.operator.surface_fields(wide, with_displacement=False)
        traction[self._box] = 0.0  # the fine operator removes the traction over the footprint
        response = self.operator.traction_stress(traction)[self._box]
        w1, w2 = self._weights
        # separable linear interpolation as matrix products: x1, then x2 for every x1 row
        rows = w1 @ np.ascontiguousarray(response).reshape(k1, -1)  # (n1, k2 · n3 · 6)
        out: np.ndarray = np.matmul(w2, rows.reshape(n1, k2, n3 * 6))
        return out.reshape(n1, n2, n3, 6)
