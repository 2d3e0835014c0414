r"""Self-equilibrated residual stress fields of steady rolling, ρ(x2, x3), as B-splines.

The load domain of steady rolling along x1 does not change under a shift of x1 and the yield
condition is convex, so Melan's search may run over residual fields that do not depend on x1
(:mod:`sacflow.mechanics.shakedown`). With ∂/∂x1 = 0 the equilibrium equations and the
traction-free surface x3 = 0 are solved exactly by three stress functions:

.. math::

    \rho_{11} = s, \qquad
    \rho_{12} = \partial_3\psi,\ \rho_{13} = -\partial_2\psi \quad (\psi = 0 \text{ on } x_3 = 0),

    \rho_{22} = \partial_{33}\phi,\ \rho_{33} = \partial_{22}\phi,\ \rho_{23} = -\partial_{23}\phi
    \quad (\phi = \partial_3\phi = 0 \text{ on } x_3 = 0).

No compatibility is asked (Melan's theorem does not need it). Here s, ψ and φ are tensor
products of clamped cubic B-splines on the box |x2| ≤ L, 0 ≤ x3 ≤ D; ψ, φ and ∂φ vanish on the
box's far edges as well, so ρ is zero outside the box and self-equilibrated in the whole
half-space, exactly: the stress functions are differentiated in closed form, not by differences.
To these the ``"full"`` class adds ρ11(x3) and ρ22(x3), functions of depth only, which are
admissible in a body of unbounded width (φ = φ(x3)); the ``"depth"`` class is that part alone.
ρ11 (of s and of the depth part) and ρ22 (of the depth part) may jump across |x2| = L and
x3 = D: ρ11 carries no traction on any plane x2 or x3 = const, ρ22 none on x3 = const.

Inside one knot cell every component is a polynomial, and a B-spline lies between its smallest
and largest coefficient (the basis is non-negative and sums to one; de Boor, *A Practical Guide
to Splines*, 1978, ch. IX). The derivatives of a spline are splines whose coefficients are
differences of the coefficients, so :meth:`SteadyResidualField.derivative_bounds` gives, with
no sampling, upper bounds of |ρ_ij| and of its first and second derivatives over each knot
cell: the residual part of the certificate of :mod:`sacflow.mechanics.shakedown_certificate`.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import NDArray
from scipy.interpolate import BSpline

__all__ = ["DERIVATIVES", "FieldClass", "SteadyResidualField", "clamped_knots"]

#: Degree of the B-splines of the stress functions (cubic: ρ continuous in the box).
SPLINE_DEGREE = 3
#: The derivatives bounded by :meth:`SteadyResidualField.derivative_bounds`, as orders
#: (along x2, along x3): the value, ∂2, ∂22, ∂3, ∂33.
DERIVATIVES: tuple[tuple[int, int], ...] = ((0, 0), (1, 0), (2, 0), (0, 1), (0, 2))

FieldClass = Literal["full", "depth"]
Basis = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]

#: Each part of the box field: (stress function, component, orders along x2 and x3).
#: Components (11, 22, 33, 12, 13, 23); the signs do not matter to a bound.
_BOX_PARTS: tuple[tuple[str, int, int, int], ...] = (
    ("s", 0, 0, 0), ("phi", 1, 0, 2), ("phi", 2, 2, 0), ("phi", 5, 1, 1),
    ("psi", 3, 0, 1), ("psi", 4, 1, 0),
)
#: Basis functions dropped at each end of each stress function (x2, x3): see ``_basis``.
_DROPPED = {"s": (0, 0), "phi": (2, 2), "psi": (1, 1)}


def clamped_knots(low: float, high: float, intervals: int) -> NDArray[np.float64]:
    """Clamped knot vector of the cubic splines on [low, high] with equal intervals."""
    step = (high - low) / intervals
    return np.concatenate([np.full(SPLINE_DEGREE, low), low + step * np.arange(intervals + 1),
                           np.full(SPLINE_DEGREE, high)])


def _basis(low: float, high: float, intervals: int, points: NDArray[np.float64],
           drop: tuple[int, int]) -> Basis:
    """Clamped cubic B-splines on [low, high] at ``points``: values, first, second derivatives.

    ``drop`` = (low, high) basis functions are removed at each end: 1 makes every combination
    vanish there, 2 also its first derivative (on a clamped knot vector only the first k of
    them are non-zero or have a non-zero derivative at the end). Zero outside [low, high].
    """
    knots = clamped_knots(low, high, intervals)
    count = knots.size - SPLINE_DEGREE - 1
    spline = BSpline(knots, np.eye(count), SPLINE_DEGREE, extrapolate=False)
    keep = slice(drop[0], count - drop[1])
    out = []
    for order in range(3):
        f = spline if order == 0 else spline.derivative(order)
        out.append(np.nan_to_num(f(points))[:, keep])  # outside the box: zero
    return out[0], out[1], out[2]


def _derivative(knots: NDArray[np.float64], coefficients: NDArray[np.float64], order: int,
                axis: int) -> tuple[NDArray[np.float64], int, NDArray[np.float64]]:
    """Knots, degree and coefficients (``axis`` kept in place) of a spline's derivative."""
    if order > SPLINE_DEGREE:  # a cubic's fourth derivative is zero inside each interval
        return knots, SPLINE_DEGREE, np.zeros_like(coefficients)
    spline = BSpline(knots, coefficients, SPLINE_DEGREE, axis=axis)
    if order:
        spline = spline.derivative(order)
    degree = SPLINE_DEGREE - order
    count = min(spline.t.size - degree - 1, spline.c.shape[0])
    # BSpline keeps the spline's axis first
    return spline.t, degree, np.moveaxis(spline.c[:count], 0, axis)


