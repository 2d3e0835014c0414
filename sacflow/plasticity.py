"""Von Mises plasticity with isotropic hardening: hardening laws and the radial return.

Conventions
-----------
* SI units; stress positive in tension; float64.
* Stress and strain arrays carry the tensor components (11, 22, 33, 12, 13, 23) on a last axis
  of size 6, with *tensor* shear strains (ε12, not γ12). In double contractions the shear
  components therefore count twice: ``a:b = a11 b11 + a22 b22 + a33 b33 + 2 (a12 b12 + ...)``.
* ``eqps`` is the accumulated equivalent plastic strain p = ∫ sqrt(2/3 dεp:dεp), a plain
  (dimensionless) strain. The seed's Swift parameters use p in micro-strain; :class:`Swift`
  converts (``strain_unit``).
* ``depth`` (x3 [m], positive into the body) must broadcast against ``eqps``; only
  :class:`DepthScaled` uses it.

Model: Prandtl–Reuss flow, von Mises yield f = q − σ_Y(p), isotropic hardening (Jacq et al.,
ASME J. Tribol. 124 (2002) 653, eqs. (3.1)–(3.2), doi:10.1115/1.1467920), integrated by the fully
implicit (backward Euler) radial return of Simo & Hughes, *Computational Inelasticity*, Springer
1998, §3.3 (Box 3.1), doi:10.1007/b98904.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from sacflow.reference import von_mises  # one implementation, re-exported here

__all__ = ["DepthScaled", "Elastic", "HardeningLaw", "Linear", "PerfectlyPlastic",
           "ReturnMappingError", "ReturnResult", "ReturnTangent", "Swift", "Tabular", "deviator",
           "double_contraction", "equivalent_strain", "hardening_from_schema", "radial_return",
           "von_mises"]

_SHEAR_WEIGHT = np.array([1.0, 1.0, 1.0, 2.0, 2.0, 2.0])


def double_contraction(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Return ``a:b`` of two (..., 6) symmetric tensors, shear components counted twice."""
    return np.einsum("...i,...i,i->...", np.asarray(a, float), np.asarray(b, float), _SHEAR_WEIGHT)


def deviator(stress: np.ndarray) -> np.ndarray:
    """Return the deviatoric part ``s = σ − tr(σ)/3 I`` of (..., 6) tensors."""
    s = np.array(stress, dtype=float)
    s[..., :3] -= ((s[..., 0] + s[..., 1] + s[..., 2]) / 3.0)[..., None]
    return s


def equivalent_strain(strain6: np.ndarray) -> np.ndarray:
    """Return sqrt(2/3 e:e) with e the deviator of (..., 6) tensor strains (= p for εp)."""
    e = deviator(strain6)
    return np.sqrt(2.0 / 3.0 * double_contraction(e, e))


class HardeningLaw(ABC):
    """Isotropic hardening law σ_Y(p) (seed eq. (3.1)); σ_Y must be positive and nondecreasing."""

    @abstractmethod
    def yield_stress(self, eqps, depth=None) -> np.ndarray:
        """Return σ_Y(p) [Pa] for equivalent plastic strain ``eqps`` (dimensionless)."""

    @abstractmethod
    def slope(self, eqps, depth=None) -> np.ndarray:
        """Return dσ_Y/dp [Pa] (right derivative at kinks)."""

    def yield_and_slope(self, eqps, depth=None) -> tuple[np.ndarray, np.ndarray]:
        """Return ``(yield_stress, slope)``; laws override it to share work."""
        return self.yield_stress(eqps, depth), self.slope(eqps, depth)


class _Joint(HardeningLaw):
    """A law whose ``yield_and_slope`` is primary."""

    def yield_stress(self, eqps, depth=None):
        return self.yield_and_slope(eqps, depth)[0]

    def slope(self, eqps, depth=None):
        return self.yield_and_slope(eqps, depth)[1]


class Swift(_Joint):
    """Swift law σ_Y = B (C + s p)^n, s = 1e6 for ``strain_unit="microstrain"`` (seed eq. (3.1)).

    The seed's bearing steel (B = 1240 MPa, C = 30, n = 0.085, micro-strain) has
    σ_Y0 = B C^n ≈ 1655.7 MPa. C = 0 (σ_Y0 = 0, infinite initial slope) is rejected.
    """

    def __init__(self, B: float, C: float, n: float, strain_unit: str = "microstrain"):
        scales = {"microstrain": 1e6, "strain": 1.0}
        if strain_unit not in scales:
            raise ValueError(f"Swift strain_unit must be one of {sorted(scales)}, "
                             f"got {strain_unit!r}")
        if not (B > 0 and C > 0 and n >= 0):
            raise ValueError(f"Swift needs B > 0, C > 0, n >= 0; got B={B}, C={C}, n={n}")
        self.B, self.C, self.n, self.scale = float(B), float(C), float(n), scales[strain_unit]

    def yield_stress(self, eqps, depth=None):
        return self.B * (self.C + self.scale * np.asarray(eqps, dtype=float)) ** self.n

    def yield_and_slope(self, eqps, depth=None):
        base = self.C + self.scale * np.asarray(eqps, dtype=float)
        y = self.B * base**self.n
        return y, (self.n * self.scale) * y / base


