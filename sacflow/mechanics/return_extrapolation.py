r"""A second-order return over a load increment: backward Euler with step doubling.

The backward-Euler return (:func:`~sacflow.mechanics.return_mapping.return_map`) integrates the
Prandtl–Reuss flow over an increment in one step: the flow direction is the one at the end of
the increment. It is exact for a proportional stress path and first-order accurate in the size
of the increment otherwise. Under a contact whose stresses rotate as the contact grows or the
load moves, that first-order error is the largest discretisation error of an elastic-plastic
run: the print depth and the peak plastic strain of a nano-indentation converge at first order
in the load increment with it (``docs/convergence.md``).

Over an increment the strain at a point follows the straight path from the start of the
increment to its end (the increment's own linearisation; the elastic trial stress runs from the
converged stress σ_n to the end-of-increment trial stress σ_tr). Integrated along that path by
backward Euler in one step (result ``F``) and in two half steps (``H``: the trial stress
σ_n + ½(σ_tr − σ_n) returned from (p_n, X_n), then the rest from the returned state), the local
Richardson extrapolation ``2 H − F`` cancels the first-order term of the step error (step
doubling; Hairer, Nørsett & Wanner, *Solving Ordinary Differential Equations I*, Springer 1993,
§II.4; for elastoplastic substepping Sloan, Int. J. Numer. Meth. Eng. 24 (1987) 893,
doi:10.1002/nme.1620240505). What is left is the path's own linearisation, second order.

Only the points that yield at the end of the full step need the halves: the von Mises norm of
the relative trial stress is convex along the straight path, so a point below the yield surface
at both ends (σ_n is admissible) stays below it between them; their increments are zero either
way. The equivalent plastic strain increment is kept non-negative (the extrapolation of two
non-negative values can dip below zero where the flow starts in the second half). The
extrapolated end state may lie off the yield surface by the extrapolation's own error, O(h²):
one more return from it puts it back (drift correction; Sloan, Abbo & Sheng, Eng. Comput. 18
(2001) 121, doi:10.1108/02644400110365842), so that von Mises = σ_Y at the plastic points as
with one step, at the same order of accuracy.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from sacflow.mechanics.hardening import HardeningLaw, KinematicLaw
from sacflow.mechanics.return_mapping import ReturnResult, radial_increments, return_map

__all__ = ["RICHARDSON_WEIGHTS", "extrapolated_return"]

FloatArray = NDArray[np.float64]

#: Weights of the two-half-steps and of the one-step result in the local extrapolation of a
#: first-order method with step doubling: 2 H − F.
RICHARDSON_WEIGHTS: tuple[float, float] = (2.0, -1.0)


def extrapolated_return(start_stress: FloatArray, trial_stress: FloatArray,
                        equivalent_plastic_strain: FloatArray, law: HardeningLaw, mu: float,
                        depth: FloatArray | None = None, *,
                        kinematic: KinematicLaw | None = None,
                        backstress: FloatArray | None = None,
                        full: ReturnResult | None = None) -> ReturnResult:
    """Return over the increment from ``start_stress`` to ``trial_stress``, step-doubled.

    Parameters
    ----------
    start_stress : ndarray, shape (..., 6)
        Converged stress σ_n at the start of the increment [Pa] (admissible).
    trial_stress : ndarray, shape (..., 6)
        Elastic trial stress at the end of the increment [Pa].
    equivalent_plastic_strain : ndarray, shape (...)
        p_n before the increment.
    law, mu, depth, kinematic, backstress
        As :func:`~sacflow.mechanics.return_mapping.return_map` (``backstress`` X_n); a
        ``depth`` of one value per last-axis index (the layers) is gathered by that index.
    full : ReturnResult, optional
        The one-step return of ``trial_stress`` if already made (it is recomputed otherwise).
        Its increment arrays are overwritten (the extrapolated ones take their place: no
        box-size copy).

    Returns
    -------
    ReturnResult
        Increments ``2 H − F`` then drift-corrected (plastic strain, equivalent plastic strain
        ≥ 0, backstress with kinematic hardening); ``stress`` is None; ``plastic`` the one-step
        return's points (a point elastic over the full step is elastic over both halves).
    """
    with_backstress = kinematic is not None
    if full is None:
        full = return_map(trial_stress, equivalent_plastic_strain, law, mu, depth,
                          kinematic=kinematic, backstress=backstress,
                          with_stress=with_backstress)
    plastic = full.plastic
    idx = np.flatnonzero(plastic)
    if idx.size == 0:
        return full
    lead = plastic.shape
    d_pl = _gathered_depth(depth, idx, lead)
    p_pl = np.broadcast_to(equivalent_plastic_strain, lead).reshape(-1)[idx]
    if kinematic is None:
        iterations = _radial_step_doubling(start_stress, trial_stress, p_pl, d_pl, idx, law,
                                           mu, full)
        return ReturnResult(None, full.plastic_strain_increment,
                            full.equivalent_plastic_strain_increment, plastic,
                            max(full.iterations, iterations))
    x_pl = None if backstress is None else backstress.reshape(-1, 6)[idx]
    start = start_stress.reshape(-1, 6)[idx]
    trial = trial_stress.reshape(-1, 6)[idx]
    half = trial - start
    half *= 0.5
    first = return_map(start + half, p_pl, law, mu, d_pl, kinematic=kinematic,
                       backstress=x_pl, with_stress=True)
    assert first.stress is not None
    second = return_map(first.stress + half, p_pl + first.equivalent_plastic_strain_increment,
                        law, mu, d_pl, kinematic=kinematic, backstress=first.backstress,
                        with_stress=False)
    w_half, w_full = RICHARDSON_WEIGHTS
    strain_all = full.plastic_strain_increment.reshape(-1, 6)
    equivalent_all = full.equivalent_plastic_strain_increment.reshape(-1)
    strain = (w_half * (first.plastic_strain_increment + second.plastic_strain_increment)
              + w_full * strain_all[idx])
    equivalent = np.maximum(w_half * (first.equivalent_plastic_strain_increment
                                      + second.equivalent_plastic_strain_increment)
                            + w_full * equivalent_all[idx], 0.0)
    x_end = None
    if with_backstress:
        assert full.backstress is not None and second.backstress is not None
        x_end = w_half * second.backstress + w_full * full.backstress.reshape(-1, 6)[idx]
    # Drift correction: the extrapolated state may lie outside the yield surface by the
    # extrapolation's error; one return from it (p and X extrapolated) puts it back on.
    trial -= 2.0 * mu * strain
    correction = return_map(trial, p_pl + equivalent, law, mu, d_pl, kinematic=kinematic,
                            backstress=x_end, with_stress=False)
    strain_all[idx] = strain + correction.plastic_strain_increment
    equivalent_all[idx] = equivalent + correction.equivalent_plastic_strain_increment
    if with_backstress:
        assert full.backstress is not None and correction.backstress is not None
        full.backstress.reshape(-1, 6)[idx] = correction.backstress
    iterations = max(full.iterations, first.iterations, second.iterations,
                     correction.iterations)
    return ReturnResult(None, full.plastic_strain_increment,
                        full.equivalent_plastic_strain_increment, plastic, iterations,
                        full.backstress)


def _radial_step_doubling(start_stress: FloatArray, trial_stress: FloatArray,
                          p_pl: FloatArray, d_pl: FloatArray | None, idx: NDArray[np.intp],
                          law: HardeningLaw, mu: float, full: ReturnResult) -> int:
    """Step-double the isotropic (radial) case of :func:`extrapolated_return` in ``full``.

    The same three returns at the points ``idx`` (first half, second half, drift correction),
    each a radial return whose only scalar unknown Δp is solved by
    :func:`~sacflow.mechanics.return_mapping.radial_increments`; the tensor work between them
    (trials, deviators, the extrapolation, the scatter into the box) is done by the compiled
    row loops of :mod:`sacflow.mechanics.radial_kernels`, without box-size temporaries.
    Returns the Newton updates of the slowest point over the three returns.
    """
    from sacflow.mechanics.radial_kernels import (  # numba: plastic runs only
        extrapolated_trials,
        midpoint_trials,
        scatter_corrected,
        second_trials,
    )

    start = np.ascontiguousarray(start_stress.reshape(-1, 6))
    trial = np.ascontiguousarray(trial_stress.reshape(-1, 6))
    strain_all = full.plastic_strain_increment.reshape(-1, 6)
    equivalent_all = full.equivalent_plastic_strain_increment.reshape(-1)
    w_half, w_full = RICHARDSON_WEIGHTS
    three_mu = 3.0 * mu
    mid, q_mid = midpoint_trials(start, trial, idx)
    dp1, ratio1, factor1, it1 = _radial_half(q_mid, p_pl, d_pl, law, three_mu)
    second, first_strain, q_second = second_trials(mid, ratio1, factor1, start, trial, idx)
    p_first = p_pl + dp1
    dp2, _, factor2, it2 = _radial_half(q_second, p_first, d_pl, law, three_mu)
    equivalent = np.maximum(w_half * (dp1 + dp2) + w_full * equivalent_all[idx], 0.0)
    strain, corrected, q_corrected = extrapolated_trials(
        second, factor2, first_strain, strain_all, trial, idx, 2.0 * mu, w_half, w_full)
    dp3, _, factor3, it3 = _radial_half(q_corrected, p_pl + equivalent, d_pl, law, three_mu)
    scatter_corrected(strain, corrected, factor3, idx, strain_all)
    equivalent_all[idx] = equivalent + dp3
    return max(it1, it2, it3)


def _radial_half(q: FloatArray, p0: FloatArray, depth: FloatArray | None, law: HardeningLaw,
                 three_mu: float) -> tuple[FloatArray, FloatArray, FloatArray, int]:
    """Return-map points of trial norm ``q``: Δp, σ_Y(p₀ + Δp)/q, 3/2 Δp/q and the updates.

    Points at or below the yield surface get Δp = 0, the ratio 1 and the factor 0 (their
    stress is the trial one).
    """
    y0 = law.yield_stress(p0, depth)
    plastic = np.flatnonzero(q > y0)
    dp = np.zeros(q.shape)
    ratio = np.ones(q.shape)
    factor = np.zeros(q.shape)
    if plastic.size == 0:
        return dp, ratio, factor, 0
    q_pl = q[plastic]
    d_pl = None if depth is None else depth[plastic]
    dp_pl, iterations = radial_increments(q_pl, p0[plastic], d_pl, law, three_mu)
    dp[plastic] = dp_pl
    ratio[plastic] = law.yield_stress(p0[plastic] + dp_pl, d_pl) / q_pl
    factor[plastic] = 1.5 * dp_pl / q_pl
    return dp, ratio, factor, iterations


def _gathered_depth(depth: FloatArray | None, idx: NDArray[np.intp],
                    lead: tuple[int, ...]) -> FloatArray | None:
    """Return the depths of the flat points ``idx`` of an array of shape ``lead``."""
    if depth is None:
        return None
    depth = np.asarray(depth, dtype=float)
    if depth.ndim == 1 and depth.size == lead[-1]:  # one per layer: no box-size broadcast
        gathered: FloatArray = depth[idx % lead[-1]]
        return gathered
    return np.broadcast_to(depth, lead).reshape(-1)[idx]