def _interval_maxima(knots: NDArray[np.float64], degree: int, magnitude: NDArray[np.float64],
                     axis: int) -> NDArray[np.float64]:
    """Largest ``magnitude`` (|coefficients| of a spline) active on each knot interval.

    Along ``axis`` the result has one entry per interval of the distinct knots: it bounds the
    spline's absolute value on that interval (convex hull property).
    """
    breaks = np.unique(knots)
    count = magnitude.shape[axis]
    c = np.moveaxis(magnitude, axis, 0)
    out = np.empty((breaks.size - 1, *c.shape[1:]))
    for j in range(breaks.size - 1):
        active = ((knots[:count] < breaks[j + 1])
                  & (knots[degree + 1:degree + 1 + count] > breaks[j]))
        out[j] = c[active].max(axis=0)
    return np.moveaxis(out, 0, axis)


def _cell_bounds(knots: tuple[NDArray[np.float64], ...], coefficients: NDArray[np.float64],
                 orders: tuple[int, ...]) -> NDArray[np.float64]:
    """Bound of |∂^orders f| on each knot cell of the tensor-product spline f (any dimension).

    The derivative's coefficients are formed along every axis first (signed), then their
    absolute values are reduced interval by interval.
    """
    degrees = []
    for axis, (t, order) in enumerate(zip(knots, orders, strict=True)):
        t_new, degree, coefficients = _derivative(t, coefficients, order, axis)
        degrees.append((t_new, degree))
    out = np.abs(coefficients)
    for axis, (t, degree) in enumerate(degrees):
        out = _interval_maxima(t, degree, out, axis)
    return out


