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
from sacflow.mechanics.return_mapping import (
    MAX_ITERATIONS,
    TOLERANCE,
    ReturnMappingError,
    ReturnResult,
    return_map,
)

__all__ = ["RICHARDSON_WEIGHTS", "extrapolated_return"]

FloatArray = NDArray[np.float64]

#: Weights of the two-half-steps and of the one-step result in the local extrapolation of a
#: first-order method with step doubling: 2 H − F.
RICHARDSON_WEIGHTS: tuple[float, float] = (2.0, -1.0)

#: Work of one point of the compiled step-doubled return, in box entries of a plain pass
#: (three radial returns): what :func:`~sacflow.machine.threads.over_ranges` weighs against
#: the cost of handing a share of the points to another thread.
POINT_WEIGHT = 16


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
    from sacflow.kernels.fft import default_threads  # with numba: plastic points only
    from sacflow.machine.threads import over_ranges
    from sacflow.mechanics.radial_kernels import compiled_law, step_doubled_points

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
    if kinematic is None:
        compiled = compiled_law(law)
        if compiled is not None:  # the whole step doubling per point, in one compiled loop
            parts = over_ranges(
                step_doubled_points, idx.size, default_threads(),
                compiled[0], compiled[1], np.ascontiguousarray(start_stress.reshape(-1, 6)),
                np.ascontiguousarray(trial_stress.reshape(-1, 6)),
                np.ascontiguousarray(np.broadcast_to(equivalent_plastic_strain, lead)
                                     .reshape(-1), dtype=float),
                idx, full.plastic_strain_increment.reshape(-1, 6),
                full.equivalent_plastic_strain_increment.reshape(-1), 2.0 * mu,
                *RICHARDSON_WEIGHTS, TOLERANCE, MAX_ITERATIONS, weight=POINT_WEIGHT)
            iterations = max(part[0] for part in parts)
            failed = sum(part[1] for part in parts)
            if failed:
                raise ReturnMappingError(f"step-doubled return: {failed} points not converged "
                                         f"after {MAX_ITERATIONS} iterations")
            return ReturnResult(None, full.plastic_strain_increment,
                                full.equivalent_plastic_strain_increment, plastic,
                                max(full.iterations, iterations))
    d_pl = _gathered_depth(depth, idx, lead)
    p_pl = np.broadcast_to(equivalent_plastic_strain, lead).reshape(-1)[idx]
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
