r"""The return mapping of von Mises plasticity: isotropic and Armstrong–Frederick hardening.

Model: Prandtl–Reuss flow, von Mises yield with an isotropic law σ_Y(p) (Jacq et al., ASME J.
Tribol. 124 (2002) 653, eqs. (3.1)–(3.2), doi:10.1115/1.1467920) and optionally one
Armstrong–Frederick backstress X (deviatoric, tensor components; Chaboche 1989; Lemaitre &
Chaboche, *Mechanics of Solid Materials*, CUP 1990, §5.4):

.. math::

    f = \sqrt{\tfrac32 (s - X):(s - X)} - \sigma_Y(p), \qquad
    d\varepsilon^p = \tfrac32\, dp\, \frac{s - X}{\sigma_Y(p)}, \qquad
    dX = \tfrac23 C\, d\varepsilon^p - \gamma X\, dp

(γ = 0: linear kinematic hardening, Prager–Ziegler; C = 0 and X = 0: isotropic hardening).
Over an increment from (σ_n, p_n, X_n) with the trial stress σ_tr = σ_n + 2μ Δε (deviatoric
part s_tr), the isotropic part is integrated by backward Euler (σ_Y at p_n + Δp; Simo & Hughes,
*Computational Inelasticity*, Springer 1998, §3.3, Box 3.1, doi:10.1007/b98904) and the
backstress exactly for a flow direction n = Δεp/Δp constant over the increment:

.. math::

    X_{n+1} = X_n e^{-\gamma\Delta p} + \tfrac23 C\, \varphi(\Delta p)\, n, \qquad
    \varphi(\Delta p) = \frac{1 - e^{-\gamma\Delta p}}{\gamma}, \qquad
    s_{n+1} = s_{tr} - 2\mu\,\Delta p\, n

(φ = Δp for γ = 0). The relative stress η = s_{n+1} − X_{n+1} is parallel to
ζ(Δp) = s_tr − X_n e^{−γΔp}, n = 3/2 ζ/q(ζ) with q(·) = sqrt(3/2 ·:·), and consistency
(q(η) = σ_Y(p_n + Δp)) is the scalar equation

.. math::

    r(\Delta p) = q(\zeta(\Delta p)) - 3\mu\Delta p - C\varphi(\Delta p)
                  - \sigma_Y(p_n + \Delta p) = 0,

solved at every plastic point by one safeguarded Newton iteration (:func:`solve_consistency`),
kept in the bracket 0 < Δp <= (q(s_tr) + q(X_n) − σ_Y(p_n))/(3μ) where r changes sign. For
isotropic hardening ζ = s_tr is fixed: the return is radial, r = q_tr − 3μΔp − σ_Y(p_n + Δp);
that case takes a path of its own without backstress arrays (the hot path of every plastic
sweep of the solver). The stress is assembled as X_{n+1} + ζ σ_Y/q(ζ) plus the trial mean
stress, so that the yield function is zero to round-off; elastic points are returned bit for
bit. Under uniaxial or any proportional loading the backstress follows the closed form
X = C/γ ± (X_0 − C/γ) exp(∓γ Δεp) to the solver tolerance, whatever the increment size.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sacflow.mechanics.hardening import (
    HardeningLaw,
    KinematicLaw,
    LinearHardening,
    PerfectPlasticity,
)
from sacflow.mechanics.stress_measures import (
    deviator,
    deviatoric_equivalent,
    double_contraction,
    equivalent_stress,
)

__all__ = ["MAX_ITERATIONS", "TOLERANCE", "ReturnMappingError", "ReturnResult",
           "radial_increments", "return_map", "solve_consistency"]

FloatArray = NDArray[np.float64]
#: Relative tolerance on the consistency residual (of σ_Y).
TOLERANCE = 1e-12
#: Newton/bisection updates before :class:`ReturnMappingError`.
MAX_ITERATIONS = 60
#: Box entries a radial return's scatter reads and writes per plastic point (six stress
#: components in, six increments out): what :func:`~sacflow.machine.threads.over_ranges`
#: weighs against the cost of handing a share of the points to another thread (counted as one
#: entry a point, the half million plastic points of a strongly plastic step at 128 × 128 × 64
#: cuboids stayed below the split and ran on one thread).
POINT_ENTRIES = 12
#: Four units of round-off: the floor of the residual and of the bracket's width.
EPS4 = 4.0 * np.finfo(float).eps


class ReturnMappingError(RuntimeError):
    """The local Newton/bisection solve did not converge (never expected for valid laws)."""


@dataclass(frozen=True)
class ReturnResult:
    """Result of :func:`return_map` (arrays over the leading shape of the trial stress).

    Attributes
    ----------
    stress : ndarray, shape (..., 6), or None
        Returned stress [Pa]; None when not asked for (``with_stress``).
    plastic_strain_increment : ndarray, shape (..., 6)
        Deviatoric Δεp, tensor components.
    equivalent_plastic_strain_increment : ndarray, shape (...)
        Δp >= 0.
    plastic : ndarray of bool, shape (...)
        True where the trial state violated the yield condition.
    iterations : int
        Largest number of Newton/bisection updates over the points.
    backstress : ndarray, shape (..., 6), or None
        X_{n+1} [Pa] (X_n where the step is elastic); None for isotropic hardening.
    """

    stress: FloatArray | None
    plastic_strain_increment: FloatArray
    equivalent_plastic_strain_increment: FloatArray
    plastic: NDArray[np.bool_]
    iterations: int
    backstress: FloatArray | None = None


class IsotropicConsistency:
    """r(Δp) = q_tr − 3μΔp − σ_Y(p_n + Δp) at the points still iterating (radial return)."""

    def __init__(self, q: FloatArray, p0: FloatArray, depth: FloatArray | None,
                 law: HardeningLaw, three_mu: float):
        self.q, self.p0, self.depth, self.law, self.three_mu = q, p0, depth, law, three_mu

    def upper_bound(self) -> FloatArray:
        """(q_tr − σ_Y(p_n))/(3μ): Δp is below it as σ_Y is non-decreasing."""
        bound: FloatArray = (self.q - self.law.yield_stress(self.p0, self.depth)) / self.three_mu
        return bound

    def residual(self, x: FloatArray) -> tuple[FloatArray, ...]:
        """Return r, −dr/dΔp, σ_Y and the rounding floor of r at Δp = ``x``."""
        y, h = self.law.yield_and_slope(self.p0 + x, self.depth)
        r = self.q - self.three_mu * x - y
        # rounding floor of r: of q_tr, and of σ_Y(p + Δp) through the rounding of p + Δp (a
        # steep segment of a tabular curve, H ~ 1e14 Pa, makes it the larger one)
        floor = EPS4 * np.maximum(self.q, h * (self.p0 + x))
        return r, self.three_mu + h, y, floor

    def keep(self, mask: NDArray[np.bool_]) -> None:
        """Drop the points that converged (``mask`` False)."""
        self.q, self.p0 = self.q[mask], self.p0[mask]
        self.depth = None if self.depth is None else self.depth[mask]


def decay_and_phi(recall: float, dp: FloatArray) -> tuple[FloatArray, FloatArray]:
    """e^{−γΔp} and φ(Δp) = (1 − e^{−γΔp})/γ (Δp for γ = 0), without cancellation."""
    if recall == 0.0:
        return np.ones_like(dp), dp.copy()
    return np.exp(-recall * dp), -np.expm1(-recall * dp) / recall


class KinematicConsistency(IsotropicConsistency):
    """r(Δp) of the module docstring with the backstress X_n (``s`` the trial deviators)."""

    def __init__(self, s: FloatArray, x0: FloatArray, p0: FloatArray,
                 depth: FloatArray | None, law: HardeningLaw, kinematic: KinematicLaw,
                 three_mu: float):
        super().__init__(deviatoric_equivalent(s), p0, depth, law, three_mu)
        self.s, self.x0 = s, x0
        self.c, self.g = kinematic.modulus, kinematic.recall

    def upper_bound(self) -> FloatArray:
        """(q(s_tr) + q(X_n) − σ_Y(p_n))/(3μ): r <= 0 there."""
        y0 = self.law.yield_stress(self.p0, self.depth)
        bound: FloatArray = (self.q + deviatoric_equivalent(self.x0) - y0) / self.three_mu
        return bound

    def residual(self, x: FloatArray) -> tuple[FloatArray, ...]:
        """Return r, −dr/dΔp, σ_Y and the rounding floor of r at Δp = ``x``."""
        decay, phi = decay_and_phi(self.g, x)
        zeta = self.s - self.x0 * decay[:, None]
        qz = deviatoric_equivalent(zeta)
        y, h = self.law.yield_and_slope(self.p0 + x, self.depth)
        r = qz - self.three_mu * x - self.c * phi - y
        # dζ/dΔp = γ X_n e^{−γΔp}, dφ/dΔp = e^{−γΔp}
        dq = 1.5 * self.g * decay * double_contraction(zeta, self.x0) / qz
        floor = EPS4 * np.maximum(qz, np.abs(h) * (self.p0 + x) + self.c * x)
        return r, self.three_mu + self.c * decay + h - dq, y, floor

    def keep(self, mask: NDArray[np.bool_]) -> None:
        """Drop the points that converged (``mask`` False)."""
        super().keep(mask)
        self.s, self.x0 = self.s[mask], self.x0[mask]


def solve_consistency(equation: IsotropicConsistency, tol: float, max_iter: int
                      ) -> tuple[FloatArray, int]:
    """Δp solving r(Δp) = 0 at every point of ``equation``: safeguarded Newton.

    Starts at the upper bound of the bracket [0, hi] (for a convex r, as with a concave σ_Y,
    one step lands left of the root), keeps the bracket where r changes sign and bisects when a
    Newton step leaves it, until |r| <= max(``tol`` σ_Y, its rounding floor) or the bracket is
    round-off wide; a last free Newton correction is kept if inside the bracket. Converged
    points leave the iteration (``equation.keep``).

    Returns
    -------
    dp : ndarray
        Δp at every point.
    iterations : int
        Newton/bisection updates of the slowest point.

    Raises
    ------
    ReturnMappingError
        When a point has not converged after ``max_iter`` updates.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        return newton_in_bracket(equation, tol, max_iter)


