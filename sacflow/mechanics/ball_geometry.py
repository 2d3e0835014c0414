"""Small dense geometry of the minimum-ball algorithms: circumcentres and distances (compiled).

The minimum enclosing ball of a point set is the circumscribed ball of an affinely independent
support subset ``T`` whose circumcentre lies in the convex hull of ``T`` (Welzl 1991; Fischer,
Gärtner & Kutz 2003). Both algorithms of :mod:`sacflow.mechanics.minimum_ball` (the pivoting
fast path, :mod:`sacflow.mechanics.ball_pivoting`, and the exact fallback,
:mod:`sacflow.mechanics.ball_exact`) need the circumcentre of ``T`` *in its affine hull* and
its affine (barycentric) coefficients: a Gram system of size ``|T| − 1`` solved here by Gaussian
elimination with partial pivoting, with an optional rank test that rejects numerically
dependent subsets.

All functions are numba-compiled, take preallocated scratch arrays and never allocate.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

__all__ = ["circumcentre", "farthest_point", "solve_small", "squared_distance"]


@numba.njit(cache=True, nogil=True)
def solve_small(g: NDArray[np.float64], b: NDArray[np.float64], k: int,
                min_pivot: float) -> bool:
    """Solve ``g[:k, :k] x = b[:k]`` in place (partial pivoting): ``x`` overwrites ``b``.

    Returns False, leaving ``b`` undefined, if a pivot is not above ``min_pivot`` in magnitude
    (``0.0``: only an exactly singular matrix is refused).
    """
    for col in range(k):
        piv = col
        best = abs(g[col, col])
        for row in range(col + 1, k):
            if abs(g[row, col]) > best:
                best = abs(g[row, col])
                piv = row
        if best <= min_pivot:
            return False
        if piv != col:
            for j in range(k):
                g[col, j], g[piv, j] = g[piv, j], g[col, j]
            b[col], b[piv] = b[piv], b[col]
        for row in range(col + 1, k):
            f = g[row, col] / g[col, col]
            for j in range(col, k):
                g[row, j] -= f * g[col, j]
            b[row] -= f * b[col]
    for col in range(k - 1, -1, -1):
        acc = b[col]
        for j in range(col + 1, k):
            acc -= g[col, j] * b[j]
        b[col] = acc / g[col, col]
    return True


@numba.njit(cache=True, nogil=True)
def _gram(q: NDArray[np.float64], support: NDArray[np.int64], m: int, g: NDArray[np.float64],
          rhs: NDArray[np.float64], diff: NDArray[np.float64]) -> float:
    """Gram system of the support differences ``q_i − q_0``; returns its largest diagonal."""
    d = q.shape[1]
    q0 = support[0]
    k = m - 1
    for i in range(k):
        qi = support[i + 1]
        for c in range(d):
            diff[i, c] = q[qi, c] - q[q0, c]
    largest = 0.0
    for i in range(k):
        for j in range(i, k):
            acc = 0.0
            for c in range(d):
                acc += diff[i, c] * diff[j, c]
            g[i, j] = acc
            g[j, i] = acc
        rhs[i] = 0.5 * g[i, i]
        largest = max(largest, g[i, i])
    return largest


@numba.njit(cache=True, nogil=True)
def circumcentre(q: NDArray[np.float64], support: NDArray[np.int64], m: int,
                 cc: NDArray[np.float64], lam: NDArray[np.float64], g: NDArray[np.float64],
                 rhs: NDArray[np.float64], diff: NDArray[np.float64],
                 rank_tol: float) -> bool:
    """Centre ``cc`` of the sphere through the ``m`` support points lying in their affine hull.

    ``cc = q0 + Σ x_i (q_i − q0)`` with ``2 (q_i − q0)·(cc − q0) = |q_i − q0|²``: a Gram
    system of size ``m − 1``. ``lam`` receives the affine coefficients (``1 − Σx, x_1, …``).
    Returns False if the support set is affinely dependent: exactly (``rank_tol = 0``) or to
    ``rank_tol`` times the largest squared difference (an elimination pivot below it).
    """
    d = q.shape[1]
    q0 = support[0]
    k = m - 1
    largest = _gram(q, support, m, g, rhs, diff)
    if not solve_small(g, rhs, k, rank_tol * largest):
        return False
    total = 0.0
    for c in range(d):
        cc[c] = q[q0, c]
    for i in range(k):
        lam[i + 1] = rhs[i]
        total += rhs[i]
        for c in range(d):
            cc[c] += rhs[i] * diff[i, c]
    lam[0] = 1.0 - total
    for i in range(m):
        if not math.isfinite(lam[i]):
            return False
    return True


@numba.njit(cache=True, nogil=True)
def squared_distance(q: NDArray[np.float64], i: int,
                     centre: NDArray[np.float64]) -> float:
    """``|q_i − centre|²``."""
    acc = 0.0
    for c in range(q.shape[1]):
        acc += (q[i, c] - centre[c]) ** 2
    return acc


@numba.njit(cache=True, nogil=True)
def farthest_point(q: NDArray[np.float64],
                   centre: NDArray[np.float64]) -> tuple[int, float]:
    """Index of the point of ``q`` farthest from ``centre`` (the first on ties), its ``d²``."""
    far = 0
    best = -1.0
    for i in range(q.shape[0]):
        acc = squared_distance(q, i, centre)
        if acc > best:
            best = acc
            far = i
    return far, best
