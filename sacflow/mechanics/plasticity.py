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
from typing import Any

import numpy as np
from pydantic import BaseModel, ValidationError

from sacflow.config import schema
from sacflow.mechanics.hertz import von_mises  # one implementation, re-exported here

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


#: Scale s of εp in the Swift law σ_Y = B (C + s εp)^n, per ``strain_unit``.
STRAIN_SCALES = {"microstrain": 1e6, "strain": 1.0}


def _validated(model: type[BaseModel], fields: dict[str, Any]) -> Any:
    """``fields`` validated by the schema ``model``: the one place of a law's rules.

    Raises
    ------
    ValueError
        Naming the law, each offending field, what is wrong and the value found.
    """
    try:
        return model.model_validate(fields)
    except ValidationError as exc:
        what = f"hardening law {fields['law']!r}" if "law" in fields else model.__name__
        problems = []
        for err in exc.errors(include_url=False):
            loc = [str(k) for k in err["loc"]]
            value = err.get("input")
            if err["type"] == schema.FIELD_ERROR:
                loc.append(err["ctx"]["field"])
                value = fields.get(loc[-1])
            got = "" if err["type"] == "missing" else f"; got {value!r:.60}"
            problems.append(f"field {'.'.join(loc)!r}: {err['msg']}{got}")
        raise ValueError(f"{what}: " + "; ".join(problems)) from None


def _floats(values) -> Any:
    """Array-likes as (nested) lists for validation; anything else as it is."""
    try:
        return np.asarray(values, dtype=float).tolist()
    except (TypeError, ValueError):
        return values


class Swift(_Joint):
    """Swift law σ_Y = B (C + s p)^n, s = 1e6 for ``strain_unit="microstrain"`` (seed eq. (3.1)).

    The seed's bearing steel (B = 1240 MPa, C = 30, n = 0.085, micro-strain) has
    σ_Y0 = B C^n ≈ 1655.7 MPa. The arguments obey :class:`sacflow.config.schema.Swift` (C > 0,
    0 < n < 1, B C^n a finite positive stress); a ``ValueError`` names the field otherwise.
    """

    def __init__(self, B: float, C: float, n: float, strain_unit: str = "microstrain"):
        law = _validated(schema.Swift, dict(law="swift", B=B, C=C, n=n, strain_unit=strain_unit))
        self.B, self.C, self.n = law.B, law.C, law.n
        self.scale = STRAIN_SCALES[law.strain_unit]

    def yield_stress(self, eqps, depth=None):
        """Return B (C + s p)^n."""
        return self.B * (self.C + self.scale * np.asarray(eqps, dtype=float)) ** self.n

    def yield_and_slope(self, eqps, depth=None):
        """Return σ_Y and its slope n s σ_Y / (C + s p) in one pass."""
        base = self.C + self.scale * np.asarray(eqps, dtype=float)
        y = self.B * base**self.n
        return y, (self.n * self.scale) * y / base


class Linear(HardeningLaw):
    """Linear hardening σ_Y = σ_Y0 + H p (:class:`sacflow.config.schema.Linear`: H >= 0)."""

    def __init__(self, yield_stress: float, modulus: float):
        law = _validated(schema.Linear,
                         dict(law="linear", yield_stress=yield_stress, modulus=modulus))
        self.sigma0, self.modulus = law.yield_stress, law.modulus

    def yield_stress(self, eqps, depth=None):
        """Return σ_Y0 + H p."""
        return self.sigma0 + self.modulus * np.asarray(eqps, dtype=float)

    def slope(self, eqps, depth=None):
        """Return H everywhere."""
        return np.full(np.shape(eqps), self.modulus)


class PerfectlyPlastic(Linear):
    """Perfect plasticity σ_Y = σ_Y0 (rules of :class:`sacflow.config.schema.PerfectlyPlastic`)."""

    def __init__(self, yield_stress: float):
        law = _validated(schema.PerfectlyPlastic,
                         dict(law="perfectly_plastic", yield_stress=yield_stress))
        self.sigma0, self.modulus = law.yield_stress, 0.0


class Elastic(HardeningLaw):
    """No plasticity: σ_Y = +inf, slope 0."""

    def yield_stress(self, eqps, depth=None):
        """Return +inf everywhere (never yields)."""
        return np.full(np.shape(eqps), np.inf)

    def slope(self, eqps, depth=None):
        """Return 0 everywhere."""
        return np.zeros(np.shape(eqps))


