"""Exact, certified minimum enclosing balls of point sets (the deviatoric paths of fatigue).

The minimum ball enclosing the deviatoric path of a material point gives the Crossland
amplitude ``√J2,a`` (its radius) and the Dang Van mesoscopic mean deviator (its centre)
(Papadopoulos et al. 1997; Bernasconi & Papadopoulos [BP05]_ recommend an exact algorithm over
the longest-chord or minimum-circumscribed-hypersphere approximations). Every ball returned
here is **certified optimal**, by the Lagrangian dual of the problem
``min_c max_i |p_i − c|²``: for any weights ``w ≥ 0``, ``Σ w = 1``,

``max_i |p_i − c'|² ≥ Σ w_i |p_i − c'|² ≥ Σ w_i |p_i − p̄_w|² =: φ(w)``  for every ``c'``,

with ``p̄_w = Σ w_i p_i``: ``φ(w)`` is a lower bound of the squared minimum radius, attained
exactly by the KKT conditions (the centre a convex combination, with non-negative weights, of
support points on the sphere). Each result carries its support set and weights and the relative
gap ``(R² − φ(w)) / R²`` between the enclosing radius ``R`` (the largest distance from the
centre: every point is inside) and that bound; a ball is certified when the gap is at most
:data:`CERTIFICATE_TOLERANCE` (``R`` then exceeds the minimum radius by at most half that,
relatively).

Algorithm, per set, in coordinates shifted to the first point and scaled to unit extent (the
result does not depend on the units): the pivoting fast path
(:func:`sacflow.mechanics.ball_pivoting.pivot_ball`) proposes a ball; if it does not stop or its
ball fails the certificate, the exact fallback (:func:`sacflow.mechanics.ball_exact.exact_ball`,
constraint generation on enumerated subproblems) takes over from the fast path's support; a set
that even the fallback cannot certify raises :class:`BallCertificateError`, never returns an
approximation silently. All of it is numba-compiled, one set after the other, so splitting the
sets into chunks gives bit-identical results.

References
----------
.. [BP05] A. Bernasconi, I. V. Papadopoulos, "Efficiency of algorithms for shear stress
   amplitude calculation in critical plane class fatigue criteria", *Comput. Mater. Sci.*
   34 (2005) 355–368.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from sacflow.errors import SacflowError
from sacflow.mechanics.ball_exact import exact_ball
from sacflow.mechanics.ball_geometry import farthest_point
from sacflow.mechanics.ball_pivoting import pivot_ball

__all__ = [
    "CERTIFICATE_TOLERANCE",
    "FALLBACK",
    "FAST_PATH",
    "UNCERTIFIED",
    "BallCertificateError",
    "EnclosingBalls",
    "certificate_gap",
    "certified_ball",
    "min_enclosing_ball",
    "raise_uncertified",
]

#: Largest relative gap ``(R² − φ(w)) / R²`` of a certified ball: round-off of the scaled
#: coordinates (1e-16) amplified by the conditioning of the support's circumcentre, with margin.
CERTIFICATE_TOLERANCE = 1.0e-10
#: Status of a ball: certified as proposed by the pivoting fast path.
FAST_PATH = 0
#: Status of a ball: certified after the exact fallback.
FALLBACK = 1
#: Status of a ball: not certified even by the fallback (:func:`min_enclosing_ball` raises).
UNCERTIFIED = 2


class BallCertificateError(SacflowError, ArithmeticError):
    """A minimum enclosing ball could not be certified optimal, even by the exact fallback.

    Parameters
    ----------
    count : int
        Number of point sets without a certified ball.
    first : int
        Flat index of the first of them.
    gap : float
        The largest relative certificate gap among them (``inf``: no ball qualified).
    """

    def __init__(self, count: int, first: int, gap: float) -> None:
        self.count = count
        self.first = first
        self.gap = gap
        super().__init__(
            f"the minimum enclosing ball of {count} point set(s) (first: set {first}) could not "
            f"be certified optimal: relative gap {gap:.3g} > {CERTIFICATE_TOLERANCE:g} after the "
            f"exact fallback")


@dataclass(frozen=True)
class EnclosingBalls:
    """Minimum enclosing balls with their optimality certificates (arrays over the sets).

    Attributes
    ----------
    centre : ndarray (..., d)
        Centres.
    radius : ndarray (...)
        Radii: the largest distance of a point from the centre (every point is inside).
    support : int ndarray (..., d + 1)
        Indices (along the point axis) of the support points, padded with −1.
    weights : ndarray (..., d + 1)
        Their dual weights ``w ≥ 0``, ``Σ w = 1`` (padded with 0): the centre is
        ``Σ w_i p_i`` and the support points lie on the sphere, to the gap.
    gap : ndarray (...)
        Relative certificate gap ``(R² − φ(w)) / R²`` (0 for a single distinct point), at most
        :data:`CERTIFICATE_TOLERANCE`.
    status : int8 ndarray (...)
        :data:`FAST_PATH` or :data:`FALLBACK`: which algorithm gave the certified ball.
    """

    centre: NDArray[np.float64]
    radius: NDArray[np.float64]
    support: NDArray[np.int64]
    weights: NDArray[np.float64]
    gap: NDArray[np.float64]
    status: NDArray[np.int8]


@numba.njit(cache=True, nogil=True)
def _dual_bound(q: NDArray[np.float64], support: NDArray[np.int64],
                weights: NDArray[np.float64], m: int) -> float:
    """``φ(w) = Σ w_i |q_i − q̄_w|²`` over the first ``m`` support points (weights as given)."""
    d = q.shape[1]
    phi = 0.0
    for c in range(d):
        mean = 0.0
        for i in range(m):
            mean += weights[i] * q[support[i], c]
        for i in range(m):
            phi += weights[i] * (q[support[i], c] - mean) ** 2
    return phi


@numba.njit(cache=True, nogil=True)
def _certificate(q: NDArray[np.float64], centre: NDArray[np.float64],
                 support: NDArray[np.int64], weights: NDArray[np.float64],
                 m: int) -> tuple[float, float]:
    """Squared enclosing radius about ``centre`` and relative gap to the dual bound.

    The affine coefficients in ``weights`` become dual weights first: negative ones (≥ −1e-12
    from the algorithms) are set to 0 and the rest normalised to a sum of 1.
    """
    _, r2 = farthest_point(q, centre)
    total = 0.0
    for i in range(m):
        weights[i] = max(weights[i], 0.0)
        total += weights[i]
    if not total > 0.0:
        return r2, np.inf
    for i in range(m):
        weights[i] /= total
    if r2 == 0.0:
        return r2, 0.0
    return r2, (r2 - _dual_bound(q, support, weights, m)) / r2


@numba.njit(cache=True, nogil=True)
def _scaled(pts: NDArray[np.float64], work: NDArray[np.float64]) -> float:
    """Set ``work = (pts − pts[0]) / scale``, ``scale`` the largest coordinate offset; return it."""
    n, d = pts.shape
    scale = 0.0
    for i in range(n):
        for c in range(d):
            work[i, c] = pts[i, c] - pts[0, c]
            scale = max(scale, abs(work[i, c]))
    if scale > 0.0:
        for i in range(n):
            for c in range(d):
                work[i, c] /= scale
    return scale


@numba.njit(cache=True, nogil=True)
def _solve_scaled(q: NDArray[np.float64], centre: NDArray[np.float64],
                  support: NDArray[np.int64], weights: NDArray[np.float64],
                  ) -> tuple[int, float, float, int]:
    """Fast path, certificate, fallback on ``q`` of unit extent: (m, R², gap, status)."""
    m = pivot_ball(q, centre, support, weights)
    if m > 0:
        r2, gap = _certificate(q, centre, support, weights, m)
        if gap <= CERTIFICATE_TOLERANCE:
            return m, r2, gap, FAST_PATH
    m = exact_ball(q, centre, support, weights, abs(m))
    if m == 0:
        _, r2 = farthest_point(q, centre)
        return 0, r2, np.inf, UNCERTIFIED
    r2, gap = _certificate(q, centre, support, weights, m)
    return m, r2, gap, (FALLBACK if gap <= CERTIFICATE_TOLERANCE else UNCERTIFIED)


@numba.njit(cache=True, nogil=True)
def certified_ball(pts: NDArray[np.float64], work: NDArray[np.float64],
                   centre: NDArray[np.float64], support: NDArray[np.int64],
                   weights: NDArray[np.float64]) -> tuple[float, float, int]:
    """Certified minimum ball of ``pts`` (n, d) in physical units (compiled; one set).

    Parameters
    ----------
    pts : ndarray (n, d)
        The points.
    work : ndarray (n, d)
        Scratch of the same shape (the scaled coordinates).
    centre : ndarray (d,)
        Receives the centre.
    support, weights : ndarray (d + 1,)
        Receive the support indices (padded with −1) and dual weights (padded with 0).

    Returns
    -------
    (float, float, int)
        Radius, relative certificate gap, status (:data:`FAST_PATH`, :data:`FALLBACK` or
        :data:`UNCERTIFIED`).
    """
    d = pts.shape[1]
    support[:] = -1
    weights[:] = 0.0
    scale = _scaled(pts, work)
    if scale == 0.0:
        centre[:] = pts[0]
        support[0] = 0
        weights[0] = 1.0
        return 0.0, 0.0, FAST_PATH
    m, r2, gap, status = _solve_scaled(work, centre, support, weights)
    support[max(m, 0):] = -1
    weights[max(m, 0):] = 0.0
    for c in range(d):
        centre[c] = pts[0, c] + scale * centre[c]
    return scale * math.sqrt(r2), gap, status


@numba.njit(cache=True, nogil=True)
def _balls(points: NDArray[np.float64], centres: NDArray[np.float64],
           radii: NDArray[np.float64], support: NDArray[np.int64],
           weights: NDArray[np.float64], gap: NDArray[np.float64],
           status: NDArray[np.int8]) -> None:
    """Certified minimum balls of ``points[j]`` (n, d) for every set j."""
    n_sets, n, d = points.shape
    work = np.empty((n, d))
    for j in range(n_sets):
        radii[j], gap[j], status[j] = certified_ball(points[j], work, centres[j], support[j],
                                                     weights[j])


def raise_uncertified(status: NDArray[np.int8], gap: NDArray[np.float64]) -> None:
    """Raise :class:`BallCertificateError` if any ``status`` is :data:`UNCERTIFIED`."""
    failed = np.flatnonzero(status.reshape(-1) == UNCERTIFIED)
    if failed.size:
        raise BallCertificateError(int(failed.size), int(failed[0]),
                                   float(np.max(gap.reshape(-1)[failed])))


def min_enclosing_ball(points: ArrayLike) -> EnclosingBalls:
    """Exact, certified minimum enclosing balls of many point sets (one per leading index).

    Parameters
    ----------
    points : array_like (..., n, d)
        ``n ≥ 1`` points of R^d per set; for the fatigue criteria ``d = 5`` and the ``n``
        points are the deviatoric vectors of one material point at successive times.

    Returns
    -------
    EnclosingBalls
        Centre and radius of the smallest ball containing all ``n`` points of each set, with
        its certificate (support, dual weights, gap) and which algorithm produced it.

    Raises
    ------
    ValueError
        If the shape is not (..., n ≥ 1, d ≥ 1) or a coordinate is not finite.
    BallCertificateError
        If a ball cannot be certified optimal even by the exact fallback.
    """
    pts = np.asarray(points, dtype=float)
    if pts.ndim < 2 or pts.shape[-2] < 1 or pts.shape[-1] < 1:
        raise ValueError(f"points must have shape (..., n >= 1, d >= 1), got {pts.shape}")
    if not np.all(np.isfinite(pts)):
        raise ValueError("points must be finite")
    lead = pts.shape[:-2]
    n, d = pts.shape[-2:]
    flat = np.ascontiguousarray(pts.reshape(-1, n, d))
    n_sets = flat.shape[0]
    centres, radii = np.empty((n_sets, d)), np.empty(n_sets)
    support = np.empty((n_sets, d + 1), dtype=np.int64)
    weights, gap = np.empty((n_sets, d + 1)), np.empty(n_sets)
    status = np.empty(n_sets, dtype=np.int8)
    _balls(flat, centres, radii, support, weights, gap, status)
    raise_uncertified(status, gap)
    return EnclosingBalls(centre=centres.reshape(*lead, d), radius=radii.reshape(lead),
                          support=support.reshape(*lead, d + 1),
                          weights=weights.reshape(*lead, d + 1), gap=gap.reshape(lead),
                          status=status.reshape(lead))


def certificate_gap(points: ArrayLike, centre: ArrayLike, radius: float, support: ArrayLike,
                    weights: ArrayLike) -> float:
    """Relative optimality gap of a claimed minimum ball of one point set; ``inf`` if invalid.

    Parameters
    ----------
    points : array_like (n, d)
        The point set.
    centre, radius
        The claimed ball.
    support : int array_like (k,)
        Indices of support points (entries < 0 are ignored).
    weights : array_like (k,)
        Their dual weights.

    Returns
    -------
    float
        ``(radius² − φ(w)) / radius²`` (see the module docstring): ≤
        :data:`CERTIFICATE_TOLERANCE` certifies the ball optimal. ``inf`` if a point lies
        outside the ball by more than that tolerance, a weight is negative or the weights do
        not sum to 1 (to 1e-12).
    """
    pts = np.asarray(points, dtype=float)
    idx = np.asarray(support, dtype=np.int64)
    w = np.asarray(weights, dtype=float)
    keep = idx >= 0
    idx, w = np.ascontiguousarray(idx[keep]), np.ascontiguousarray(w[keep])
    r2 = float(radius) ** 2
    dist2 = np.sum((pts - np.asarray(centre, dtype=float)) ** 2, axis=-1)
    enclosed = bool(np.all(dist2 <= r2 * (1.0 + CERTIFICATE_TOLERANCE)))
    if not (enclosed and np.all(w >= 0.0) and abs(w.sum() - 1.0) <= 1e-12):
        return math.inf
    if r2 == 0.0:
        return 0.0
    return float((r2 - _dual_bound(np.ascontiguousarray(pts), idx, w, idx.size)) / r2)
