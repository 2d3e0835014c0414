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
"""

from __future__ import annotations

import numpy as np

__all__ = ["FoldedAxis"]


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

    def difference(self, values: np.ndarray, axis: int) -> np.ndarray:
        """``Δ F``: the lattice values at ``folded + h`` minus those at ``folded − h``."""
        delta: np.ndarray = (np.take(values, self.upper, axis=axis)
                             - np.take(values, self.lower, axis=axis))
        return delta

    def unfold(self, values: np.ndarray, axis: int) -> np.ndarray:
        """Values at the folded offsets → values at the offsets ``x`` (without parity signs)."""
        return np.take(values, self.inverse, axis=axis)
