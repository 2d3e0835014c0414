r"""Combined isotropic–kinematic hardening: the backstress and its return mapping.

Model (Chaboche 1989, one Armstrong–Frederick backstress; Lemaitre & Chaboche, *Mechanics of
Solid Materials*, CUP 1990, §5.4): von Mises yield with a backstress X (deviatoric, tensor
components),

.. math::

    f = \sqrt{\tfrac32 (s - X):(s - X)} - \sigma_Y(p), \qquad
    d\varepsilon^p = \tfrac32\, dp\, \frac{s - X}{\sigma_Y(p)}, \qquad
    dX = \tfrac23 C\, d\varepsilon^p - \gamma X\, dp,

σ_Y(p) any isotropic law of :mod:`sacflow.mechanics.plasticity`; γ = 0 is linear kinematic hardening
(Prager–Ziegler). Over an increment from (σ_n, p_n, X_n) with the trial stress
σ_tr = σ_n + 2μ Δε (deviatoric part s_tr), the isotropic part is integrated by backward Euler
(σ_Y at p_n + Δp) and the backstress exactly for a flow direction n = Δεp/Δp that is constant
over the increment (the exponential integrator of the linear equation dX/dp = 2/3 C n − γX):

.. math::

    X_{n+1} = X_n e^{-\gamma\Delta p} + \tfrac23 C\, \varphi(\Delta p)\, n, \qquad
    \varphi(\Delta p) = \frac{1 - e^{-\gamma\Delta p}}{\gamma}, \qquad
    s_{n+1} = s_{tr} - 2\mu\,\Delta p\, n

(φ = Δp for γ = 0).

The relative stress η = s_{n+1} − X_{n+1} is then parallel to ζ(Δp) = s_tr − X_n e^{−γΔp},
n = 3/2 ζ/q(ζ) with q(·) = sqrt(3/2 ·:·), and consistency (q(η) = σ_Y(p_n + Δp)) is the scalar
equation

.. math::

    r(\Delta p) = q(\zeta(\Delta p)) - 3\mu\Delta p - C\varphi(\Delta p)
                  - \sigma_Y(p_n + \Delta p) = 0,

solved by Newton kept in the bracket 0 < Δp <= (q(s_tr) + q(X_n) − σ_Y(p_n))/(3μ), where r
changes sign (bisection when a step leaves it). Under uniaxial or any proportional loading the
backstress then follows the closed form X = C/γ ± (X_0 − C/γ) exp(∓γ Δεp) to the solver
tolerance, whatever the increment size. With γ = 0, ζ = s_tr − X_n is fixed and the return is
radial with the hardening modulus H + C. The stress is assembled as X_{n+1} + ζ σ_Y/q(ζ) plus
the trial mean stress, so that the yield function is zero to round-off.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sacflow.mechanics.plasticity import (
    HardeningLaw,
    ReturnMappingError,
    deviator,
    double_contraction,
)

__all__ = ["KinematicLaw", "KinematicReturn", "KinematicTangent", "kinematic_from_schema",
           "kinematic_return"]


@dataclass(frozen=True)
class KinematicLaw:
    """Armstrong–Frederick backstress: modulus C [Pa], dynamic recall γ (0: Prager–Ziegler)."""

    modulus: float
    recall: float = 0.0

    def __post_init__(self) -> None:
        """Refuse a negative modulus or recall."""
        if not (self.modulus >= 0.0 and self.recall >= 0.0):
            raise ValueError(f"kinematic hardening needs C >= 0 and gamma >= 0, got "
                             f"C = {self.modulus}, gamma = {self.recall}")

    @property
    def saturation(self) -> float:
        """C/γ [Pa]: the backstress's uniaxial limit (inf for linear kinematic hardening)."""
        return self.modulus / self.recall if self.recall > 0.0 else np.inf


@dataclass(frozen=True)
class KinematicReturn:
    """Result of :func:`kinematic_return` (arrays over the leading shape of the trial stress).

    Attributes
    ----------
    stress : ndarray, shape (..., 6)
        Returned stress [Pa].
    plastic_strain_increment : ndarray, shape (..., 6)
        Deviatoric Δεp, tensor components.
    eqps_increment : ndarray, shape (...)
        Δp >= 0.
    backstress : ndarray, shape (..., 6)
        X_{n+1} [Pa] (X_n where the step is elastic).
    plastic : ndarray of bool, shape (...)
        True where the trial state violated the yield condition.
    iterations : int
        Largest number of Newton/bisection updates over the points.
    """

    stress: np.ndarray
    plastic_strain_increment: np.ndarray
    eqps_increment: np.ndarray
    backstress: np.ndarray
    plastic: np.ndarray
    iterations: int