class Linear(HardeningLaw):
    """Linear hardening σ_Y = σ_Y0 + H p, H >= 0."""

    def __init__(self, yield_stress: float, modulus: float):
        if not (yield_stress > 0 and modulus >= 0):
            raise ValueError(f"Linear needs yield_stress > 0 and modulus >= 0; got "
                             f"{yield_stress}, {modulus}")
        self.sigma0, self.modulus = float(yield_stress), float(modulus)

    def yield_stress(self, eqps, depth=None):
        return self.sigma0 + self.modulus * np.asarray(eqps, dtype=float)

    def slope(self, eqps, depth=None):
        return np.full(np.shape(eqps), self.modulus)


class PerfectlyPlastic(Linear):
    """Perfect plasticity σ_Y = σ_Y0."""

    def __init__(self, yield_stress: float):
        super().__init__(yield_stress, 0.0)


class Elastic(HardeningLaw):
    """No plasticity: σ_Y = +inf, slope 0."""

    def yield_stress(self, eqps, depth=None):
        return np.full(np.shape(eqps), np.inf)

    def slope(self, eqps, depth=None):
        return np.zeros(np.shape(eqps))


class Tabular(_Joint):
    """Piecewise-linear measured curve through (``plastic_strain``, ``stress``) points.

    ``plastic_strain`` starts at 0 and increases strictly; ``stress`` is positive and
    nondecreasing. Beyond the last point the curve continues with the last segment's slope
    (``extrapolation="linear"``, default) or stays flat (``"flat"``). At kinks ``slope`` returns
    the slope of the segment on the right.
    """

    def __init__(self, plastic_strain, stress, extrapolation: str = "linear"):
        e, s = np.asarray(plastic_strain, dtype=float), np.asarray(stress, dtype=float)
        if e.ndim != 1 or e.shape != s.shape or e.size < 2:
            raise ValueError("Tabular plastic_strain and stress must be 1-D of equal length >= 2")
        if e[0] != 0.0 or np.any(np.diff(e) <= 0):
            raise ValueError("Tabular plastic_strain must start at 0 and increase strictly")
        if s[0] <= 0 or np.any(np.diff(s) < 0):
            raise ValueError("Tabular stress must be positive and nondecreasing (no softening)")
        if extrapolation not in ("linear", "flat"):
            raise ValueError("Tabular extrapolation must be 'linear' or 'flat', "
                             f"got {extrapolation!r}")
        self.strain, self.stress, self.extrapolation = e, s, extrapolation
        self.slopes = np.diff(s) / np.diff(e)

    def yield_and_slope(self, eqps, depth=None):
        p = np.asarray(eqps, dtype=float)
        if self.extrapolation == "flat":
            beyond = p >= self.strain[-1]
            p = np.minimum(p, self.strain[-1])
        i = np.clip(np.searchsorted(self.strain, p, side="right") - 1, 0, self.slopes.size - 1)
        k = self.slopes[i]
        y = self.stress[i] + k * (p - self.strain[i])
        if self.extrapolation == "flat":
            k = np.where(beyond, 0.0, k)
        return y, k


class DepthScaled(_Joint):
    """σ_Y(p, x3) = factor(x3) · law(p): factor piecewise linear in depth, constant beyond ends.

    For surface-hardened steels (the seed's stated next step); ``depth`` is then required.
    """

    def __init__(self, law: HardeningLaw, depth, factor):
        d, f = np.asarray(depth, dtype=float), np.asarray(factor, dtype=float)
        if d.ndim != 1 or d.shape != f.shape or d.size < 1:
            raise ValueError("depth_profile depth and factor must be 1-D of equal length >= 1")
        if np.any(np.diff(d) <= 0) or np.any(f <= 0):
            raise ValueError("depth_profile depth must increase strictly and factor be > 0")
        self.law, self.depth, self.factor = law, d, f

    def scale(self, depth) -> np.ndarray:
        """Return the factor at ``depth`` [m]."""
        if depth is None:
            raise ValueError("DepthScaled hardening needs the depth x3 of every point")
        return np.interp(np.asarray(depth, dtype=float), self.depth, self.factor)

    def yield_and_slope(self, eqps, depth=None):
        y, h = self.law.yield_and_slope(eqps, depth)
        f = self.scale(depth)
        return f * y, f * h


def _field(obj, name, default=None):
    return obj.get(name, default) if isinstance(obj, dict) else getattr(obj, name, default)


