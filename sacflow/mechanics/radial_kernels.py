r"""Compiled loops of the radial return: deviator scatters, Δp, and the step-doubled return.

The radial return (:func:`~sacflow.mechanics.return_mapping.isotropic_return`) and its
step-doubled form (:mod:`sacflow.mechanics.return_extrapolation`) are sequences of short
per-tensor formulas over the plastic points of a cuboid box (half of it in a strongly plastic
step): the deviator s = σ − tr(σ)/3 I, a scaling of it, a sum with another tensor, the von Mises
norm q = sqrt(3/2 s:s) of the result, and one scalar equation per point for Δp,
r(Δp) = q − 3μΔp − σ_Y(p₀ + Δp) = 0. Through numpy each is one or more passes over (m, 6)
arrays with a temporary each, a gather and a scatter by fancy indexing, and a dozen array passes
per Newton update; the loops here read each tensor once and write each result once, and solve
Δp in registers. The arithmetic is that of :func:`~sacflow.mechanics.stress_measures.deviator`
and :func:`~sacflow.mechanics.stress_measures.equivalent_stress` (tensor shear components,
counted twice in s:s) and of the return mapping's safeguarded Newton iteration
(:func:`~sacflow.mechanics.return_mapping.newton_in_bracket`: same start, bracket, stopping rule
and last correction).

The laws evaluated in compiled code (:func:`compiled_law`) are linear hardening, perfect
plasticity (where Δp has a closed form) and the Swift law σ_Y = B (C + s p)^n (seed eq. (3.1));
the others (tabular, depth-scaled) keep the array code. :func:`step_doubled_points` is the whole
step-doubled return of one point (three radial returns and the extrapolation) in one loop.

numba compiles each loop at its first call (cached on disk): elastic runs do without it.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

from sacflow.mechanics.hardening import (
    HardeningLaw,
    LinearHardening,
    PerfectPlasticity,
    SwiftHardening,
)

__all__ = ["LINEAR", "SWIFT", "compiled_law", "returned_into",
           "scaled_deviators_into", "step_doubled_points"]

FloatArray = NDArray[np.float64]
IndexArray = NDArray[np.intp]

#: Rounding floor factor of the consistency residual (as in the return mapping): 4 ulp.
EPS4 = 4.0 * np.finfo(float).eps
#: Law codes of the compiled loops: σ_Y = σ_Y0 + H p (parameters σ_Y0, H) and the Swift law
#: σ_Y = B (C + s p)^n (parameters B, C, n, s).
LINEAR, SWIFT = 0, 1


def compiled_law(law: HardeningLaw) -> tuple[int, FloatArray] | None:
    """Return the code and parameters of a law the compiled loops evaluate, or None.

    Linear hardening, perfect plasticity (H = 0) and the Swift law; any other law (tabular,
    depth-scaled, user-defined) is left to the array code.
    """
    kind = type(law)
    if kind is LinearHardening or kind is PerfectPlasticity:
        assert isinstance(law, LinearHardening)
        return LINEAR, np.array([law.initial_yield_stress, law.modulus, 0.0, 0.0])
    if kind is SwiftHardening:
        assert isinstance(law, SwiftHardening)
        return SWIFT, np.array([law.B, law.C, law.n, law.scale])
    return None


@numba.njit(nogil=True, cache=True, boundscheck=False, error_model="numpy")
def _mean(t: FloatArray) -> float:  # pragma: no cover - compiled
    return float((t[0] + t[1] + t[2]) / 3.0)


@numba.njit(nogil=True, cache=True, boundscheck=False, error_model="numpy")
def _norm(s0: float, s1: float, s2: float, t3: float, t4: float,
          t5: float) -> float:  # pragma: no cover - compiled
    """Return q = sqrt(3/2 s:s) of the deviator (s0, s1, s2), tensor shears (t3, t4, t5)."""
    return float(np.sqrt(1.5 * (s0 * s0 + s1 * s1 + s2 * s2
                                + 2.0 * (t3 * t3 + t4 * t4 + t5 * t5))))


@numba.njit(nogil=True, cache=True, boundscheck=False, error_model="numpy")
def scaled_deviators_into(stress: FloatArray, idx: IndexArray, factor: FloatArray,
                          out: FloatArray, first: int,
                          last: int) -> None:  # pragma: no cover - compiled
    """Set ``out[idx[k]] = factor[k] · dev(stress[idx[k]])`` for first ≤ k < last (rows of (n, 6)).

    The plastic strain increment of a radial return, 3/2 Δp s/q_tr, scattered into the box.
    """
    idx, factor = idx[first:last], factor[first:last]  # from 0: no negative-index checks on k
    for k in range(idx.size):
        i = idx[k]
        mean = _mean(stress[i])
        f = factor[k]
        for j in range(3):
            out[i, j] = f * (stress[i, j] - mean)
        for j in range(3, 6):
            out[i, j] = f * stress[i, j]


@numba.njit(nogil=True, cache=True, boundscheck=False, error_model="numpy")
def returned_into(stress: FloatArray, idx: IndexArray, ratio: FloatArray, out: FloatArray,
                  first: int, last: int) -> None:  # pragma: no cover - compiled
    """Set ``out[idx[k]] = mean(σ) I + ratio[k] · dev(σ)``, σ = ``stress[idx[k]]``.

    The returned stress of a radial return, ratio = σ_Y(p + Δp)/q_tr, for first ≤ k < last.
    """
    idx, ratio = idx[first:last], ratio[first:last]
    for k in range(idx.size):
        i = idx[k]
        mean = _mean(stress[i])
        r = ratio[k]
        for j in range(3):
            out[i, j] = mean + r * (stress[i, j] - mean)
        for j in range(3, 6):
            out[i, j] = r * stress[i, j]


@numba.njit(nogil=True, cache=True, boundscheck=False, error_model="numpy")
def _yield_and_slope(kind: int, prm: FloatArray,
                     p: float) -> tuple[float, float]:  # pragma: no cover - compiled
    """σ_Y(p) and dσ_Y/dp of the law ``kind`` with parameters ``prm`` (:func:`compiled_law`)."""
    if kind == LINEAR:
        return prm[0] + prm[1] * p, prm[1]
    base = prm[1] + prm[3] * p
    y = prm[0] * base ** prm[2]
    return y, prm[2] * prm[3] * y / base


@numba.njit(nogil=True, cache=True, boundscheck=False, error_model="numpy")
def _radial_dp(kind: int, prm: FloatArray, q: float, p0: float, three_mu: float, tol: float,
               max_iter: int) -> tuple[float, int, bool]:  # pragma: no cover - compiled
    """Δp of one radial return of trial norm ``q`` from p₀: (Δp, updates, converged).

    Δp = 0 at or below the yield surface; the closed form (q − σ_Y(p₀))/(3μ + H) for linear
    hardening; otherwise the safeguarded Newton iteration of
    :func:`~sacflow.mechanics.return_mapping.newton_in_bracket` (start at the bracket's upper
    end (q − σ_Y(p₀))/(3μ), keep the bracket where r changes sign, bisect when a step leaves it,
    stop when |r| <= max(tol σ_Y, 4 ulp of the larger of q and H (p₀ + Δp)) or the bracket is
    round-off wide, and keep a last Newton correction if it lies in the bracket).
    """
    y0, h0 = _yield_and_slope(kind, prm, p0)
    if not q > y0:
        return 0.0, 0, True
    if kind == LINEAR:
        return (q - y0) / (three_mu + h0), 1, True
    lo = 0.0
    hi = (q - y0) / three_mu
    x = hi
    for it in range(max_iter + 1):
        y, h = _yield_and_slope(kind, prm, p0 + x)
        r = q - three_mu * x - y
        slope = three_mu + h
        if r > 0.0:
            lo = x
        else:
            hi = x
        if abs(r) <= max(tol * y, EPS4 * max(q, h * (p0 + x))) or hi - lo <= EPS4 * x:
            xn = x + r / slope
            return (xn if lo <= xn <= hi else x), it, True
        xn = x + r / slope
        x = xn if lo < xn < hi else 0.5 * (lo + hi)
    return x, max_iter, False


@numba.njit(nogil=True, cache=True, boundscheck=False, error_model="numpy")
def _deviator_and_norm(t: FloatArray, s: FloatArray) -> tuple[float, float]:  # pragma: no cover
    """Write dev(t) into ``s``; return mean(t) and q = sqrt(3/2 s:s)."""
    mean = _mean(t)
    for j in range(3):
        s[j] = t[j] - mean
    for j in range(3, 6):
        s[j] = t[j]
    return mean, _norm(s[0], s[1], s[2], s[3], s[4], s[5])


@numba.njit(nogil=True, cache=True, boundscheck=False, error_model="numpy")
def step_doubled_points(kind: int, prm: FloatArray, start: FloatArray, trial: FloatArray,
                        p_all: FloatArray, idx: IndexArray, strain_all: FloatArray,
                        dp_all: FloatArray, two_mu: float, w_half: float, w_full: float,
                        tol: float, max_iter: int, first: int,
                        last: int) -> tuple[int, int]:  # pragma: no cover
    """Step-doubled radial return at the points ``idx``, in place of their one-step increments.

    Per point, with h = ½ (σ_tr − σ_n): the first half returns σ_n + h from p₀ (Δp₁, Δεp₁,
    returned stress mean + s σ_Y(p₀ + Δp₁)/q), the second half that stress + h from p₀ + Δp₁
    (Δp₂, Δεp₂); the increment w_half (Δεp₁ + Δεp₂) + w_full Δεp_F (Δεp_F the one-step
    increment in ``strain_all``) and Δp likewise, kept ≥ 0; then one drift-correcting return of
    σ_tr − 2μ Δεp from p₀ + Δp (:mod:`sacflow.mechanics.return_extrapolation`). The results
    replace ``strain_all[idx]`` and ``dp_all[idx]``, for the points idx[first … last − 1] (a
    thread's share). Returns the updates of the slowest Newton iteration and the number of
    points where one did not converge.
    """
    three_mu = 1.5 * two_mu
    iterations = 0
    failed = 0
    half = np.empty(6)
    point = np.empty(6)
    s = np.empty(6)
    strain = np.empty(6)
    for i in idx[first:last]:
        p0 = p_all[i]
        for j in range(6):
            half[j] = 0.5 * (trial[i, j] - start[i, j])
            point[j] = start[i, j] + half[j]
        mean, q = _deviator_and_norm(point, s)
        dp1, it1, ok1 = _radial_dp(kind, prm, q, p0, three_mu, tol, max_iter)
        ratio, factor = 1.0, 0.0
        if dp1 > 0.0:
            ratio = _yield_and_slope(kind, prm, p0 + dp1)[0] / q
            factor = 1.5 * dp1 / q
        for j in range(6):
            strain[j] = w_half * factor * s[j]
            point[j] = ratio * s[j] + (mean if j < 3 else 0.0) + half[j]
        mean, q = _deviator_and_norm(point, s)
        dp2, it2, ok2 = _radial_dp(kind, prm, q, p0 + dp1, three_mu, tol, max_iter)
        factor = 1.5 * dp2 / q if dp2 > 0.0 else 0.0
        for j in range(6):
            strain[j] += w_half * factor * s[j] + w_full * strain_all[i, j]
            point[j] = trial[i, j] - two_mu * strain[j]
        dp = max(w_half * (dp1 + dp2) + w_full * dp_all[i], 0.0)
        mean, q = _deviator_and_norm(point, s)
        dp3, it3, ok3 = _radial_dp(kind, prm, q, p0 + dp, three_mu, tol, max_iter)
        factor = 1.5 * dp3 / q if dp3 > 0.0 else 0.0
        for j in range(6):
            strain_all[i, j] = strain[j] + factor * s[j]
        dp_all[i] = dp + dp3
        iterations = max(iterations, it1, it2, it3)
        failed += 0 if (ok1 and ok2 and ok3) else 1
    return iterations, failed