def _q(tensor: np.ndarray) -> np.ndarray:
    """sqrt(3/2 t:t) of (..., 6) deviatoric tensors."""
    return np.sqrt(1.5 * double_contraction(tensor, tensor))


def kinematic_return(trial_stress, eqps, backstress, law: HardeningLaw, kinematic: KinematicLaw,
                     mu: float, depth=None, tol: float = 1e-12,
                     max_iter: int = 60) -> KinematicReturn:
    """Backward-Euler return mapping with isotropic and Armstrong–Frederick hardening.

    See the module docstring for the equations.

    Parameters
    ----------
    trial_stress : ndarray, shape (..., 6)
        Trial stress [Pa].
    eqps : array_like, broadcastable to (...)
        Accumulated equivalent plastic strain p_n >= 0.
    backstress : array_like, broadcastable to (..., 6)
        Backstress X_n [Pa], deviatoric.
    law : HardeningLaw
        Isotropic part σ_Y(p).
    kinematic : KinematicLaw
        C and γ.
    mu : float
        Shear modulus [Pa].
    depth : array_like, optional
        Depth x3 [m] for depth-scaled laws.
    tol : float
        Relative tolerance on the consistency residual (of σ_Y).
    max_iter : int
        Newton/bisection updates before :class:`~sacflow.mechanics.plasticity.ReturnMappingError`.

    Returns
    -------
    KinematicReturn
    """
    if not mu > 0:
        raise ValueError(f"shear modulus mu must be > 0, got {mu}")
    sig = np.asarray(trial_stress, dtype=float)
    lead = sig.shape[:-1]
    sig2 = sig.reshape(-1, 6)
    x_old = np.broadcast_to(np.asarray(backstress, float), sig.shape).reshape(-1, 6)
    p_old = np.broadcast_to(np.asarray(eqps, float), lead).reshape(-1)
    d_all = None if depth is None else np.broadcast_to(np.asarray(depth, float), lead).reshape(-1)
    s_tr = deviator(sig2)
    y_old = law.yield_stress(p_old, d_all)
    plastic = _q(s_tr - x_old) > y_old
    out_stress, out_x = sig2.copy(), x_old.copy()
    dep = np.zeros(sig2.shape)
    dp_all = np.zeros(p_old.shape)
    idx = np.flatnonzero(plastic)
    iterations = 0
    if idx.size:
        c, g, three_mu = kinematic.modulus, kinematic.recall, 3.0 * mu
        s, x0, p0 = s_tr[idx], x_old[idx], p_old[idx]
        d = None if d_all is None else d_all[idx]
        dp, iterations = _solve_consistency(s, x0, p0, d, law, c, g, three_mu, tol, max_iter)
        decay, phi = _decay(g, dp)
        zeta = s - x0 * decay[:, None]
        q_zeta = _q(zeta)
        direction = 1.5 * zeta / q_zeta[:, None]  # n: sqrt(2/3 n:n) = 1
        x_new = x0 * decay[:, None] + (2.0 / 3.0) * c * phi[:, None] * direction
        y_new = law.yield_stress(p0 + dp, d)
        new = x_new + zeta * (y_new / q_zeta)[:, None]
        new[:, :3] += ((sig2[idx, 0] + sig2[idx, 1] + sig2[idx, 2]) / 3.0)[:, None]
        out_stress[idx], out_x[idx], dp_all[idx] = new, x_new, dp
        dep[idx] = direction * dp[:, None]
    return KinematicReturn(out_stress.reshape(sig.shape), dep.reshape(sig.shape),
                           dp_all.reshape(lead), out_x.reshape(sig.shape),
                           plastic.reshape(lead), iterations)


