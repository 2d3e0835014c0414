"""Derivative of the return mapping's plastic strain increment with respect to the trial stress.

Used, matrix-free, by the solver's Newton–Krylov iteration, where the directional derivative
dΔεp[dσ] is all it needs; zero at elastic points.

* Isotropic hardening: the algorithmic tangent in closed form. For a plastic point with flow
  direction N = 3/2 s_tr/q_tr, Δp and slope H = σ_Y'(p + Δp), differentiating Δεp = Δp N with
  q_tr − 3μΔp − σ_Y(p + Δp) = 0 gives (Simo & Hughes, *Computational Inelasticity*, Springer
  1998, §3.3.2)

      dΔεp = N (N:dσ) / (3μ + H) + (Δp / q_tr) (3/2 dσ_dev − N (N:dσ)).

* With a backstress: the central difference [Δεp(σ_tr + h dσ) − Δεp(σ_tr − h dσ)] / 2h of
  :func:`~sacflow.mechanics.return_mapping.return_map` with the state (p_n, X_n) fixed,
  h = :data:`TANGENT_STEP` · max|σ_tr| / max|dσ|.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sacflow.mechanics.hardening import HardeningLaw, KinematicLaw
from sacflow.mechanics.return_mapping import ReturnResult, return_map
from sacflow.mechanics.stress_measures import deviator, deviatoric_equivalent, double_contraction

__all__ = ["TANGENT_STEP", "ReturnTangent"]

FloatArray = NDArray[np.float64]
#: Relative step of the central differences with a backstress (of the trial stress).
TANGENT_STEP = 1e-6


class ReturnTangent:
    """dΔεp/dσ_tr of a return at its plastic points (matrix-free, module docstring).

    Closed form for isotropic hardening, central differences of
    :func:`~sacflow.mechanics.return_mapping.return_map` with a backstress.

    Parameters
    ----------
    trial_stress, equivalent_plastic_strain, law, mu, depth, kinematic, backstress
        The arguments of the return (``kinematic`` None: isotropic hardening).
    result : ReturnResult
        What the return gave.
    """

    def __init__(self, trial_stress: ArrayLike, result: ReturnResult,
                 equivalent_plastic_strain: ArrayLike, law: HardeningLaw, mu: float,
                 depth: ArrayLike | None = None, *, kinematic: KinematicLaw | None = None,
                 backstress: ArrayLike | None = None):
        lead = result.plastic.shape
        self.index = np.flatnonzero(result.plastic.reshape(-1))
        self.shape = lead + (6,)

        def take(a: ArrayLike, tail: tuple[int, ...] = ()) -> FloatArray:
            full = np.broadcast_to(np.asarray(a, float), lead + tail)
            out: FloatArray = full.reshape(-1, *tail)[self.index]
            return out

        self.trial = np.asarray(trial_stress, float).reshape(-1, 6)[self.index]
        self.p = take(equivalent_plastic_strain)
        self.depth = None if depth is None else take(depth)
        self.law, self.mu, self.kinematic = law, mu, kinematic
        self.backstress = None if kinematic is None else take(
            np.zeros(6) if backstress is None else backstress, (6,))
        self.scale = float(np.abs(self.trial).max()) if self.index.size else 0.0
        if kinematic is None:
            s = deviator(self.trial)
            q = deviatoric_equivalent(s)
            dp = result.equivalent_plastic_strain_increment.reshape(-1)[self.index]
            slope = law.slope(self.p + dp, self.depth)
            self.N = 1.5 * s / q[:, None]
            self.a = 1.0 / (3.0 * mu + slope)
            self.b = dp / q

    def apply(self, dsigma: ArrayLike) -> FloatArray:
        """Return dΔεp (shape of the trial stress) for a stress perturbation ``dsigma``."""
        out = np.zeros(self.shape).reshape(-1, 6)
        if self.index.size:
            ds = np.asarray(dsigma, float).reshape(-1, 6)[self.index]
            out[self.index] = (self.closed_form(ds) if self.kinematic is None
                               else self.central_difference(ds))
        return out.reshape(self.shape)

    def closed_form(self, ds: FloatArray) -> FloatArray:
        """dΔεp at the plastic points for isotropic hardening (module docstring)."""
        nd = double_contraction(self.N, ds)
        out: FloatArray = (self.N * ((self.a - self.b) * nd)[:, None]
                           + 1.5 * self.b[:, None] * deviator(ds))
        return out

    def central_difference(self, ds: FloatArray) -> FloatArray:
        """dΔεp at the plastic points with a backstress (module docstring)."""
        size = float(np.abs(ds).max())
        if size == 0.0:
            return np.zeros(ds.shape)
        h = TANGENT_STEP * self.scale / size
        plus, minus = (return_map(self.trial + sign * h * ds, self.p, self.law, self.mu,
                                  self.depth, kinematic=self.kinematic,
                                  backstress=self.backstress, with_stress=False)
                       for sign in (1.0, -1.0))
        out: FloatArray = (plus.plastic_strain_increment
                           - minus.plastic_strain_increment) / (2.0 * h)
        return out