class Tabular(_Joint):
    """Piecewise-linear measured curve through (``plastic_strain``, ``stress``) points.

    The points obey :class:`sacflow.config.schema.Tabular` (strains from 0, strictly increasing;
    stresses positive and non-decreasing). Beyond the last point the curve stays at the last
    stress with slope 0 (``beyond_last="constant"``, default) or continues with the last
    segment's slope (``"extrapolate"``); the radial return's hardening modulus follows. At kinks
    ``slope`` returns the slope of the segment on the right.
    """

    def __init__(self, plastic_strain, stress, beyond_last: str = "constant"):
        law = _validated(schema.Tabular, dict(law="tabular", plastic_strain=_floats(plastic_strain),
                                              stress=_floats(stress), beyond_last=beyond_last))
        self.strain = np.array(law.plastic_strain)
        self.stress = np.array(law.stress)
        self.beyond_last = law.beyond_last
        self.slopes = np.diff(self.stress) / np.diff(self.strain)

    def yield_and_slope(self, eqps, depth=None):
        """Return the interpolated stress and the slope of the segment on the right."""
        p = np.asarray(eqps, dtype=float)
        constant = self.beyond_last == "constant"
        if constant:
            beyond = p >= self.strain[-1]
            p = np.minimum(p, self.strain[-1])
        i = np.clip(np.searchsorted(self.strain, p, side="right") - 1, 0, self.slopes.size - 1)
        k = self.slopes[i]
        y = self.stress[i] + k * (p - self.strain[i])
        if constant:
            k = np.where(beyond, 0.0, k)
        return y, k


class DepthScaled(_Joint):
    """σ_Y(p, x3) = factor(x3) · law(p): factor piecewise linear in depth, constant beyond ends.

    For surface-hardened steels (the seed's stated next step); ``depth`` is then required.
    ``depth`` and ``factor`` obey :class:`sacflow.config.schema.DepthProfile`.
    """

    def __init__(self, law: HardeningLaw, depth, factor):
        profile = _validated(schema.DepthProfile, dict(depth=_floats(depth),
                                                       factor=_floats(factor)))
        self.law, self.depth, self.factor = law, np.array(profile.depth), np.array(profile.factor)

    def scale(self, depth) -> np.ndarray:
        """Return the factor at ``depth`` [m]."""
        if depth is None:
            raise ValueError("DepthScaled hardening needs the depth x3 of every point")
        return np.interp(np.asarray(depth, dtype=float), self.depth, self.factor)

    def yield_and_slope(self, eqps, depth=None):
        """Return factor(x3) times the law's yield stress and slope."""
        y, h = self.law.yield_and_slope(eqps, depth)
        f = self.scale(depth)
        return f * y, f * h


def _field(obj, name, default=None):
    return obj.get(name, default) if isinstance(obj, dict) else getattr(obj, name, default)


#: Schema model of each ``law``.
_SCHEMA_LAWS: dict[str, type[BaseModel]] = {
    "elastic": schema.Elastic,
    "swift": schema.Swift,
    "linear": schema.Linear,
    "perfectly_plastic": schema.PerfectlyPlastic,
    "tabular": schema.Tabular,
}


def _schema_law(obj) -> Any:
    """``obj`` as a validated schema hardening model (it may be one already)."""
    if isinstance(obj, tuple(_SCHEMA_LAWS.values())):
        return obj
    kind = _field(obj, "law")
    if kind not in _SCHEMA_LAWS:
        raise ValueError(f"hardening law must be one of {list(_SCHEMA_LAWS)}, got {kind!r}")
    model = _SCHEMA_LAWS[kind]
    data = {name: _field(obj, name) for name in model.model_fields}
    data = {name: value for name, value in data.items() if value is not None}
    if "depth_profile" in data and not isinstance(data["depth_profile"], BaseModel):
        profile = data["depth_profile"]
        data["depth_profile"] = {k: _floats(_field(profile, k)) for k in ("depth", "factor")}
    for name in ("plastic_strain", "stress"):
        if name in data:
            data[name] = _floats(data[name])
    return _validated(model, data)


def hardening_from_schema(obj) -> HardeningLaw:
    """Build a law from a schema model or any object (SimpleNamespace, dict) with a ``law`` field.

    ``law`` in {"elastic", "swift", "linear", "perfectly_plastic", "tabular"} with the fields
    of :mod:`sacflow.config.schema`'s model of that law (B, C, n, strain_unit / yield_stress,
    modulus
    / yield_stress / plastic_strain, stress, beyond_last); an optional ``depth_profile``
    (``depth``, ``factor``) wraps the law in :class:`DepthScaled`. Anything but a schema model
    is validated by that model first: the schema is the one source of the laws' rules, and
    what it accepts builds here and runs in :func:`radial_return`.

    Raises
    ------
    ValueError
        Naming the law and the offending field.
    """
    law = _schema_law(obj)
    builders = {
        "elastic": Elastic,
        "swift": lambda: Swift(law.B, law.C, law.n, law.strain_unit),
        "linear": lambda: Linear(law.yield_stress, law.modulus),
        "perfectly_plastic": lambda: PerfectlyPlastic(law.yield_stress),
        "tabular": lambda: Tabular(law.plastic_strain, law.stress, law.beyond_last),
    }
    built = builders[law.law]()
    profile = getattr(law, "depth_profile", None)
    if profile is not None:
        built = DepthScaled(built, profile.depth, profile.factor)
    return built