class SteadyResidualField:
    """Self-equilibrated residual stress ρ(x2, x3), independent of x1, on sample points.

    The coefficient vector holds, in order: the depth-only part ρ11(x3), ρ22(x3) (splines on
    [0, depth], free at both ends: admissible in a body of unbounded width), then, for
    ``"full"``, the stress functions s, φ, ψ of the box (module docstring). So the ``"full"``
    class contains the ``"depth"`` class, and a ``"depth"`` solution padded with zeros is a
    ``"full"`` one (:meth:`extend`).

    Parameters
    ----------
    x2, x3 : ndarray
        Sample coordinates (1-D, any units, x3 ≥ 0 the depth).
    half_width, depth : float
        The box |x2| ≤ half_width, 0 ≤ x3 ≤ depth outside which the box part vanishes; the
        depth-only part vanishes below ``depth``.
    intervals : (int, int)
        Knot intervals of the splines along x2 and x3.
    kind : {"full", "depth"}
        The whole class of the module docstring, or ρ11(x3), ρ22(x3) only.
    """

    def __init__(self, x2: NDArray[np.float64], x3: NDArray[np.float64], half_width: float,
                 depth: float, intervals: tuple[int, int], kind: FieldClass = "full") -> None:
        self.kind = kind
        self.half_width, self.depth, self.intervals = half_width, depth, intervals
        self.points = (len(x2), len(x3))
        bases = self._bases(np.asarray(x2, float), np.asarray(x3, float))
        self._z_free = bases["z", "s"]
        nz = self._z_free[0].shape[1]
        self.shapes = [(1, nz), (1, nz)]
        if kind == "full":
            self._y_free, self._y_phi, self._z_phi, self._y_psi, self._z_psi = (
                bases["y", "s"], bases["y", "phi"], bases["z", "phi"], bases["y", "psi"],
                bases["z", "psi"])
            self.shapes += [(bases["y", name][0].shape[1], bases["z", name][0].shape[1])
                            for name in ("s", "phi", "psi")]
        self.sizes = [p * q for p, q in self.shapes]
        self.size = sum(self.sizes)

    def _bases(self, x2: NDArray[np.float64], x3: NDArray[np.float64]
               ) -> dict[tuple[str, str], Basis]:
        """Evaluate the bases of every stress function along x2 ("y") and x3 ("z")."""
        n2, n3 = self.intervals
        out = {("z", "s"): _basis(0.0, self.depth, n3, x3, (0, 0))}
        if self.kind == "full":
            for name, (drop_y, drop_z) in _DROPPED.items():
                out["y", name] = _basis(-self.half_width, self.half_width, n2, x2,
                                        (drop_y, drop_y))
                out["z", name] = _basis(0.0, self.depth, n3, x3, (drop_z, drop_z))
        return out

    def _split(self, c: NDArray[np.float64]) -> list[NDArray[np.float64]]:
        out, start = [], 0
        for shape, size in zip(self.shapes, self.sizes, strict=True):
            out.append(c[start:start + size].reshape(shape))
            start += size
        return out

    def extend(self, depth_coefficients: NDArray[np.float64]) -> NDArray[np.float64]:
        """Coefficients of this class for a field of the ``"depth"`` class on the same knots."""
        out = np.zeros(self.size)
        out[:depth_coefficients.size] = depth_coefficients
        return out

    def stress(self, c: NDArray[np.float64]) -> NDArray[np.float64]:
        """ρ at the samples, shape (n2, n3, 6), components (11, 22, 33, 12, 13, 23)."""
        rho = np.zeros((*self.points, 6))
        z0 = self._z_free[0]
        parts = self._split(c)
        rho[..., 0] = (z0 @ parts[0][0])[None, :]
        rho[..., 1] = (z0 @ parts[1][0])[None, :]
        if self.kind == "depth":
            return rho
        s, phi, psi = parts[2:]
        a0, a1, a2 = self._y_phi
        b0, b1, b2 = self._z_phi
        c0, c1, _ = self._y_psi
        d0, d1, _ = self._z_psi
        rho[..., 0] += self._y_free[0] @ s @ z0.T
        rho[..., 1] += a0 @ phi @ b2.T
        rho[..., 2] = a2 @ phi @ b0.T
        rho[..., 5] = -(a1 @ phi @ b1.T)
        rho[..., 3] = c0 @ psi @ d1.T
        rho[..., 4] = -(c1 @ psi @ d0.T)
        return rho

    def adjoint(self, g: NDArray[np.float64]) -> NDArray[np.float64]:
        """Gradient with respect to the coefficients of Σ g·ρ (g of shape (n2, n3, 6))."""
        z0 = self._z_free[0]
        out = [g[..., 0].sum(axis=0) @ z0, g[..., 1].sum(axis=0) @ z0]
        if self.kind == "full":
            a0, a1, a2 = self._y_phi
            b0, b1, b2 = self._z_phi
            c0, c1, _ = self._y_psi
            d0, d1, _ = self._z_psi
            out.append((self._y_free[0].T @ g[..., 0] @ z0).ravel())
            out.append((a0.T @ g[..., 1] @ b2 + a2.T @ g[..., 2] @ b0
                        - a1.T @ g[..., 5] @ b1).ravel())
            out.append((c0.T @ g[..., 3] @ d1 - c1.T @ g[..., 4] @ d0).ravel())
        return np.concatenate(out)

    def stress_at(self, c: NDArray[np.float64], x2: NDArray[np.float64],
                  x3: NDArray[np.float64]) -> NDArray[np.float64]:
        """ρ at scattered points (x2[i], x3[i]), shape (n, 6): the same field as :meth:`stress`.

        On the box's faces |x2| = L, x3 = D the value is the one from inside the box.
        """
        x2, x3 = np.asarray(x2, float), np.asarray(x3, float)
        bases = self._bases(x2, x3)
        parts = self._split(c)
        rho = np.zeros((x2.size, 6))
        z0 = bases["z", "s"][0]
        rho[:, 0] = z0 @ parts[0][0]
        rho[:, 1] = z0 @ parts[1][0]
        if self.kind == "depth":
            return rho
        functions = dict(zip(("s", "phi", "psi"), parts[2:], strict=True))
        for name, comp, oy, oz in _BOX_PARTS:
            sign = -1.0 if comp in (4, 5) else 1.0
            y, z = bases["y", name][oy], bases["z", name][oz]
            rho[:, comp] += sign * np.einsum("ni,ij,nj->n", y, functions[name], z)
        return rho

    def _padded(self, c: NDArray[np.float64]) -> dict[str, NDArray[np.float64]]:
        """Return the stress functions' coefficients, zeros for the dropped basis functions."""
        parts = self._split(c)
        count = [n + SPLINE_DEGREE for n in self.intervals]
        out = {"depth11": parts[0][0], "depth22": parts[1][0]}
        if self.kind == "full":
            for name, part in zip(("s", "phi", "psi"), parts[2:], strict=True):
                dy, dz = _DROPPED[name]
                full = np.zeros(count)
                full[dy:count[0] - dy, dz:count[1] - dz] = part
                out[name] = full
        return out

    def derivative_bounds(self, c: NDArray[np.float64], x2: NDArray[np.float64],
                          x3: NDArray[np.float64]) -> NDArray[np.float64]:
        """Bounds of |ρ| and its derivatives over the knot cells holding the points (x2, x3).

        Returns
        -------
        ndarray, shape (n, 5, 6)
            For each point, sup over its knot cell (of the box, or of the depth part beyond
            |x2| = L; zero below x3 = D) of |∂ ρ_ij| for the derivatives :data:`DERIVATIVES`.
            A point must lie strictly inside a cell: a cell centre, not a knot.
        """
        ty = clamped_knots(-self.half_width, self.half_width, self.intervals[0])
        tz = clamped_knots(0.0, self.depth, self.intervals[1])
        functions = self._padded(c)
        x2, x3 = np.asarray(x2, float), np.asarray(x3, float)
        iz = np.clip(np.floor(x3 / self.depth * self.intervals[1]).astype(int), 0,
                     self.intervals[1] - 1)
        below = x3 > self.depth
        out = np.zeros((x2.size, len(DERIVATIVES), 6))
        for k, (oy, oz) in enumerate(DERIVATIVES):
            if oy:
                continue  # the depth part does not depend on x2
            for comp, name in ((0, "depth11"), (1, "depth22")):
                table = _cell_bounds((tz,), functions[name], (oz,))
                out[:, k, comp] += np.where(below, 0.0, table[iz])
        if self.kind == "depth":
            return out
        iy = np.floor((x2 + self.half_width) / (2 * self.half_width) * self.intervals[0])
        inside = (iy >= 0) & (iy < self.intervals[0]) & ~below
        iy = np.clip(iy.astype(int), 0, self.intervals[0] - 1)
        for k, (oy, oz) in enumerate(DERIVATIVES):
            for name, comp, by, bz in _BOX_PARTS:
                table = _cell_bounds((ty, tz), functions[name], (by + oy, bz + oz))
                out[:, k, comp] += np.where(inside, table[iy, iz], 0.0)
        return out