def newton_in_bracket(equation: IsotropicConsistency, tol: float, max_iter: int
                      ) -> tuple[FloatArray, int]:
    """Run the iteration of :func:`solve_consistency` (same arguments and results)."""
    hi = equation.upper_bound()
    result = np.zeros(hi.shape)
    act: NDArray[np.intp] = np.arange(hi.size)  # indices of the points iterating
    lo: FloatArray = np.zeros(hi.size)
    x, iterations = hi, 0
    for it in range(max_iter + 1):
        r, slope, y, floor = equation.residual(x)
        pos = r > 0.0
        lo, hi = np.where(pos, x, lo), np.where(pos, hi, x)
        done = (np.abs(r) <= np.maximum(tol * y, floor)) | (hi - lo <= EPS4 * x)
        if done.any():  # a last free Newton correction, kept if inside the bracket
            xd, xn = x[done], x[done] + r[done] / slope[done]
            result[act[done]] = np.where((xn >= lo[done]) & (xn <= hi[done]), xn, xd)
            keep = ~done
            act = act[keep]
            lo, hi, x, r, slope = (a[keep] for a in (lo, hi, x, r, slope))
            equation.keep(keep)
            if act.size == 0:
                break
        if it == max_iter:
            raise ReturnMappingError(
                f"return mapping: {act.size} points not converged after {max_iter} "
                f"iterations (max residual {np.max(np.abs(r)):.3e} Pa)")
        xn = x + r / slope  # a slope <= 0 (backstress) gives ±inf or nan: bisection
        x = np.where((xn > lo) & (xn < hi), xn, 0.5 * (lo + hi))
        iterations = it + 1
    return result, iterations


