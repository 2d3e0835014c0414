r"""Corner lattices: closed-form influence coefficients of equal cells at whole-cell offsets.

The closed forms of a uniform source over a rectangle or a cuboid (Love's rectangle, Chiu's
cuboid) are alternating sums of a corner function ``F`` over the corners ``x ± h``:
``Σ_c s_c F(x − c) = Δ_1 Δ_2 … F`` with ``Δ_i F = F(y_i = x_i + h_i) − F(y_i = x_i − h_i)``.
For the offsets ``x = o d`` of a regular grid (cell size ``d = 2 h``) the corners of all offsets
lie on one lattice of half-integer multiples of the cell size, shared by neighbouring offsets:
evaluating ``F`` once per lattice point and differencing gives every corner sum with a fraction
of the work of the corner-by-corner sum (a quarter in 2-D, an eighth in 3-D). The kernels are
even or odd along each lateral axis, so the offsets are first folded to ``|x|`` and the result
mirrored back with the parities.

Used by :mod:`sacflow.kernels.cuboid_lattice` and
:func:`sacflow.kernels.surface.rectangle_stress_grid`.

A cell-averaged coefficient (:mod:`sacflow.kernels.cell_average`) is the mean of the closed
form over the target cell's sub-points ``x + q``. :class:`SampledAxis` folds the sub-points of
every offset into one :class:`FoldedAxis`: the union's corner lattice is evaluated once (for
two points per axis, the odd multiples of a quarter cell), and the mean over ``q`` is taken on
the folded values, the sub-points on the negative side entering with the kernel's parity.
"""

from __future__ import annotations

import numpy as np

__all__ = ["FoldedAxis", "SampledAxis"]


class FoldedAxis:
    """Offsets along one axis, folded to ``|x|``, with their corner lattice ``|x| ± h``.

    Parameters
    ----------
    x : array_like, 1-D
        Offsets of the field points from the cell centre (any sign).
    h : float
        Half size of the cell along the axis (same unit as ``x``).

    Attributes
    ----------
    folded : ndarray
        The distinct values of ``|x|``, increasing.
    lattice : ndarray
        The distinct corner coordinates ``folded ± h`` (values within a few ulp merged).
    lower, upper : ndarray of int
        Index in ``lattice`` of ``folded − h`` and ``folded + h``.
    inverse : ndarray of int
        Index in ``folded`` of each entry of ``x``.
    sign : ndarray
        −1 where ``x < 0``, else +1 (the factor of an odd kernel).
    """

    def __init__(self, x: np.ndarray, h: float):
        x = np.asarray(x, dtype=float).ravel()
        self.folded, inverse = np.unique(np.abs(x), return_inverse=True)
        self.inverse = inverse.ravel()
        self.sign = np.where(x < 0.0, -1.0, 1.0)
        ends = np.concatenate([self.folded - h, self.folded + h])
        order = np.argsort(ends, kind="stable")
        ordered = ends[order]
        tol = 8.0 * np.finfo(float).eps * max(float(np.abs(ordered).max()), abs(h))
        new = np.empty(ordered.size, dtype=bool)
        new[0] = True
        new[1:] = np.diff(ordered) > tol
        index = np.empty(ends.size, dtype=np.intp)
        index[order] = np.cumsum(new) - 1
        self.lattice = ordered[new]
        self.lower, self.upper = index[: self.folded.size], index[self.folded.size:]
        # On a regular grid (and on the union of its sub-points) each end runs through
        # consecutive lattice points: the differences are then of two slices.
        self._runs: tuple[slice, slice] | None = None
        if all(np.array_equal(ends, np.arange(ends[0], ends[0] + ends.size))
               for ends in (self.lower, self.upper)):
            self._runs = (slice(int(self.upper[0]), int(self.upper[-1]) + 1),
                          slice(int(self.lower[0]), int(self.lower[-1]) + 1))

    def difference(self, values: np.ndarray, axis: int) -> np.ndarray:
        """``Δ F``: the lattice values at ``folded + h`` minus those at ``folded − h``."""
        if self._runs is not None:  # both ends consecutive lattice points: views, no copies
            upper, lower = ([slice(None)] * values.ndim for _ in range(2))
            upper[axis], lower[axis] = self._runs
            runs: np.ndarray = np.subtract(values[tuple(upper)], values[tuple(lower)])
            return runs
        delta: np.ndarray = (np.take(values, self.upper, axis=axis)
                             - np.take(values, self.lower, axis=axis))
        return delta

    def unfold(self, values: np.ndarray, axis: int) -> np.ndarray:
        """Values at the folded offsets → values at the offsets ``x`` (without parity signs)."""
        return np.take(values, self.inverse, axis=axis)