def hardening_from_schema(obj) -> HardeningLaw:
    """Build a law from any object (pydantic model, SimpleNamespace, dict) with a ``law`` field.

    ``law`` in {"elastic", "swift", "linear", "perfectly_plastic", "tabular"} with the fields
    B, C, n, strain_unit / yield_stress, modulus / yield_stress / plastic_strain, stress; an
    optional ``depth_profile`` (``depth``, ``factor``) wraps the law in :class:`DepthScaled`.
    """
    kind = _field(obj, "law")

    def req(name):
        if (value := _field(obj, name)) is None:
            raise ValueError(f"hardening law {kind!r} needs the field {name!r}")
        return value

    builders = {
        "elastic": Elastic,
        "swift": lambda: Swift(req("B"), req("C"), req("n"),
                               _field(obj, "strain_unit") or "microstrain"),
        "linear": lambda: Linear(req("yield_stress"), req("modulus")),
        "perfectly_plastic": lambda: PerfectlyPlastic(req("yield_stress")),
        "tabular": lambda: Tabular(req("plastic_strain"), req("stress")),
    }
    if kind not in builders:
        raise ValueError(f"hardening law must be one of {list(builders)}, got {kind!r}")
    law = builders[kind]()
    profile = _field(obj, "depth_profile")
    if profile is not None and kind != "elastic":
        law = DepthScaled(law, _field(profile, "depth"), _field(profile, "factor"))
    return law


class ReturnMappingError(RuntimeError):
    """The local Newton/bisection solve did not converge (never expected for valid laws)."""


@dataclass(frozen=True)
class ReturnResult:
    """Result of :func:`radial_return` (arrays over the leading shape of the trial stress).

    Attributes
    ----------
    stress : ndarray, shape (..., 6)
        Returned stress σ = σ_tr − 2μ Δεp [Pa].
    plastic_strain_increment : ndarray, shape (..., 6)
        Deviatoric Δεp, tensor components.
    eqps_increment : ndarray, shape (...)
        Δp >= 0.
    plastic : ndarray of bool, shape (...)
        True where the trial state violated the yield condition.
    iterations : int
        Maximum number of Newton/bisection updates over all points.
    """

    stress: np.ndarray
    plastic_strain_increment: np.ndarray
    eqps_increment: np.ndarray
    plastic: np.ndarray
    iterations: int