def return_map(trial_stress: ArrayLike, equivalent_plastic_strain: ArrayLike,
               law: HardeningLaw, mu: float, depth: ArrayLike | None = None, *,
               kinematic: KinematicLaw | None = None, backstress: ArrayLike | None = None,
               tol: float = TOLERANCE, max_iter: int = MAX_ITERATIONS,
               with_stress: bool = True) -> ReturnResult:
    """Backward-Euler return mapping of von Mises plasticity (module docstring).

    Parameters
    ----------
    trial_stress : ndarray, shape (..., 6)
        Trial stress [Pa], finite.
    equivalent_plastic_strain : array_like, broadcastable to (...)
        Accumulated equivalent plastic strain p_n >= 0 before the increment.
    law : HardeningLaw
        Isotropic part σ_Y(p).
    mu : float
        Shear modulus [Pa].
    depth : array_like, optional
        Depth x3 [m] broadcastable to (...); required by depth-scaled laws.
    kinematic : KinematicLaw, optional
        C and γ of the backstress; None: isotropic hardening (radial return, no backstress).
    backstress : array_like, broadcastable to (..., 6), optional
        Backstress X_n [Pa], deviatoric (with ``kinematic``; zero when not given).
    tol : float
        Relative tolerance on the consistency residual.
    max_iter : int
        Maximum Newton/bisection updates; :class:`ReturnMappingError` beyond.
    with_stress : bool
        Assemble the returned stress. The plastic fixed point needs only the increments:
        without it, a box-size array less per sweep.

    Returns
    -------
    ReturnResult
    """
    if not mu > 0:
        raise ValueError(f"shear modulus mu must be > 0, got {mu}")
    sig = np.asarray(trial_stress, dtype=float)
    if sig.ndim < 1 or sig.shape[-1] != 6:
        raise ValueError(f"trial_stress must have a last axis of size 6, got shape {sig.shape}")
    lead = sig.shape[:-1]
    p_old = np.broadcast_to(np.asarray(equivalent_plastic_strain, dtype=float),
                            lead).reshape(-1)
    if np.any(p_old < 0.0):
        raise ValueError("equivalent_plastic_strain must be >= 0")
    d_all = None if depth is None else np.broadcast_to(np.asarray(depth, float), lead).reshape(-1)
    sig2 = np.ascontiguousarray(sig.reshape(-1, 6))
    if kinematic is None:
        return isotropic_return(sig2, lead, p_old, d_all, law, mu, tol, max_iter, with_stress)
    x_old = np.zeros(sig2.shape) if backstress is None else np.broadcast_to(
        np.asarray(backstress, float), sig.shape).reshape(-1, 6)
    return return_with_backstress(sig2, lead, p_old, d_all, x_old, law, kinematic, mu, tol,
                                  max_iter, with_stress)