class SampledAxis:
    """Offsets ``x`` with sub-points ``x + q`` each, folded as one :class:`FoldedAxis`.

    Parameters
    ----------
    x : array_like, 1-D
        Offsets of the target cells' centres from the source cell's centre.
    sub : array_like, 1-D
        Offsets ``q`` of the sub-points from a target cell's centre (same unit as ``x``).
    h : float
        Half size of the source cell along the axis.

    Attributes
    ----------
    axis : FoldedAxis
        The union of the sub-points ``x + q``: evaluate the corner functions on its lattice.
    """

    def __init__(self, x: np.ndarray, sub: np.ndarray, h: float):
        x = np.asarray(x, dtype=float).ravel()
        sub = np.asarray(sub, dtype=float).ravel()
        self.axis = FoldedAxis((x[:, None] + sub[None, :]).ravel(), h)
        self.index = self.axis.inverse.reshape(x.size, sub.size)
        #: −1 at the sub-points ``x + q < 0``, where a kernel odd along the axis changes sign
        self.sign = self.axis.sign.reshape(x.size, sub.size)

    def mean(self, folded: np.ndarray, axis: int, odd: np.ndarray) -> np.ndarray:
        """Mean over the sub-points of values given at ``self.axis.folded`` along ``axis``.

        ``odd`` (bool, over the last axis of ``folded``: one entry per column) marks the
        kernels odd along this axis; at a sub-point ``x + q < 0`` they enter with sign −1.
        Returns the values at the offsets ``x`` (axis ``axis`` of length ``len(x)``).
        """
        odd = np.asarray(odd, dtype=bool)
        negative = np.argwhere(self.sign < 0)
        if not (np.any(odd) and negative.size):
            total = self._sum(folded, axis, None)
        elif len(negative) <= self.index.shape[1]:
            # few sub-points across the origin (offsets ≥ 0, as the eigenstrain kernels'):
            # added with +1, take them off twice (a third less time for their set-up than the
            # split below, which offsets of both signs need)
            total = self._sum(folded, axis, None)
            target, source = np.moveaxis(total, axis, 0), np.moveaxis(folded, axis, 0)
            for k, q in negative:
                target[k][..., odd] -= 2.0 * source[self.index[k, q]][..., odd]
        else:
            total = np.empty((*folded.shape[:axis], self.index.shape[0],
                              *folded.shape[axis + 1:]))
            for columns, signed in ((np.flatnonzero(~odd), False), (np.flatnonzero(odd), True)):
                if columns.size:
                    total[..., columns] = self._sum(folded[..., columns], axis,
                                                    self.sign if signed else None)
        total /= self.index.shape[1]
        return total

    def _sum(self, folded: np.ndarray, axis: int, sign: np.ndarray | None) -> np.ndarray:
        """``Σ_q`` of the folded values at ``x + q`` along ``axis`` (times ``sign``, if given)."""
        shape = [1] * folded.ndim
        shape[axis] = -1
        total: np.ndarray | None = None
        for q in range(self.index.shape[1]):
            term = np.take(folded, self.index[:, q], axis=axis)
            if sign is not None:
                term *= sign[:, q].reshape(shape)
            total = term if total is None else np.add(total, term, out=total)
        assert total is not None
        return total
