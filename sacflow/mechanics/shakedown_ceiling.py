r"""The kinematic-hardening ceiling on the shakedown limit of a load domain.

Let a load factor λ be proved safe by Melan's theorem: some residual stress ρ(x) keeps
σ_vM(λ σ̂(t, x) + ρ(x)) ≤ σ_Y for every load t of the domain (the unloaded state, σ̂ = 0,
included) at every point x. At one point x this says that the deviatoric path
{λ dev σ̂(t, x)} lies in a ball of radius σ_Y (von Mises norm) centred at −dev ρ(x), so the
radius R(x) of the smallest ball holding the path per unit load obeys λ R(x) ≤ σ_Y:

.. math:: \lambda \le \frac{\sigma_Y}{\sup_x R(x)}.

Only the yield condition at each point was used, not equilibrium: 1/sup R is the shakedown
limit of a body that hardens kinematically without limit (Melan's theorem for kinematic
hardening, where ρ may be any back stress), and it bounds from above every λ that Melan's
theorem proves for the perfectly plastic body. The perfectly plastic shakedown limit itself is
the supremum of those λ (Koiter's theorem: under the classical assumptions of small strains,
a convex yield surface and associated flow, the static bound is attained), so it lies below
the ceiling too. The argument needs a von Mises body of uniform yield stress (σ_Y the same at
every point: with a graded σ_Y(x) use the ratio R(x)/σ_Y(x)).

Any subset of the points and of the loads gives a valid ceiling: the smallest ball of fewer
path points is no larger, so a ceiling from samples lies at or above the one from the whole
domain and is still an upper bound (sampling errs on the safe side, making the ceiling looser,
never wrong). What must not err is the ball: a radius computed too large would give a ceiling
too low. :func:`ball_radius_bounds` therefore returns a certified lower bound of the exact
radius — the dual of the minimum-ball problem, R² = max over weights w of the simplex of
Σ w_i |p_i|² − |Σ w_i p_i|² (Yildirim, SIAM J. Optim. 19 (2008) 1368), which any w bounds from
below — with the radius about the dual's centre as an upper bound; their gap says how exact
the radius is. The iterations are Frank–Wolfe steps with away steps (Yildirim's algorithm),
run on every point at once.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["KinematicCeiling", "ball_radius_bounds", "deviatoric_path", "kinematic_ceiling"]

#: (point sets (m, n, d), iterations) → (lower, upper) radii of their smallest balls.
BallBounds = Callable[[NDArray[np.float64], int],
                      tuple[NDArray[np.float64], NDArray[np.float64]]]
#: Frank–Wolfe iterations on every point (a first screening).
SCREEN_ITERATIONS = 60
#: Frank–Wolfe iterations on the points that may hold the largest radius.
FINAL_ITERATIONS = 3000
#: Points screened at once (bounds the memory of the iterations).
CHUNK = 1024
#: Relative gap between the radius bounds at which the iterations stop.
RADIUS_GAP = 1e-7


def deviatoric_path(stress: NDArray[np.float64]) -> NDArray[np.float64]:
    """Deviatoric stresses as vectors whose Euclidean length is the von Mises stress.

    ``stress`` (..., 6), components (11, 22, 33, 12, 13, 23) → (..., 6): √(3/2) (s11, s22,
    s33, √2 σ12, √2 σ13, √2 σ23), s = dev σ; then |v − w| = σ_vM(σ − τ).
    """
    s = np.asarray(stress, dtype=float)
    mean = s[..., :3].mean(axis=-1, keepdims=True)
    out: NDArray[np.float64] = np.sqrt(1.5) * np.concatenate(
        [s[..., :3] - mean, np.sqrt(2.0) * s[..., 3:]], axis=-1)
    return out


def ball_radius_bounds(points: NDArray[np.float64], iterations: int = FINAL_ITERATIONS
                       ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Lower and upper bounds of the radius of the smallest ball holding each point set.

    Parameters
    ----------
    points : ndarray, shape (m, n, d)
        m sets of n points in d dimensions.
    iterations : int
        Frank–Wolfe iterations at most (they stop early once the bounds meet to
        :data:`RADIUS_GAP`).

    Returns
    -------
    lower, upper : ndarray, shape (m,)
        ``lower`` = √(Σ w_i|p_i|² − |c|²), c = Σ w_i p_i, is certified (module docstring);
        ``upper`` = max_i |p_i − c| is the radius of a ball that holds the set.
    """
    p = np.asarray(points, dtype=float)
    m, n, _ = p.shape
    w = np.full((m, n), 1.0 / n)
    rows = np.arange(m)
    for _ in range(iterations):
        c = np.einsum("mn,mnd->md", w, p)
        dist = np.einsum("mnd,mnd->mn", p - c[:, None], p - c[:, None])
        # Σ w|p|² − |c|², written as the weighted variance about c (no cancellation)
        dual = np.einsum("mn,mn->m", w, dist)
        far = dist.argmax(axis=1)
        near = np.where(w > 0, dist, np.inf).argmin(axis=1)
        d_far, d_near = dist[rows, far], dist[rows, near]
        if np.all(d_far <= dual * (1 + RADIUS_GAP) ** 2):
            break
        safe = np.maximum(dual, 1e-300)
        toward = d_far / safe - 1 >= 1 - d_near / safe
        j = np.where(toward, far, near)
        dj = np.where(toward, d_far, d_near)
        # exact line search of the dual along e_j − w (module docstring, Yildirim 2008)
        step = (dj - dual) / (2 * np.maximum(dj, 1e-300))
        wj = w[rows, j]
        step = np.where(toward, step, np.maximum(step, -wj / np.maximum(1 - wj, 1e-300)))
        w *= (1 - step)[:, None]
        w[rows, j] += step
        np.clip(w, 0.0, None, out=w)
        w /= w.sum(axis=1, keepdims=True)
    c = np.einsum("mn,mnd->md", w, p)
    dist = np.einsum("mnd,mnd->mn", p - c[:, None], p - c[:, None])
    return np.sqrt(np.einsum("mn,mn->m", w, dist)), np.sqrt(dist.max(axis=1))


