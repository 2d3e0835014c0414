"""Fast path of the minimum enclosing ball: the pivoting algorithm of Fischer, Gärtner & Kutz.

Pivoting algorithm of Fischer, Gärtner & Kutz [FGK03]_ (the one of Gärtner's *Seb*): the ball
``B(c, r)`` encloses every point and has its support set ``T`` (affinely independent, at most
``d + 1`` points) on its boundary. While ``c`` is not the circumcentre of ``T`` in ``aff(T)``,
``c`` walks towards that circumcentre (staying equidistant from ``T``, the radius shrinking)
until a point outside ``T`` reaches the boundary; that point joins ``T``. Once ``c`` is the
circumcentre, its affine coefficients decide: all ≥ 0 means ``c ∈ conv(T)``, the optimality
condition, otherwise the point with the most negative coefficient leaves ``T``.

In floating point, and on degenerate inputs (a path lying in a subspace of R⁵, as the
deviatoric path of any point on a symmetry plane of the load), the pivots can cycle. This
module therefore only *proposes* a ball: :mod:`sacflow.mechanics.minimum_ball` certifies it
and hands any uncertified set to the exact fallback (:mod:`sacflow.mechanics.ball_exact`).

References
----------
.. [FGK03] K. Fischer, B. Gärtner, M. Kutz, "Fast smallest-enclosing-ball computation in
   high dimensions", *Algorithms – ESA 2003*, LNCS 2832, Springer, 2003, pp. 630–641.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from sacflow.mechanics.ball_geometry import circumcentre, farthest_point

__all__ = ["PIVOT_TOLERANCE", "pivot_ball"]

#: Relative tolerance (of the point set's extent, 1 in the scaled coordinates) under which the
#: ball centre is taken to lie in the affine hull of its support set, and affine coefficients
#: count as non-negative.
PIVOT_TOLERANCE = 1.0e-12
#: Pivot steps per support dimension (``d + 1``) before the fast path gives up and leaves the
#: set to the exact fallback: a converging run needs a few tens of steps per support point
#: (at most 204 in all for the 17 160 paths of 177 points of the seed rolling case), a cycling
#: one never stops.
_STEPS_PER_DIMENSION = 50


@numba.njit(cache=True, nogil=True)
def _start(q: NDArray[np.float64], centre: NDArray[np.float64]) -> int:
    """Centroid into ``centre``; returns the point farthest from it (the first support point)."""
    n, d = q.shape
    for c in range(d):
        acc = 0.0
        for i in range(n):
            acc += q[i, c]
        centre[c] = acc / n
    far, _ = farthest_point(q, centre)
    return far


@numba.njit(cache=True, nogil=True)
def _walk_stopper(q: NDArray[np.float64], support: NDArray[np.int64], m: int,
                  centre: NDArray[np.float64], step: NDArray[np.float64],
                  den_min: float) -> tuple[float, int]:
    """Fraction of ``step`` the centre may walk, and the point that stops it (−1: none).

    A point ``p`` reaches the boundary at ``t_p = (r² − |p − c|²) / (2 (q0 − p)·step)``. A
    point whose offset from ``aff(T)`` along the walk is below ``den_min`` cannot stop it: this
    keeps ``T`` affinely independent (duplicates of support points included) and leaves such a
    point outside by at most ~:data:`PIVOT_TOLERANCE`.
    """
    n, d = q.shape
    q0 = support[0]
    r2 = 0.0
    for c in range(d):
        r2 += (q[q0, c] - centre[c]) ** 2
    t_best = 1.0
    stopper = -1
    for i in range(n):
        if i in support[:m]:
            continue
        den = 0.0
        p2 = 0.0
        for c in range(d):
            den += (q[q0, c] - q[i, c]) * step[c]
            p2 += (q[i, c] - centre[c]) ** 2
        den *= 2.0
        if den <= den_min:
            continue
        t = (r2 - p2) / den
        if t < t_best:
            t_best = max(t, 0.0)
            stopper = i
    return t_best, stopper


@numba.njit(cache=True, nogil=True)
def _most_negative(lam: NDArray[np.float64], m: int) -> int:
    """Position of the smallest of ``lam[:m]`` (the first on ties)."""
    worst = 0
    for i in range(1, m):
        if lam[i] < lam[worst]:
            worst = i
    return worst


@numba.njit(cache=True, nogil=True)
def _remove(support: NDArray[np.int64], m: int, position: int) -> None:
    """Drop ``support[position]`` from the first ``m`` entries, keeping their order."""
    for i in range(position, m - 1):
        support[i] = support[i + 1]


@numba.njit(cache=True, nogil=True)
def pivot_ball(q: NDArray[np.float64], centre: NDArray[np.float64],
               support: NDArray[np.int64],
               lam: NDArray[np.float64]) -> int:
    """Propose the minimum ball of the rows of ``q`` (n, d), centred and scaled to extent ~1.

    Parameters
    ----------
    q : ndarray (n, d)
        The points, in coordinates of unit extent.
    centre : ndarray (d,)
        Receives the centre.
    support : int ndarray (d + 1,)
        Receives the support set (indices of ``q``) in its first entries.
    lam : ndarray (d + 1,)
        Receives the affine coefficients of the centre on the support set.

    Returns
    -------
    int
        The size ``m`` of the support set once the optimality condition holds (all affine
        coefficients ≥ −:data:`PIVOT_TOLERANCE`), or ``−m`` if the pivots did not stop within
        ``50 (d + 1)`` steps (the first ``m`` entries of ``support`` then hold the last state,
        a start for the fallback).
    """
    d = q.shape[1]
    dmax = d + 1
    g = np.empty((d, d))
    rhs = np.empty(d)
    diff = np.empty((d, d))
    cc = np.empty(d)
    step = np.empty(d)
    tol2 = PIVOT_TOLERANCE * PIVOT_TOLERANCE
    support[0] = _start(q, centre)
    m = 1
    for _ in range(_STEPS_PER_DIMENSION * dmax):
        if not circumcentre(q, support, m, cc, lam, g, rhs, diff, 0.0):
            # Affinely dependent support (rounding): drop the newest point and go on.
            m -= 1
            continue
        dist2 = 0.0
        for c in range(d):
            step[c] = cc[c] - centre[c]
            dist2 += step[c] * step[c]
        if dist2 <= tol2:
            centre[:] = cc
            worst = _most_negative(lam, m)
            if lam[worst] >= -PIVOT_TOLERANCE or m == 1:
                return m
            _remove(support, m, worst)
            m -= 1
            continue
        t_best, stopper = 1.0, -1
        if m < dmax:
            den_min = 2.0 * PIVOT_TOLERANCE * math.sqrt(dist2)
            t_best, stopper = _walk_stopper(q, support, m, centre, step, den_min)
        for c in range(d):
            centre[c] += t_best * step[c]
        if stopper >= 0:
            support[m] = stopper
            m += 1
    return -m