def isotropic_return(sig2: FloatArray, lead: tuple[int, ...], p_old: FloatArray,
                     d_all: FloatArray | None, law: HardeningLaw, mu: float, tol: float,
                     max_iter: int, with_stress: bool) -> ReturnResult:
    """Radial return of the (n, 6) trial stresses ``sig2`` (the fast path of :func:`return_map`).

    Δεp = 3/2 Δp s/q_tr; the stress is mean(σ_tr) I + s σ_Y(p + Δp)/q_tr, so that
    von_mises(σ) = σ_Y(p + Δp) to round-off. Only the plastic points change (a small part of a
    large cuboid box): they are gathered, solved and written back.
    """
    shape = lead + (6,)
    q_tr = equivalent_stress(sig2)  # one pass over the box, no full-size deviator
    plastic = (q_tr > law.yield_stress(p_old, d_all)).reshape(lead)
    idx = np.flatnonzero(plastic)
    if idx.size == 0:
        return ReturnResult(sig2.reshape(shape).copy() if with_stress else None,
                            np.zeros(shape), np.zeros(lead), plastic, 0)
    # numba, pyfftw's thread count and the pool: plastic points only (a material point's
    # return, in the comparison stages, imports none of them)
    from sacflow.kernels.fft import default_threads
    from sacflow.machine.threads import over_ranges
    from sacflow.mechanics.radial_kernels import returned_into, scaled_deviators_into

    q_pl = q_tr[idx]
    d_pl = None if d_all is None else d_all[idx]
    dp, iterations = radial_increments(q_pl, p_old[idx], d_pl, law, 3.0 * mu, tol, max_iter)
    dp_all = np.zeros(q_tr.shape)
    dp_all[idx] = dp
    dep = np.zeros(sig2.shape)
    threads = default_threads()
    over_ranges(scaled_deviators_into, idx.size, threads, sig2, idx, 1.5 * dp / q_pl,
                dep, weight=POINT_ENTRIES)  # Δεp = 3/2 Δp s/q_tr
    stress = None
    if with_stress:
        ratio = law.yield_stress(p_old[idx] + dp, d_pl) / q_pl  # s_new = s σ_Y(p + Δp)/q_tr
        stress = sig2.copy()
        over_ranges(returned_into, idx.size, threads, sig2, idx, ratio, stress,
                    weight=POINT_ENTRIES)
        stress = stress.reshape(shape)
    return ReturnResult(stress, dep.reshape(shape), dp_all.reshape(lead), plastic, iterations)