class ReturnMappingError(RuntimeError):
    """The local Newton/bisection solve did not converge (never expected for valid laws)."""


@dataclass(frozen=True)
class ReturnResult:
    """Result of :func:`radial_return` (arrays over the leading shape of the trial stress).

    Attributes
    ----------
    stress : ndarray, shape (..., 6), or None
        Returned stress σ = σ_tr − 2μ Δεp [Pa]; None when not asked for (``with_stress``).
    plastic_strain_increment : ndarray, shape (..., 6)
        Deviatoric Δεp, tensor components.
    eqps_increment : ndarray, shape (...)
        Δp >= 0.
    plastic : ndarray of bool, shape (...)
        True where the trial state violated the yield condition.
    iterations : int
        Maximum number of Newton/bisection updates over all points.
    """

    stress: np.ndarray | None
    plastic_strain_increment: np.ndarray
    eqps_increment: np.ndarray
    plastic: np.ndarray
    iterations: int


def radial_return(trial_stress, eqps, law: HardeningLaw, mu: float, depth=None,
                  tol: float = 1e-12, max_iter: int = 50, with_stress: bool = True
                  ) -> ReturnResult:
    """Fully implicit radial return for von Mises plasticity with isotropic hardening.

    Backward-Euler integration of the Prandtl–Reuss flow of seed eq. (3.2) (Simo & Hughes 1998,
    §3.3, Box 3.1). Points with q_tr = sqrt(3/2 s:s) > σ_Y(p) solve
    ``q_tr − 3μ Δp − σ_Y(p + Δp) = 0`` by vectorised Newton kept inside the bracket
    ``0 < Δp <= (q_tr − σ_Y(p))/(3μ)`` (bisection when a step leaves it) until the residual is
    below ``tol`` σ_Y (or its rounding floor 4ε max(q_tr, H (p + Δp)), H = σ_Y'), then
    ``Δεp = 3/2 Δp s/q_tr``. The stress
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
    with_stress : bool
        Assemble the returned stress (a copy of the trial stress, the plastic points replaced).
        The plastic fixed point needs only the increments: without it, a box-size array less
        per sweep.

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
    sig2 = np.ascontiguousarray(sig.reshape(-1, 6))
    from sacflow.mechanics.equivalent_stress import equivalent_stress  # numba: plastic runs only

    q_tr = equivalent_stress(sig2)  # one pass over the box, no full-size deviator
    plastic = (q_tr > law.yield_stress(p_old, d_all)).reshape(lead)
    idx = np.flatnonzero(plastic)
    if idx.size == 0:
        return ReturnResult(sig.copy() if with_stress else None, np.zeros(sig.shape),
                            np.zeros(lead), plastic, 0)
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
        # rounding floor of r: of q_tr, and of σ_Y(p + Δp) through the rounding of p + Δp (a
        # steep segment of a tabular curve, H ~ 1e14 Pa, makes it the larger one)
        floor = eps4 * np.maximum(q, h * (p0 + x))
        done = (np.abs(r) <= np.maximum(tol * y, floor)) | (hi - lo <= eps4 * x)
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
    # Only the plastic points change (a small part of a large cuboid box): written in place.
    sig_pl = sig2[idx]
    s_pl = deviator(sig_pl)
    dep = np.zeros(sig2.shape)
    dep[idx] = s_pl * (1.5 * dp / q_pl)[:, None]
    stress = None
    if with_stress:
        ratio = law.yield_stress(p_old[idx] + dp, d_pl) / q_pl  # s_new = s σ_Y(p + Δp)/q_tr
        new = s_pl * ratio[:, None]
        new[:, :3] += ((sig_pl[:, 0] + sig_pl[:, 1] + sig_pl[:, 2]) / 3.0)[:, None]
        stress = sig2.copy()
        stress[idx] = new
        stress = stress.reshape(sig.shape)
    return ReturnResult(stress, dep.reshape(sig.shape), dp_all.reshape(lead), plastic,
                        iterations)


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
