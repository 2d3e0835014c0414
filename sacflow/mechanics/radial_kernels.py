r"""Compiled row loops of the radial return: deviator scatters and the Swift consistency root.

The radial return (:func:`~sacflow.mechanics.return_mapping.isotropic_return`) and its
step-doubled form (:mod:`sacflow.mechanics.return_extrapolation`) are sequences of short
per-tensor formulas over the plastic points of a cuboid box (half of it in a strongly plastic
step): the deviator s = σ − tr(σ)/3 I, a scaling of it, a sum with another tensor, and the von
Mises norm q = sqrt(3/2 s:s) of the result. Through numpy each is one or more passes over
(m, 6) arrays with a temporary each, plus a gather and a scatter by fancy indexing; the loops
here read each tensor once and write each result once. The arithmetic is that of
:func:`~sacflow.mechanics.stress_measures.deviator` and
:func:`~sacflow.mechanics.stress_measures.equivalent_stress` (tensor shear components, counted
twice in s:s).

:func:`swift_increments` solves the consistency equation of the radial return for the Swift law
σ_Y = B (C + s p)^n (seed eq. (3.1)) point by point with the safeguarded Newton iteration of
:func:`~sacflow.mechanics.return_mapping.newton_in_bracket` (same start, bracket, stopping rule
and last correction), in registers instead of a dozen array passes per Newton step.

numba compiles each loop at its first call (cached on disk): elastic runs do without it.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

__all__ = ["extrapolated_trials", "midpoint_trials", "returned_into", "scaled_deviators_into",
           "scatter_corrected", "second_trials", "swift_increments"]

FloatArray = NDArray[np.float64]
IndexArray = NDArray[np.intp]

#: Rounding floor factor of the consistency residual (as in the return mapping): 4 ulp.
EPS4 = 4.0 * np.finfo(float).eps


@numba.njit(nogil=True, cache=True, boundscheck=False)
def _mean(t: FloatArray) -> float:  # pragma: no cover - compiled
    return float((t[0] + t[1] + t[2]) / 3.0)


@numba.njit(nogil=True, cache=True, boundscheck=False)
def _norm(s0: float, s1: float, s2: float, t3: float, t4: float,
          t5: float) -> float:  # pragma: no cover - compiled
    """Return q = sqrt(3/2 s:s) of the deviator (s0, s1, s2), tensor shears (t3, t4, t5)."""
    return float(np.sqrt(1.5 * (s0 * s0 + s1 * s1 + s2 * s2
                                + 2.0 * (t3 * t3 + t4 * t4 + t5 * t5))))


@numba.njit(nogil=True, cache=True, boundscheck=False)
def scaled_deviators_into(stress: FloatArray, idx: IndexArray, factor: FloatArray,
                          out: FloatArray) -> None:  # pragma: no cover - compiled
    """Set ``out[idx[k]] = factor[k] · dev(stress[idx[k]])`` for every k (rows of (n, 6)).

    The plastic strain increment of a radial return, 3/2 Δp s/q_tr, scattered into the box.
    """
    for k in range(idx.size):
        i = idx[k]
        mean = _mean(stress[i])
        f = factor[k]
        for j in range(3):
            out[i, j] = f * (stress[i, j] - mean)
        for j in range(3, 6):
            out[i, j] = f * stress[i, j]


@numba.njit(nogil=True, cache=True, boundscheck=False)
def returned_into(stress: FloatArray, idx: IndexArray, ratio: FloatArray,
                  out: FloatArray) -> None:  # pragma: no cover - compiled
    """Set ``out[idx[k]] = mean(σ) I + ratio[k] · dev(σ)``, σ = ``stress[idx[k]]``.

    The returned stress of a radial return, ratio = σ_Y(p + Δp)/q_tr.
    """
    for k in range(idx.size):
        i = idx[k]
        mean = _mean(stress[i])
        r = ratio[k]
        for j in range(3):
            out[i, j] = mean + r * (stress[i, j] - mean)
        for j in range(3, 6):
            out[i, j] = r * stress[i, j]


@numba.njit(nogil=True, cache=True, boundscheck=False)
def midpoint_trials(start: FloatArray, trial: FloatArray,
                    idx: IndexArray) -> tuple[FloatArray, FloatArray]:  # pragma: no cover
    """Return the first half step's trial σ_n + ½ (σ_tr − σ_n) at ``idx``, and its q."""
    m = idx.size
    mid = np.empty((m, 6))
    q = np.empty(m)
    for k in range(m):
        i = idx[k]
        for j in range(6):
            mid[k, j] = start[i, j] + 0.5 * (trial[i, j] - start[i, j])
        mean = _mean(mid[k])
        q[k] = _norm(mid[k, 0] - mean, mid[k, 1] - mean, mid[k, 2] - mean,
                     mid[k, 3], mid[k, 4], mid[k, 5])
    return mid, q