def radial_increments(q: FloatArray, p0: FloatArray, depth: FloatArray | None,
                      law: HardeningLaw, three_mu: float, tol: float = TOLERANCE,
                      max_iter: int = MAX_ITERATIONS) -> tuple[FloatArray, int]:
    """Δp of the radial return at plastic points (q > σ_Y(p₀)): r = q − 3μΔp − σ_Y(p₀ + Δp).

    Linear hardening (and perfect plasticity) has the closed form Δp = (q − σ_Y(p₀))/(3μ + H),
    which the Newton iteration of :func:`solve_consistency` reaches in its first update; any
    other law is solved by :func:`solve_consistency` on arrays (vectorised: for the Swift law's
    power, faster than a compiled point-by-point iteration).

    Returns
    -------
    dp : ndarray
        Δp at each point.
    iterations : int
        Newton/bisection updates of the slowest point (1 for the closed form).

    Raises
    ------
    ReturnMappingError
        When a point has not converged after ``max_iter`` updates.
    """
    kind = type(law)
    if kind is LinearHardening or kind is PerfectPlasticity:
        assert isinstance(law, LinearHardening)
        dp: FloatArray = (q - law.yield_stress(p0)) / (three_mu + law.modulus)
        return dp, 1
    return solve_consistency(IsotropicConsistency(q, p0, depth, law, three_mu), tol, max_iter)


def return_with_backstress(sig2: FloatArray, lead: tuple[int, ...], p_old: FloatArray,
                           d_all: FloatArray | None, x_old: FloatArray, law: HardeningLaw,
                           kinematic: KinematicLaw, mu: float, tol: float, max_iter: int,
                           with_stress: bool) -> ReturnResult:
    """Return mapping with the backstress ``x_old`` (n, 6) (module docstring's equations)."""
    shape = lead + (6,)
    q_rel = equivalent_stress(np.ascontiguousarray(sig2 - x_old))  # X deviatoric: q(s − X)
    plastic = q_rel > law.yield_stress(p_old, d_all)
    idx = np.flatnonzero(plastic)
    out_x = x_old.copy()
    dep = np.zeros(sig2.shape)
    dp_all = np.zeros(p_old.shape)
    stress = sig2.copy() if with_stress else None
    iterations = 0
    if idx.size:
        c, g = kinematic.modulus, kinematic.recall
        s, x0, p0 = deviator(sig2[idx]), x_old[idx], p_old[idx]
        d = None if d_all is None else d_all[idx]
        equation = KinematicConsistency(s, x0, p0, d, law, kinematic, 3.0 * mu)
        dp, iterations = solve_consistency(equation, tol, max_iter)
        decay, phi = decay_and_phi(g, dp)
        zeta = s - x0 * decay[:, None]
        q_zeta = deviatoric_equivalent(zeta)
        direction = 1.5 * zeta / q_zeta[:, None]  # n: sqrt(2/3 n:n) = 1
        x_new = x0 * decay[:, None] + (2.0 / 3.0) * c * phi[:, None] * direction
        out_x[idx], dp_all[idx] = x_new, dp
        dep[idx] = direction * dp[:, None]
        if stress is not None:
            y_new = law.yield_stress(p0 + dp, d)
            new = x_new + zeta * (y_new / q_zeta)[:, None]
            new[:, :3] += ((sig2[idx, 0] + sig2[idx, 1] + sig2[idx, 2]) / 3.0)[:, None]
            stress[idx] = new
    return ReturnResult(None if stress is None else stress.reshape(shape), dep.reshape(shape),
                        dp_all.reshape(lead), plastic.reshape(lead), iterations,
                        out_x.reshape(shape))
