"""Exact fallback of the minimum enclosing ball: constraint generation on small subproblems.

The minimum ball of a point set ``P`` is the circumscribed ball, in its affine hull, of an
affinely independent subset ``T`` (at most ``d + 1`` points) whose circumcentre is a convex
combination of ``T`` (Welzl 1991, [We91]_). This fallback builds it without pivoting on
coefficients, so degenerate inputs (paths in a subspace, cospherical or repeated points) cannot
make it cycle:

1. the candidate set ``C`` (at most ``d + 2`` points) starts as the support proposed by the fast
   path, or the point farthest from the centroid;
2. the minimum ball of ``C`` is found by **enumeration**: among the ``2^|C| − 1`` subsets, the
   affinely independent ones (a rank test on the Gram pivots) whose circumcentre has affine
   coefficients ≥ −tolerance and whose circumscribed ball encloses ``C``, the smallest one. By
   the characterisation above this is the minimum ball of ``C``; near-dependent subsets are
   skipped, an equivalent independent one (Carathéodory) taking their place;
3. the point of ``P`` farthest from that ball's centre: if it lies inside (to
   :data:`ENCLOSURE_TOLERANCE`), the ball is the minimum ball of ``P``; otherwise ``C`` becomes
   the support of the ball plus that point and step 2 repeats. The radius grows strictly at
   every round (the new point lies outside the previous ball: Welzl's lemma puts it on the
   boundary of the next one), so no set of candidates comes back.

Each round costs at most ``2^(d+2)`` circumcentres of at most ``d + 1`` points, independent of
``|P|``, plus one pass over ``P``.

References
----------
.. [We91] E. Welzl, "Smallest enclosing disks (balls and ellipsoids)", in *New Results and New
   Trends in Computer Science*, LNCS 555, Springer, 1991, pp. 359–370.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

from sacflow.mechanics.ball_geometry import circumcentre, farthest_point, squared_distance

__all__ = ["ENCLOSURE_TOLERANCE", "exact_ball"]

#: Relative tolerance on the squared radius within which a point counts as enclosed.
ENCLOSURE_TOLERANCE = 1.0e-12
#: Relative size (of the largest squared difference) of a Gram pivot under which a subset is
#: taken as affinely dependent. A point that close to the hull of the others lies, once dropped,
#: outside their sphere by far less than :data:`ENCLOSURE_TOLERANCE`.
RANK_TOLERANCE = 1.0e-14
#: Affine coefficients down to minus this count as non-negative (the centre in the hull).
COEFFICIENT_TOLERANCE = 1.0e-12
#: Rounds of constraint generation per support dimension (``d + 1``) before giving up: the
#: radius grows at every round, and a few rounds per support point suffice.
_ROUNDS_PER_DIMENSION = 100


@numba.njit(cache=True, nogil=True)
def _subset(candidates: NDArray[np.int64], k: int, mask: int,
            subset: NDArray[np.int64]) -> int:
    """Copy the candidates selected by the bits of ``mask`` into ``subset``; return the count."""
    m = 0
    for i in range(k):
        if mask >> i & 1:
            subset[m] = candidates[i]
            m += 1
    return m


@numba.njit(cache=True, nogil=True)
def _encloses(q: NDArray[np.float64], candidates: NDArray[np.int64], k: int,
              centre: NDArray[np.float64], r2: float) -> bool:
    """Whether every candidate lies within ``r2 (1 + ENCLOSURE_TOLERANCE)`` of ``centre``."""
    bound = r2 * (1.0 + ENCLOSURE_TOLERANCE)
    for i in range(k):
        if squared_distance(q, candidates[i], centre) > bound:
            return False
    return True


@numba.njit(cache=True, nogil=True)
def _in_hull(lam: NDArray[np.float64], m: int) -> bool:
    """Whether every affine coefficient is ≥ −:data:`COEFFICIENT_TOLERANCE`."""
    for i in range(m):
        if lam[i] < -COEFFICIENT_TOLERANCE:
            return False
    return True


@numba.njit(cache=True, nogil=True)
def _smallest_ball(q: NDArray[np.float64], candidates: NDArray[np.int64], k: int,
                   centre: NDArray[np.float64], support: NDArray[np.int64],
                   weights: NDArray[np.float64]) -> tuple[int, float]:
    """Minimum ball of the ``k`` candidates by enumeration of their subsets.

    Writes the centre, the support (indices of ``q``) and its affine coefficients; returns the
    support size and the squared radius, or ``(0, inf)`` if no subset qualifies.
    """
    d = q.shape[1]
    dmax = d + 1
    subset = np.empty(dmax, dtype=np.int64)
    cc = np.empty(d)
    lam = np.empty(dmax)
    g = np.empty((d, d))
    rhs = np.empty(d)
    diff = np.empty((d, d))
    best_m, best_r2 = 0, np.inf
    for mask in range(1, 1 << k):
        m = _subset(candidates, k, mask, subset)
        if m > dmax or not circumcentre(q, subset, m, cc, lam, g, rhs, diff, RANK_TOLERANCE):
            continue
        r2 = squared_distance(q, subset[0], cc)
        if r2 < best_r2 and _in_hull(lam, m) and _encloses(q, candidates, k, cc, r2):
            best_m, best_r2 = m, r2
            centre[:] = cc
            support[:m] = subset[:m]
            weights[:m] = lam[:m]
    return best_m, best_r2


@numba.njit(cache=True, nogil=True)
def exact_ball(q: NDArray[np.float64], centre: NDArray[np.float64],
               support: NDArray[np.int64], weights: NDArray[np.float64],
               m: int) -> int:
    """Minimum ball of the rows of ``q`` (n, d), centred and scaled to extent ~1.

    Parameters
    ----------
    q : ndarray (n, d)
        The points, in coordinates of unit extent.
    centre : ndarray (d,)
        Receives the centre.
    support : int ndarray (d + 1,)
        On entry, its first ``m`` entries are a starting candidate set (``m = 0``: none);
        receives the support set.
    weights : ndarray (d + 1,)
        Receives the affine coefficients of the centre on the support set (≥ −1e-12).
    m : int
        Number of starting candidates in ``support``.

    Returns
    -------
    int
        The size of the support set, or 0 if no round could qualify a ball or the rounds ran
        out (the caller raises: never a silent approximation).
    """
    n, d = q.shape
    dmax = d + 1
    candidates = np.empty(dmax + 1, dtype=np.int64)
    k = 0
    for i in range(m):
        if support[i] not in candidates[:k]:
            candidates[k] = support[i]
            k += 1
    if k == 0:
        for c in range(d):
            centre[c] = np.mean(q[:, c])
        candidates[0], _ = farthest_point(q, centre)
        k = 1
    for _ in range(_ROUNDS_PER_DIMENSION * dmax):
        m, r2 = _smallest_ball(q, candidates, k, centre, support, weights)
        if m == 0:
            return 0
        far, far2 = farthest_point(q, centre)
        if far2 <= r2 * (1.0 + ENCLOSURE_TOLERANCE):
            return m
        candidates[:m] = support[:m]
        candidates[m] = far
        k = m + 1
    return 0
