r"""Cuboid eigenstrain stresses on a regular grid of offsets, from the lattice of corners.

The stress of a cuboid of uniform eigenstrain (:mod:`sacflow.kernels.cuboid`, Chiu 1977,
doi:10.1115/1.3424384) is an alternating sum over the cuboid's eight corners of functions of
``y = x − c`` (``c`` a corner). The influence coefficients of a grid of equal cuboids are needed
at offsets ``x = o · d`` (whole cells): their corners ``x ± d/2`` then lie on one lattice of
half-integer multiples of the cell size, shared by neighbouring offsets. Evaluating the corner
functions once per lattice point and differencing them along each axis gives every corner sum
with one eighth of the transcendental functions of the corner-by-corner evaluation, and the
lateral offsets folded to ``x1, x2 ≥ 0`` by the kernels' parities another quarter:

.. math::

    \sum_c s_c F(x - c) = Δ_1 Δ_2 Δ_3 F,\qquad
    Δ_i F = F(y_i = x_i + h_i) - F(y_i = x_i - h_i),

with ``s_c = +1`` for an even number of upper bounds among the corner's coordinates, as in
:func:`sacflow.kernels.cuboid._corner_sums`. The 18 corner sums (``T``, ``L``, ``Q``, ``M``,
``N`` there) enter the stress linearly; the 6 × 6 stress columns are one matrix product of them
with the coefficients that :func:`sacflow.kernels.cuboid.stress_from_sums` defines, taken from
it (one source of the formulas). Inside the cuboid ``−C:ε*`` is added as there.

The same corner functions, the same differences: results equal the corner-by-corner evaluation
to rounding (the tests compare them to 1e-12 of each column's largest value). Validity is that
of :mod:`sacflow.kernels.cuboid`: no lattice coordinate may be zero, which whole-cell offsets
(odd multiples of the half sizes) never are.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from sacflow.kernels.cuboid import PARITY, checked_half_sizes, stiffness_matrix, stress_from_sums
from sacflow.kernels.lattice import FoldedAxis, SampledAxis

__all__ = ["CuboidLattice", "corner_sum_coefficients"]

#: Corner functions per lattice point: T (3), L (3), Q (3), N (3) and the three M(i, i+1).
_FUNCTIONS = 15
#: Corner sums in the order of the coefficient matrix: T, L, Q, N (3 each), then
#: M(0,1) M(1,2) M(2,0) and their partners M(1,0) M(2,1) M(0,2).
_SUMS = 18
_M_PAIRS = ((0, 1), (1, 2), (2, 0))
#: Calls of :meth:`CuboidLattice.folded_plane` whose planes of corner functions are kept for
#: reuse: consecutive depth offsets share planes, and a caller may alternate two sequences (the
#: surface traction's cuboid and its image).
_CALLS_KEPT = 2
#: Resolution of the planes' cache keys, in half sizes: depths that differ by less (the
#: rounding of sums such as ``x3 + q + h``) are one plane of the lattice.
_KEY_RESOLUTION = 2.0**-24


def corner_sum_coefficients(nu: float, mu: float) -> np.ndarray:
    """Coefficients ``K[k, c, d]``: stress ``c`` of unit eigenstrain ``d`` per corner sum ``k``.

    :func:`sacflow.kernels.cuboid.stress_from_sums` is linear in the corner sums outside the
    cuboid; fed the unit vectors of the 18 sums (order of this module) it returns its matrix.
    """
    basis = np.eye(_SUMS)
    T = [basis[i] for i in range(3)]
    L = [basis[3 + i] for i in range(3)]
    Q = [basis[6 + i] for i in range(3)]
    N = [basis[9 + i] for i in range(3)]
    M: dict[tuple[int, int], np.ndarray] = {}
    for n, (i, j) in enumerate(_M_PAIRS):
        M[(i, j)] = basis[12 + n]
        M[(j, i)] = basis[15 + n]
    return stress_from_sums((T, L, Q, M, N), 0.0, tuple(range(6)), nu, mu)


def _corner_functions(y0: np.ndarray, y1: np.ndarray, y2: float, out: np.ndarray) -> None:
    """Evaluate the 15 corner functions at the lattice points ``y0 × y1`` of the plane ``y2``.

    Written into ``out`` (15, len(y0), len(y1)); the same expressions, term by term, as
    :func:`sacflow.kernels.cuboid._corner_sums` at one corner.
    """
    y = (y0[:, None], y1[None, :], np.float64(y2))
    sq = (y[0] * y[0], y[1] * y[1], y[2] * y[2])
    inv_r = 1.0 / np.sqrt(sq[0] + sq[1] + sq[2])
    prod = y[0] * y[1] * y[2]
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        out[i] = np.arctan((y[j] * y[k] / y[i]) * inv_r)
        rho2 = sq[i] + sq[j]
        out[3 + k] = np.arcsinh(y[k] / np.sqrt(rho2))
        yk_r = y[k] * inv_r
        out[9 + k] = yk_r
        out[6 + k] = (prod / rho2) * inv_r
        out[12 + i] = (sq[i] / rho2) * yk_r


class CuboidLattice:
    """Stress of a unit cuboid eigenstrain at the grid ``x1 × x2``, one plane ``x3`` at a time.

    Parameters
    ----------
    x1, x2 : array_like, 1-D
        Lateral offsets of the field points from the cuboid centre [m]; each may hold negative
        values (they are folded to ``|x|`` and mirrored with the kernels' parities).
    half : (float, float, float)
        Half sizes of the cuboid [m].
    nu, mu : float
        Poisson ratio and shear modulus [Pa].
    sub : (array_like, array_like), optional
        Lateral offsets [m] of sub-points of each target (:meth:`mean_plane`): the lattice is
        then that of the union of the sub-points ``x + q`` (:class:`~sacflow.kernels.lattice.
        SampledAxis`), and :meth:`folded_plane` gives the values at their folded offsets.

    Notes
    -----
    :meth:`plane` returns the columns asked for; the corner functions of a depth are kept for
    the next plane (offsets one cell apart share a lattice plane).
    """

    def __init__(self, x1: np.ndarray, x2: np.ndarray, half: Sequence[float], nu: float,
                 mu: float, sub: tuple[np.ndarray, np.ndarray] | None = None):
        half = checked_half_sizes(half, nu)
        self.scale = max(half)
        self.h = tuple(hh / self.scale for hh in half)
        self.nu, self.mu = float(nu), float(mu)
        x1 = np.asarray(x1, dtype=float).ravel() / self.scale
        x2 = np.asarray(x2, dtype=float).ravel() / self.scale
        self._sampled: tuple[SampledAxis, SampledAxis] | None = None
        if sub is None:
            self._axes = (FoldedAxis(x1, self.h[0]), FoldedAxis(x2, self.h[1]))
        else:
            self._sampled = (SampledAxis(x1, np.asarray(sub[0]) / self.scale, self.h[0]),
                             SampledAxis(x2, np.asarray(sub[1]) / self.scale, self.h[1]))
            self._axes = (self._sampled[0].axis, self._sampled[1].axis)
        # Corner sums → stress: coefficients (18, 36) of every (c, d) column.
        self._coefficients = corner_sum_coefficients(self.nu, self.mu).reshape(_SUMS, 36)
        self._free = stiffness_matrix(self.nu, self.mu).reshape(36)
        self._planes: dict[int, np.ndarray] = {}
        self._recent: list[set[int]] = []
        self.shape = (x1.size, x2.size)

    def _function_planes(self, depths: Sequence[float]) -> list[np.ndarray]:
        """Corner functions on the folded lateral lattice at lattice depths ``depths``.

        Planes of the last :data:`_CALLS_KEPT` calls are reused, the others dropped; depths
        closer than :data:`_KEY_RESOLUTION` (rounding) are one plane.
        """
        keys = [round(y2 / _KEY_RESOLUTION) for y2 in depths]
        for key, y2 in zip(keys, depths, strict=True):
            if key not in self._planes:
                u0, u1 = self._axes[0].lattice, self._axes[1].lattice
                plane = np.empty((_FUNCTIONS, u0.size, u1.size))
                with np.errstate(divide="ignore", invalid="ignore"):
                    _corner_functions(u0, u1, y2, plane)
                self._planes[key] = plane
        self._recent = [*self._recent[1 - _CALLS_KEPT:], set(keys)]
        kept = set().union(*self._recent)
        planes = [self._planes[key] for key in keys]
        self._planes = {key: plane for key, plane in self._planes.items() if key in kept}
        return planes

    def _sums(self, x3s: Sequence[float]) -> np.ndarray:
        """Return the 18 corner sums at the folded lateral offsets, summed over depths ``x3s``."""
        planes = self._function_planes([x3 + sign * self.h[2] for x3 in x3s for sign in (1, -1)])
        delta = planes[0] - planes[1]
        for upper, lower in zip(planes[2::2], planes[3::2], strict=True):
            delta += upper
            delta -= lower
        f = self._axes[1].difference(self._axes[0].difference(delta, 1), 2)
        sums = np.empty((_SUMS, *f.shape[1:]))
        sums[:12] = f[:12]
        for n, (i, j) in enumerate(_M_PAIRS):
            k = 3 - i - j
            sums[12 + n] = f[12 + i]
            sums[15 + n] = f[9 + k] - f[12 + i]
        return sums

    def folded_plane(self, x3: float, columns: Sequence[tuple[int, int]] | None = None,
                     depths: Sequence[float] = (0.0,)) -> np.ndarray:
        """Columns ``(c, d)`` at the folded offsets ``|x1| × |x2|`` and depth offset ``x3`` [m].

        With ``depths`` [m], the mean over the depth offsets ``x3 + depths`` (one set of corner
        sums: the closed form is linear in them).

        Returns
        -------
        ndarray (len(|x1|), len(|x2|), len(columns))
            ``A[..., c, d]`` of :func:`sacflow.kernels.cuboid.cuboid_stress` for each column
            (all 36, row-major, by default).
        """
        index = (np.arange(36) if columns is None
                 else np.array([6 * c + d for c, d in columns], dtype=np.intp))
        x3s = [(float(x3) + float(p)) / self.scale for p in depths]
        sums = self._sums(x3s)
        a, b = sums.shape[1:]
        out: np.ndarray = (sums.reshape(_SUMS, a * b).T
                           @ self._coefficients[:, index]).reshape(a, b, -1)
        inside_depths = sum(abs(x) < self.h[2] for x in x3s)
        if inside_depths:
            inside = ((self._axes[0].folded < self.h[0])[:, None]
                      & (self._axes[1].folded < self.h[1])[None, :])
            out[inside] -= inside_depths * self._free[index]
        if len(x3s) > 1:
            out /= len(x3s)
        return out

    def mean_plane(self, x3: float, columns: Sequence[tuple[int, int]],
                   depths: Sequence[float] = (0.0,)) -> np.ndarray:
        """Mean of the columns over the sub-points ``(x1 + q1, x2 + q2, x3 + depths)`` [m].

        Needs the lattice built with ``sub``. The values at the union's folded offsets, taken
        once, are averaged along each axis with the columns' parities
        (:meth:`~sacflow.kernels.lattice.SampledAxis.mean`).

        Returns
        -------
        ndarray (len(x1), len(x2), len(columns))
        """
        if self._sampled is None:
            raise ValueError("mean_plane needs a CuboidLattice built with sub-points (sub=)")
        folded = self.folded_plane(x3, columns, depths)
        odd = [np.array([PARITY[axis, c] * PARITY[axis, d] < 0 for c, d in columns])
               for axis in (0, 1)]
        along1 = self._sampled[0].mean(folded, 0, odd[0])
        return self._sampled[1].mean(along1, 1, odd[1])

    def unfold_signs(self, columns: Sequence[tuple[int, int]]) -> np.ndarray:
        """Signs (len(x1), len(x2), len(columns)) that mirror folded columns onto ``x1 × x2``.

        ``A_cd(R_i x) = ± A_cd(x)`` for the reflection ``R_i`` of axis i: odd when the axis
        occurs an odd number of times in ``c`` and ``d`` together.
        """
        sign0, sign1 = self._axes[0].sign, self._axes[1].sign
        out = np.ones((*self.shape, len(columns)))
        for n, (c, d) in enumerate(columns):
            if PARITY[0, c] * PARITY[0, d] < 0:
                out[:, :, n] *= sign0[:, None]
            if PARITY[1, c] * PARITY[1, d] < 0:
                out[:, :, n] *= sign1[None, :]
        return out

    def unfold(self, folded: np.ndarray, signs: np.ndarray,
               out: np.ndarray | None = None) -> np.ndarray:
        """Mirror folded columns (from :meth:`folded_plane`) onto the grid ``x1 × x2``."""
        full = self._axes[1].unfold(self._axes[0].unfold(folded, 0), 1)
        unfolded: np.ndarray = np.multiply(full, signs, out=out)
        return unfolded

    def plane(self, x3: float, columns: Sequence[tuple[int, int]]) -> np.ndarray:
        """Columns ``(c, d)`` at the grid ``x1 × x2`` and depth offset ``x3`` [m].

        Returns
        -------
        ndarray (len(columns), len(x1), len(x2))
            Stress component ``c`` [Pa] of unit eigenstrain component ``d`` for each column.
        """
        full = self.unfold(self.folded_plane(x3, columns), self.unfold_signs(columns))
        return np.moveaxis(full, -1, 0)