def radial_return(trial_stress, eqps, law: HardeningLaw, mu: float, depth=None,
                  tol: float = 1e-12, max_iter: int = 50) -> ReturnResult:
    """Fully implicit radial return for von Mises plasticity with isotropic hardening.

    Backward-Euler integration of the Prandtl–Reuss flow of seed eq. (3.2) (Simo & Hughes 1998,
    §3.3, Box 3.1). Points with q_tr = sqrt(3/2 s:s) > σ_Y(p) solve
    ``q_tr − 3μ Δp − σ_Y(p + Δp) = 0`` by vectorised Newton kept inside the bracket
    ``0 < Δp <= (q_tr − σ_Y(p))/(3μ)`` (bisection when a step leaves it) until the residual is
    below ``tol`` σ_Y (or its rounding floor 4ε q_tr), then ``Δεp = 3/2 Δp s/q_tr``. The stress
    σ = σ_tr − 2μ Δεp is assembled as mean(σ_tr) I + s σ_Y(p + Δp)/q_tr, so that
    von_mises(σ) = σ_Y(p + Δp) to round-off. Elastic points are returned bit for bit.

    Parameters
    ----------
    trial_stress : ndarray, shape (..., 6)
        Trial stress [Pa], finite.
    eqps : array_like, broadcastable to (...)
        Accumulated equivalent plastic strain p >= 0 before the increment.
    law : HardeningLaw
        Isotropic hardening law σ_Y(p).
    mu : float
        Shear modulus [Pa].
    depth : array_like, optional
        Depth x3 [m] broadcastable to (...); required by :class:`DepthScaled`.
    tol : float
        Relative tolerance on the consistency residual.
    max_iter : int
        Maximum Newton/bisection updates; :class:`ReturnMappingError` beyond.

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
    p_old = np.broadcast_to(np.asarray(eqps, dtype=float), lead).reshape(-1)
    if np.any(p_old < 0.0):
        raise ValueError("eqps (accumulated equivalent plastic strain) must be >= 0")
    d_all = None if depth is None else np.broadcast_to(np.asarray(depth, float), lead).reshape(-1)
    sig2 = sig.reshape(-1, 6)
    s = deviator(sig2)
    q_tr = np.sqrt(1.5 * double_contraction(s, s))
    plastic = (q_tr > law.yield_stress(p_old, d_all)).reshape(lead)
    idx = np.flatnonzero(plastic)
    if idx.size == 0:
        return ReturnResult(sig.copy(), np.zeros(sig.shape), np.zeros(lead), plastic, 0)
    dp_all = np.zeros(q_tr.shape)
    act, q, p0 = idx, q_tr[idx], p_old[idx]  # act: global indices of the points iterating
    q_pl = q
    d = d_pl = None if d_all is None else d_all[idx]
    three_mu, eps4, iterations = 3.0 * mu, 4.0 * np.finfo(float).eps, 0
    lo = np.zeros(act.size)
    x = hi = (q - law.yield_stress(p0, d)) / three_mu  # Δp <= hi as σ_Y is nondecreasing
    for it in range(max_iter + 1):  # starting at hi, one step lands left of the root
        y, h = law.yield_and_slope(p0 + x, d)
        r = q - three_mu * x - y
        pos = r > 0.0
        lo, hi = np.where(pos, x, lo), np.where(pos, hi, x)
        done = (np.abs(r) <= np.maximum(tol * y, eps4 * q)) | (hi - lo <= eps4 * x)
        if done.any():  # a last free Newton correction, kept if inside the bracket
            xd, xn = x[done], x[done] + r[done] / (three_mu + h[done])
            dp_all[act[done]] = np.where((xn >= lo[done]) & (xn <= hi[done]), xn, xd)
            keep = ~done
            act, q, p0, lo, hi, x, r, h = (a[keep] for a in (act, q, p0, lo, hi, x, r, h))
            d = None if d is None else d[keep]
            if act.size == 0:
                break
        if it == max_iter:
            raise ReturnMappingError(
                f"radial return: {act.size} points not converged after {max_iter} "
                f"iterations (max residual {np.max(np.abs(r)):.3e} Pa)")
        xn = x + r / (three_mu + h)
        x = np.where((xn > lo) & (xn < hi), xn, 0.5 * (lo + hi))
        iterations = it + 1
    dp = dp_all[idx]
    ratio = np.ones(q_tr.shape)  # s_new = s σ_Y(p + Δp)/q_tr: consistency to round-off
    ratio[idx] = law.yield_stress(p_old[idx] + dp, d_pl) / q_pl
    factor = np.zeros(q_tr.shape)
    factor[idx] = 1.5 * dp / q_pl
    dep = s * factor[:, None]
    new = s * ratio[:, None]
    new[:, :3] += ((sig2[:, 0] + sig2[:, 1] + sig2[:, 2]) / 3.0)[:, None]
    stress = np.where(plastic.reshape(-1, 1), new, sig2)
    return ReturnResult(stress.reshape(sig.shape), dep.reshape(sig.shape), dp_all.reshape(lead),
                        plastic, iterations)


class ReturnTangent:
    """Derivative of the radial-return plastic strain increment with respect to the trial stress.

    For a plastic point with flow direction N = 3/2 s_tr/q_tr, Δp and slope H = σ_Y'(p + Δp),
    differentiating Δεp = Δp N with q_tr − 3μΔp − σ_Y(p + Δp) = 0 gives (Simo & Hughes 1998,
    §3.3.2, the algorithmic tangent)

        dΔεp = N (N:dσ) / (3μ + H) + (Δp / q_tr) (3/2 dσ_dev − N (N:dσ)),

    and zero at elastic points. Used by the solver's Newton–Krylov iteration.
    """

    def __init__(self, trial_stress, result: ReturnResult, eqps, law: HardeningLaw, mu: float,
                 depth=None):
        plastic = result.plastic
        self.index = np.flatnonzero(plastic.reshape(-1))
        lead = plastic.shape
        trial = np.asarray(trial_stress, float).reshape(-1, 6)[self.index]
        s = deviator(trial)
        q = np.sqrt(1.5 * double_contraction(s, s))
        dp = result.eqps_increment.reshape(-1)[self.index]
        p = np.broadcast_to(np.asarray(eqps, float), lead).reshape(-1)[self.index]
        d = None if depth is None else np.broadcast_to(
            np.asarray(depth, float), lead).reshape(-1)[self.index]
        slope = law.slope(p + dp, d)
        self.N = 1.5 * s / q[:, None]
        self.a = 1.0 / (3.0 * mu + slope)
        self.b = dp / q
        self.shape = plastic.shape + (6,)

    def apply(self, dsigma: np.ndarray) -> np.ndarray:
        """Return dΔεp (shape of the trial stress) for a stress perturbation ``dsigma``."""
        out = np.zeros(self.shape).reshape(-1, 6)
        if self.index.size:
            ds = np.asarray(dsigma, float).reshape(-1, 6)[self.index]
            nd = double_contraction(self.N, ds)
            out[self.index] = (self.N * ((self.a - self.b) * nd)[:, None]
                               + 1.5 * self.b[:, None] * deviator(ds))
        return out.reshape(self.shape)