def _decay(g: float, dp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """e^{−γΔp} and φ(Δp) = (1 − e^{−γΔp})/γ (Δp for γ = 0), without cancellation."""
    if g == 0.0:
        return np.ones_like(dp), dp.copy()
    return np.exp(-g * dp), -np.expm1(-g * dp) / g


def _solve_consistency(s, x0, p0, d, law: HardeningLaw, c: float, g: float, three_mu: float,
                       tol: float, max_iter: int) -> tuple[np.ndarray, int]:
    """Δp solving r(Δp) = 0 (module docstring) at every point: safeguarded Newton."""
    eps4 = 4.0 * np.finfo(float).eps
    lo = np.zeros(p0.shape)
    hi = (_q(s) + _q(x0) - law.yield_stress(p0, d)) / three_mu
    x = 0.5 * hi
    result = np.zeros(p0.shape)
    act = np.arange(p0.size)
    for it in range(max_iter + 1):
        da = None if d is None else d[act]
        decay, phi = _decay(g, x)
        zeta = s[act] - x0[act] * decay[:, None]
        qz = _q(zeta)
        y, h = law.yield_and_slope(p0[act] + x, da)
        r = qz - three_mu * x - c * phi - y
        # dr/dΔp: dζ/dΔp = γ X_n e^{−γΔp}, dφ/dΔp = e^{−γΔp}
        dq = 1.5 * g * decay * double_contraction(zeta, x0[act]) / qz
        slope = dq - three_mu - c * decay - h
        pos = r > 0.0
        lo[act], hi[act] = np.where(pos, x, lo[act]), np.where(pos, hi[act], x)
        floor = eps4 * np.maximum(qz, np.abs(h) * (p0[act] + x) + c * x)
        done = (np.abs(r) <= np.maximum(tol * y, floor)) | (hi[act] - lo[act] <= eps4 * x)
        result[act[done]] = x[done]
        keep = ~done
        act, x, r, slope = act[keep], x[keep], r[keep], slope[keep]
        if act.size == 0:
            return result, it + 1
        if it == max_iter:
            raise ReturnMappingError(
                f"kinematic return: {act.size} points not converged after {max_iter} "
                f"iterations (max residual {np.max(np.abs(r)):.3e} Pa)")
        with np.errstate(divide="ignore", invalid="ignore"):
            xn = x - r / slope
        inside = np.isfinite(xn) & (xn > lo[act]) & (xn < hi[act])
        x = np.where(inside, xn, 0.5 * (lo[act] + hi[act]))
    return result, max_iter


#: Relative step of the central differences in :class:`KinematicTangent` (of the trial stress).
TANGENT_STEP = 1e-6


class KinematicTangent:
    """Derivative of the kinematic return's Δεp with respect to the trial stress, matrix-free.

    At the plastic points of a return, ``apply(dσ)`` is the central difference
    [Δεp(σ_tr + h dσ) − Δεp(σ_tr − h dσ)] / 2h of :func:`kinematic_return` with the state
    (p_n, X_n) fixed, h = :data:`TANGENT_STEP` · max|σ_tr| / max|dσ|; zero at elastic points.
    Used, like :class:`sacflow.mechanics.plasticity.ReturnTangent` for isotropic hardening, by the
    solver's Newton–Krylov iteration, where the directional derivative is all it needs.
    """

    def __init__(self, trial_stress, result: KinematicReturn, eqps, backstress,
                 law: HardeningLaw, kinematic: KinematicLaw, mu: float, depth=None):
        plastic = result.plastic.reshape(-1)
        self.index = np.flatnonzero(plastic)
        self.shape = result.plastic.shape + (6,)
        lead = result.plastic.shape
        take = self.index

        def flat(a, tail=()):
            return np.broadcast_to(np.asarray(a, float), lead + tail).reshape(-1, *tail)[take]

        self.trial = np.asarray(trial_stress, float).reshape(-1, 6)[take]
        self.p = flat(eqps)
        self.x = flat(backstress, (6,))
        self.depth = None if depth is None else flat(depth)
        self.law, self.kinematic, self.mu = law, kinematic, mu
        self.scale = float(np.abs(self.trial).max()) if take.size else 0.0

    def apply(self, dsigma: np.ndarray) -> np.ndarray:
        """Return dΔεp (shape of the trial stress) for a stress perturbation ``dsigma``."""
        out = np.zeros(self.shape).reshape(-1, 6)
        if self.index.size:
            ds = np.asarray(dsigma, float).reshape(-1, 6)[self.index]
            size = float(np.abs(ds).max())
            if size > 0.0:
                h = TANGENT_STEP * self.scale / size
                plus, minus = (kinematic_return(self.trial + sign * h * ds, self.p, self.x,
                                                self.law, self.kinematic, self.mu, self.depth)
                               for sign in (1.0, -1.0))
                out[self.index] = (plus.plastic_strain_increment
                                   - minus.plastic_strain_increment) / (2.0 * h)
        return out.reshape(self.shape)


def kinematic_from_schema(hardening) -> KinematicLaw | None:
    """Return the :class:`KinematicLaw` of a schema hardening law (or dict), or None."""
    spec = (hardening.get("kinematic") if isinstance(hardening, dict)
            else getattr(hardening, "kinematic", None))
    if spec is None:
        return None
    if isinstance(spec, dict):
        return KinematicLaw(float(spec["modulus"]), float(spec.get("recall", 0.0)))
    return KinematicLaw(float(spec.modulus), float(spec.recall))