@numba.njit(nogil=True, cache=True, boundscheck=False)
def second_trials(mid: FloatArray, ratio: FloatArray, factor: FloatArray, start: FloatArray,
                  trial: FloatArray, idx: IndexArray
                  ) -> tuple[FloatArray, FloatArray, FloatArray]:  # pragma: no cover
    """Return the second half's trial, the first half's plastic strain increment, its q.

    ``mid`` is the first half's trial, ``ratio`` σ_Y(p + Δp₁)/q (1 where elastic) and
    ``factor`` 3/2 Δp₁/q (0 where elastic): the returned stress is mean + ratio · s and the
    increment factor · s; the second trial adds the other half, ½ (σ_tr − σ_n).
    """
    m = idx.size
    second = np.empty((m, 6))
    strain = np.empty((m, 6))
    q = np.empty(m)
    for k in range(m):
        i = idx[k]
        mean = _mean(mid[k])
        for j in range(6):
            s = mid[k, j] - mean if j < 3 else mid[k, j]
            strain[k, j] = factor[k] * s
            returned = ratio[k] * s + (mean if j < 3 else 0.0)
            second[k, j] = returned + 0.5 * (trial[i, j] - start[i, j])
        mean2 = _mean(second[k])
        q[k] = _norm(second[k, 0] - mean2, second[k, 1] - mean2, second[k, 2] - mean2,
                     second[k, 3], second[k, 4], second[k, 5])
    return second, strain, q


@numba.njit(nogil=True, cache=True, boundscheck=False)
def extrapolated_trials(second: FloatArray, factor: FloatArray, first_strain: FloatArray,
                        full_strain: FloatArray, trial: FloatArray, idx: IndexArray,
                        two_mu: float, w_half: float, w_full: float
                        ) -> tuple[FloatArray, FloatArray, FloatArray]:  # pragma: no cover
    """Return w_half (Δεp₁ + Δεp₂) + w_full Δεp_F (extrapolated), its drift trial, its q.

    ``factor`` is the second half's 3/2 Δp₂/q (0 where elastic), ``full_strain`` the box of
    one-step increments; the drift-correction trial is σ_tr − 2μ Δεp (extrapolated).
    """
    m = idx.size
    strain = np.empty((m, 6))
    corrected = np.empty((m, 6))
    q = np.empty(m)
    for k in range(m):
        i = idx[k]
        mean = _mean(second[k])
        for j in range(6):
            s = second[k, j] - mean if j < 3 else second[k, j]
            e = w_half * (first_strain[k, j] + factor[k] * s) + w_full * full_strain[i, j]
            strain[k, j] = e
            corrected[k, j] = trial[i, j] - two_mu * e
        mean3 = _mean(corrected[k])
        q[k] = _norm(corrected[k, 0] - mean3, corrected[k, 1] - mean3,
                     corrected[k, 2] - mean3, corrected[k, 3], corrected[k, 4],
                     corrected[k, 5])
    return strain, corrected, q


@numba.njit(nogil=True, cache=True, boundscheck=False)
def scatter_corrected(strain: FloatArray, corrected: FloatArray, factor: FloatArray,
                      idx: IndexArray, out: FloatArray) -> None:  # pragma: no cover
    """Set ``out[idx[k]] = strain[k] + factor[k] · dev(corrected[k])`` (drift-corrected)."""
    for k in range(idx.size):
        i = idx[k]
        mean = _mean(corrected[k])
        f = factor[k]
        for j in range(3):
            out[i, j] = strain[k, j] + f * (corrected[k, j] - mean)
        for j in range(3, 6):
            out[i, j] = strain[k, j] + f * corrected[k, j]


@numba.njit(nogil=True, cache=True, boundscheck=False)
def swift_increments(q: FloatArray, p0: FloatArray, B: float, C: float, n: float,
                     scale: float, three_mu: float, tol: float,
                     max_iter: int) -> tuple[FloatArray, int, int]:  # pragma: no cover
    """Return Δp solving q − 3μΔp − B (C + s (p₀ + Δp))^n = 0 at each (plastic) point.

    The safeguarded Newton iteration of
    :func:`~sacflow.mechanics.return_mapping.newton_in_bracket`, point by point: start at the
    bracket's upper end (q − σ_Y(p₀))/(3μ), keep the bracket [lo, hi] where r changes sign,
    bisect when a Newton step leaves it, stop when |r| <= max(tol σ_Y, 4 ulp of the larger of
    q and H (p₀ + Δp)) or the bracket is round-off wide, and keep a last Newton correction if
    it lies in the bracket.

    Returns
    -------
    dp : ndarray
        Δp at each point.
    iterations : int
        Updates of the slowest point.
    failed : int
        Points not converged after ``max_iter`` updates (the caller raises).
    """
    m = q.size
    dp = np.empty(m)
    iterations = 0
    failed = 0
    for k in range(m):
        lo = 0.0
        hi = (q[k] - B * (C + scale * p0[k]) ** n) / three_mu
        x = hi
        done = False
        for it in range(max_iter + 1):
            base = C + scale * (p0[k] + x)
            y = B * base ** n
            h = n * scale * y / base
            r = q[k] - three_mu * x - y
            slope = three_mu + h
            if r > 0.0:
                lo = x
            else:
                hi = x
            floor = EPS4 * max(q[k], h * (p0[k] + x))
            if abs(r) <= max(tol * y, floor) or hi - lo <= EPS4 * x:
                xn = x + r / slope
                dp[k] = xn if lo <= xn <= hi else x
                iterations = max(iterations, it)
                done = True
                break
            xn = x + r / slope
            x = xn if lo < xn < hi else 0.5 * (lo + hi)
        if not done:
            dp[k] = x
            failed += 1
            iterations = max_iter
    return dp, iterations, failed