@dataclass(frozen=True)
class KinematicCeiling:
    """Result of :func:`kinematic_ceiling`.

    Attributes
    ----------
    load_factor : float
        1 / (largest certified lower bound of the radius): an upper bound of the
        perfectly plastic shakedown limit per unit load (module docstring), in the unit of
        the yield stress.
    load_factor_low : float
        1 / (largest upper bound of the radius): what the ceiling would be if the balls were
        no better than the iterations found; ``load_factor_low ≤ exact ≤ load_factor``.
    point : tuple of int
        Index of the point where the largest radius is found.
    """

    load_factor: float
    load_factor_low: float
    point: tuple[int, ...]


def kinematic_ceiling(elastic: NDArray[np.float64],
                      ball: BallBounds = ball_radius_bounds) -> KinematicCeiling:
    """Kinematic-hardening ceiling of a sampled load domain (module docstring).

    Parameters
    ----------
    elastic : ndarray, shape (n_loads, *points, 6)
        Elastic stress per unit load at each point for each load of the domain; the
        unloaded state is added here.
    ball : callable
        ``ball(points, iterations)`` → (lower, upper) radii of the smallest balls of
        (m, n, d) point sets, lower certified (:func:`ball_radius_bounds`); an exact
        minimum-ball routine may be passed, returning its radius as both.

    Returns
    -------
    KinematicCeiling
    """
    e = np.asarray(elastic, dtype=float)
    shape = e.shape[1:-1]
    path = deviatoric_path(np.moveaxis(e, 0, -2).reshape(-1, e.shape[0], 6))
    path = np.concatenate([path, np.zeros((path.shape[0], 1, 6))], axis=1)
    lower = np.empty(path.shape[0])
    upper = np.empty(path.shape[0])
    for start in range(0, path.shape[0], CHUNK):
        chunk = slice(start, start + CHUNK)
        lower[chunk], upper[chunk] = ball(path[chunk], SCREEN_ITERATIONS)
    keep = np.nonzero(upper >= lower.max())[0]  # only these can hold the largest radius
    for start in range(0, keep.size, CHUNK):
        part = keep[start:start + CHUNK]
        fine_lower, fine_upper = ball(path[part], FINAL_ITERATIONS)
        lower[part] = np.maximum(lower[part], fine_lower)
        upper[part] = np.minimum(upper[part], fine_upper)
    best = int(np.argmax(lower))
    return KinematicCeiling(load_factor=float(1.0 / lower[best]),
                            load_factor_low=float(1.0 / upper.max()),
                            point=tuple(int(i) for i in np.unravel_index(best, shape)))
