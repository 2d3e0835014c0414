"""Multiaxial high-cycle fatigue indices: Dang Van and Crossland (numerical core, issue #16).

A stress history is an array whose last axis holds the six components in the order
``11 22 33 12 13 23`` (tensor, not engineering, shears; Pa; tension positive) and one axis of
which is time (named explicitly by every function). Both criteria need the mesoscopic
*alternating* part of the deviator, found as the centre of the minimum ball enclosing the
deviatoric path (Papadopoulos et al. 1997; Bernasconi & Papadopoulos 2005):

* the deviator ``s`` is mapped isometrically onto the 5-vector
  ``S = (√3/2 s11, (s22 − s33)/2, s12, s13, s23)``, for which ``|S| = √J2 = √(½ s:s)``
  (:mod:`sacflow.mechanics.deviatoric_space`);
* the minimum ball enclosing ``{S(t)}`` has centre ``S*`` and radius ``R = √J2,a``
  (:func:`sacflow.mechanics.minimum_ball.min_enclosing_ball`, exact and certified);
* **Dang Van** (Dang Van, Griveau & Message 1989): with ``ŝ(t) = s(t) − s*``, the mesoscopic
  shear ``τ(t) = (ŝ_I − ŝ_III)/2`` (Tresca of ``ŝ``) and the hydrostatic stress
  ``p(t) = tr σ(t)/3``, the index is ``DV = max_t [τ(t) + a p(t)] / b``,
  ``a = 3 (t₋₁/f₋₁ − ½)``, ``b = t₋₁`` (:func:`dang_van`);
* **Crossland** (Crossland 1956): ``CR = [√J2,a + α p_max] / β``, ``α = 3 t₋₁/f₋₁ − √3``,
  ``β = t₋₁`` (:func:`crossland`);

where ``f₋₁`` and ``t₋₁`` are the fully reversed bending and torsion endurance limits
(:class:`EnduranceLimits`). Both constants are calibrated so that either pure alternating
loading at its own endurance limit gives an index of exactly 1; an index above 1 predicts
crack initiation at that material point.

Every material point is processed independently by the same compiled code, so splitting the
points into chunks (to stream a long history) gives bit-identical results.

References
----------
.. [DV89] K. Dang Van, B. Griveau, O. Message, "On a new multiaxial fatigue limit criterion:
   theory and application", in *Biaxial and Multiaxial Fatigue*, EGF 3, M. W. Brown and
   K. J. Miller (eds.), Mechanical Engineering Publications, London, 1989, pp. 479–496.
.. [Cr56] B. Crossland, "Effect of large hydrostatic pressures on the torsional fatigue
   strength of an alloy steel", *Proc. Int. Conf. on Fatigue of Metals*, IMechE, London,
   1956, pp. 138–149.
.. [Pa97] I. V. Papadopoulos, P. Davoli, C. Gorla, M. Filippini, A. Bernasconi, "A
   comparative study of multiaxial high-cycle fatigue criteria for metals", *Int. J.
   Fatigue* 19 (1997) 219–235.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from sacflow.mechanics.deviatoric_space import (
    HALF_SQRT3,
    N_DEVIATORIC,
    SQRT3,
    as_stress_components,
    deviatoric_vector,
)
from sacflow.mechanics.minimum_ball import certified_ball, min_enclosing_ball, raise_uncertified

__all__ = [
    "CrosslandResult",
    "DangVanResult",
    "EnduranceLimits",
    "crossland",
    "dang_van",
    "fatigue_indices",
]

#: Jacobi sweeps for the 3 × 3 principal stresses (convergence is quadratic; 4–6 suffice).
_JACOBI_MAX_SWEEPS = 50


@dataclass(frozen=True)
class EnduranceLimits:
    """Fully reversed endurance limits of the material, the constants of both criteria.

    The core has no defaults: the caller supplies the limits of its material. The fatigue
    stage's order-of-magnitude defaults for bearing steel, and their source, are
    :data:`sacflow.compare.fatigue_index.DEFAULT_LIMITS` (published bending *and* torsion limits of
    one heat of AISI 52100 / 100Cr6 could not be verified from a citable source).

    Parameters
    ----------
    bending : float
        ``f₋₁``, fully reversed (R = −1) bending endurance limit, amplitude, Pa.
    torsion : float
        ``t₋₁``, fully reversed torsion endurance limit, amplitude, Pa.

    Notes
    -----
    The criteria are meaningful (positive pressure sensitivity) for ``t₋₁/f₋₁ > ½``
    (Dang Van) and ``t₋₁/f₋₁ > 1/√3 ≈ 0.577`` (Crossland), the usual range for hard metals
    [Pa97]_; ratios outside it are accepted (the indices remain well defined) but the
    pressure term then lowers the index.
    """

    bending: float
    torsion: float

    def __post_init__(self) -> None:
        """Reject non-finite or non-positive limits."""
        for name in ("bending", "torsion"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"EnduranceLimits.{name} must be finite and > 0 Pa, "
                                 f"got {value!r}")

    @property
    def dang_van_a(self) -> float:
        """Dang Van hydrostatic sensitivity ``a = 3 (t₋₁/f₋₁ − ½)`` (dimensionless)."""
        return 3.0 * (self.torsion / self.bending - 0.5)

    @property
    def dang_van_b(self) -> float:
        """Dang Van shear resistance ``b = t₋₁`` (Pa)."""
        return self.torsion

    @property
    def crossland_alpha(self) -> float:
        """Crossland hydrostatic sensitivity ``α = 3 t₋₁/f₋₁ − √3`` (dimensionless)."""
        return 3.0 * self.torsion / self.bending - SQRT3

    @property
    def crossland_beta(self) -> float:
        """Crossland shear resistance ``β = t₋₁`` (Pa)."""
        return self.torsion


@dataclass(frozen=True)
class DangVanResult:
    """Dang Van index and what a fatigue stage reports with it (arrays over material points).

    Attributes
    ----------
    index : ndarray
        ``DV = max_t [τ(t) + a p(t)] / b``.
    time_index : int ndarray
        Position along the time axis of the maximum (the first one on ties).
    tau : ndarray
        ``τ`` at the maximum (Pa): Tresca shear of the mesoscopic alternating deviator.
    pressure : ndarray
        ``p = tr σ / 3`` at the maximum (Pa).
    centre : ndarray (..., 5)
        Centre ``S*`` of the minimum ball of the deviatoric path (Pa; 5-vector).
    radius : ndarray
        Its radius ``√J2,a`` (Pa).
    ball_gap : ndarray
        Relative optimality gap of that ball, its certificate (at most
        :data:`~sacflow.mechanics.minimum_ball.CERTIFICATE_TOLERANCE`).
    ball_status : int8 ndarray
        Which algorithm certified it: :data:`~sacflow.mechanics.minimum_ball.FAST_PATH` or
        :data:`~sacflow.mechanics.minimum_ball.FALLBACK`.
    """

    index: NDArray[np.float64]
    time_index: NDArray[np.intp]
    tau: NDArray[np.float64]
    pressure: NDArray[np.float64]
    centre: NDArray[np.float64]
    radius: NDArray[np.float64]
    ball_gap: NDArray[np.float64]
    ball_status: NDArray[np.int8]


@dataclass(frozen=True)
class CrosslandResult:
    """Crossland index and its ingredients (arrays over material points).

    Attributes
    ----------
    index : ndarray
        ``CR = [√J2,a + α p_max] / β``.
    sqrt_j2a : ndarray
        ``√J2,a``: radius of the minimum ball of the deviatoric path (Pa).
    p_max : ndarray
        Maximum over time of ``p = tr σ / 3`` (Pa).
    time_index_p_max : int ndarray
        Position along the time axis of ``p_max`` (the first one on ties).
    """

    index: NDArray[np.float64]
    sqrt_j2a: NDArray[np.float64]
    p_max: NDArray[np.float64]
    time_index_p_max: NDArray[np.intp]


# ------------------------------------------------------------------------------ Dang Van


@numba.njit(cache=True, nogil=True)
def _tresca(a: NDArray[np.float64]) -> float:
    """Half the spread of the eigenvalues of the symmetric 3 × 3 ``a`` (cyclic Jacobi)."""
    for _ in range(_JACOBI_MAX_SWEEPS):
        off = a[0, 1] * a[0, 1] + a[0, 2] * a[0, 2] + a[1, 2] * a[1, 2]
        diag = a[0, 0] * a[0, 0] + a[1, 1] * a[1, 1] + a[2, 2] * a[2, 2]
        if off <= 1.0e-34 * diag or off == 0.0:
            break
        for p in range(2):
            for r in range(p + 1, 3):
                apr = a[p, r]
                if apr == 0.0:
                    continue
                theta = (a[r, r] - a[p, p]) / (2.0 * apr)
                t = math.copysign(1.0, theta) / (abs(theta) + math.sqrt(theta * theta + 1.0))
                cs = 1.0 / math.sqrt(t * t + 1.0)
                sn = t * cs
                for k in range(3):
                    akp = a[k, p]
                    akr = a[k, r]
                    a[k, p] = cs * akp - sn * akr
                    a[k, r] = sn * akp + cs * akr
                for k in range(3):
                    apk = a[p, k]
                    ark = a[r, k]
                    a[p, k] = cs * apk - sn * ark
                    a[r, k] = sn * apk + cs * ark
    hi: float = max(a[0, 0], max(a[1, 1], a[2, 2]))
    lo: float = min(a[0, 0], min(a[1, 1], a[2, 2]))
    return 0.5 * (hi - lo)


@numba.njit(cache=True, nogil=True)
def _deviatoric_path(stress: NDArray[np.float64],
                     vec: NDArray[np.float64]) -> None:
    """5-vectors of one point's history ``stress`` (T, 6) into ``vec`` (T, 5)."""
    for t in range(stress.shape[0]):
        s = stress[t]
        s11 = s[0] - (s[0] + s[1] + s[2]) / 3.0
        vec[t, 0] = HALF_SQRT3 * s11
        vec[t, 1] = 0.5 * (s[1] - s[2])
        vec[t, 2] = s[3]
        vec[t, 3] = s[4]
        vec[t, 4] = s[5]


@numba.njit(cache=True, nogil=True)
def _mesoscopic_shear(v: NDArray[np.float64], c: NDArray[np.float64],
                      mat: NDArray[np.float64]) -> float:
    """Tresca shear of ``ŝ = s − s*`` from the 5-vectors ``v`` of ``s`` and ``c`` of ``s*``.

    Back from 5-D to the 3 × 3 deviator (the isotropic part is irrelevant to the spread).
    """
    v0 = v[0] - c[0]
    v1 = v[1] - c[1]
    third = v0 / SQRT3
    mat[0, 0] = 2.0 * third
    mat[1, 1] = -third + v1
    mat[2, 2] = -third - v1
    mat[0, 1] = mat[1, 0] = v[2] - c[2]
    mat[0, 2] = mat[2, 0] = v[3] - c[3]
    mat[1, 2] = mat[2, 1] = v[4] - c[4]
    return _tresca(mat)


@numba.njit(cache=True, nogil=True)
def _dang_van_kernel(stress: NDArray[np.float64], a_dv: float, index: NDArray[np.float64],
                     time_index: NDArray[np.intp], tau_out: NDArray[np.float64],
                     p_out: NDArray[np.float64], centres: NDArray[np.float64],
                     radii: NDArray[np.float64], gap: NDArray[np.float64],
                     status: NDArray[np.int8]) -> None:
    """Per material point j of ``stress`` (P, T, 6): certified ball of the path, then ``max_t``."""
    n_pts, n_t, _ = stress.shape
    vec = np.empty((n_t, N_DEVIATORIC))
    work = np.empty((n_t, N_DEVIATORIC))
    support = np.empty(N_DEVIATORIC + 1, dtype=np.int64)
    weights = np.empty(N_DEVIATORIC + 1)
    mat = np.empty((3, 3))
    for j in range(n_pts):
        _deviatoric_path(stress[j], vec)
        radii[j], gap[j], status[j] = certified_ball(vec, work, centres[j], support, weights)
        best = -np.inf
        for t in range(n_t):
            tau = _mesoscopic_shear(vec[t], centres[j], mat)
            s = stress[j, t]
            p = (s[0] + s[1] + s[2]) / 3.0
            value = tau + a_dv * p
            if value > best:
                best = value
                time_index[j] = t
                tau_out[j] = tau
                p_out[j] = p
        index[j] = best


def _history(stress: ArrayLike, time_axis: int) -> tuple[NDArray[np.float64], tuple[int, ...]]:
    """``stress`` as a contiguous (points, times, 6) array, and the shape of the point axes."""
    sig = as_stress_components(stress)
    if sig.ndim < 2:
        raise ValueError(f"a stress history needs a time axis and a component axis, "
                         f"got shape {sig.shape}")
    axis = time_axis + sig.ndim if time_axis < 0 else time_axis
    if not 0 <= axis < sig.ndim - 1:
        raise ValueError(f"time_axis {time_axis} is not an axis of shape {sig.shape} other "
                         f"than the last (component) one")
    if sig.shape[axis] < 1:
        raise ValueError("the stress history has no time step")
    if not np.all(np.isfinite(sig)):
        raise ValueError("the stress history must be finite")
    moved = np.moveaxis(sig, axis, -2)
    lead = moved.shape[:-2]
    flat = np.ascontiguousarray(moved.reshape(-1, *moved.shape[-2:]))
    return flat, lead


def dang_van(stress_history: ArrayLike, limits: EnduranceLimits, *,
             time_axis: int) -> DangVanResult:
    """Dang Van index of each material point over one load cycle [DV89]_.

    Parameters
    ----------
    stress_history : array_like (..., 6)
        Stress components (11 22 33 12 13 23, tensor shears, Pa) over time along
        ``time_axis``; every other leading axis indexes material points.
    limits : EnduranceLimits
        ``f₋₁`` and ``t₋₁``, giving ``a = 3 (t₋₁/f₋₁ − ½)`` and ``b = t₋₁``.
    time_axis : int
        The time axis of ``stress_history`` (not the last one).

    Returns
    -------
    DangVanResult
        Arrays over the material-point axes (in their order, time axis removed).

    Raises
    ------
    sacflow.mechanics.minimum_ball.BallCertificateError
        If the minimum ball of a point's path cannot be certified optimal.

    Notes
    -----
    The mesoscopic mean deviator ``s*`` is the centre of the minimum ball enclosing the
    deviatoric path (Papadopoulos et al. [Pa97]_, computed exactly and certified: see
    :func:`~sacflow.mechanics.minimum_ball.min_enclosing_ball`); ``ŝ(t) = s(t) − s*``,
    ``τ(t) = (ŝ_I − ŝ_III)/2`` (principal values by Jacobi rotations, accurate to rounding)
    and ``p(t) = tr σ(t)/3``;
    ``DV = max_t [τ(t) + a p(t)] / b``. The maximum is taken over the given time steps only;
    between them it is not interpolated, so the sampling must resolve the cycle.
    """
    flat, lead = _history(stress_history, time_axis)
    return _dang_van_flat(flat, limits, lead)


def _dang_van_flat(flat: NDArray[np.float64], limits: EnduranceLimits,
                   lead: tuple[int, ...]) -> DangVanResult:
    """Dang Van result from a contiguous (points, times, 6) history."""
    n_pts = flat.shape[0]
    index = np.empty(n_pts)
    time_index = np.empty(n_pts, dtype=np.intp)
    tau = np.empty(n_pts)
    pressure = np.empty(n_pts)
    centres = np.empty((n_pts, N_DEVIATORIC))
    radii = np.empty(n_pts)
    gap = np.empty(n_pts)
    status = np.empty(n_pts, dtype=np.int8)
    _dang_van_kernel(flat, limits.dang_van_a, index, time_index, tau, pressure, centres, radii,
                     gap, status)
    raise_uncertified(status, gap)
    return DangVanResult(index=(index / limits.dang_van_b).reshape(lead),
                         time_index=time_index.reshape(lead), tau=tau.reshape(lead),
                         pressure=pressure.reshape(lead),
                         centre=centres.reshape(*lead, N_DEVIATORIC), radius=radii.reshape(lead),
                         ball_gap=gap.reshape(lead), ball_status=status.reshape(lead))


def crossland(stress_history: ArrayLike, limits: EnduranceLimits, *,
              time_axis: int) -> CrosslandResult:
    """Crossland index of each material point over one load cycle [Cr56]_.

    Parameters
    ----------
    stress_history : array_like (..., 6)
        Stress components (11 22 33 12 13 23, tensor shears, Pa) over time along
        ``time_axis``; every other leading axis indexes material points.
    limits : EnduranceLimits
        ``f₋₁`` and ``t₋₁``, giving ``α = 3 t₋₁/f₋₁ − √3`` and ``β = t₋₁``.
    time_axis : int
        The time axis of ``stress_history`` (not the last one).

    Returns
    -------
    CrosslandResult
        Arrays over the material-point axes (in their order, time axis removed).

    Notes
    -----
    ``√J2,a`` is the radius of the minimum ball enclosing the deviatoric path, the
    definition of the amplitude for non-proportional loading recommended by Papadopoulos et
    al. [Pa97]_ (exact and certified, :func:`~sacflow.mechanics.minimum_ball.min_enclosing_ball`);
    ``p_max = max_t tr σ(t)/3``; ``CR = [√J2,a + α p_max] / β``.
    """
    flat, lead = _history(stress_history, time_axis)
    radii = min_enclosing_ball(deviatoric_vector(flat)).radius
    return _crossland_from(flat, radii, limits, lead)


def _crossland_from(flat: NDArray[np.float64], radii: NDArray[np.float64],
                    limits: EnduranceLimits, lead: tuple[int, ...]) -> CrosslandResult:
    """Crossland result from (points, times, 6) histories and their ball radii ``√J2,a``."""
    p = (flat[..., 0] + flat[..., 1] + flat[..., 2]) / 3.0
    t_max = np.argmax(p, axis=-1)
    p_max = np.take_along_axis(p, t_max[:, None], axis=-1)[:, 0]
    index = (radii + limits.crossland_alpha * p_max) / limits.crossland_beta
    return CrosslandResult(index=index.reshape(lead), sqrt_j2a=radii.reshape(lead),
                           p_max=p_max.reshape(lead), time_index_p_max=t_max.reshape(lead))


def fatigue_indices(stress_history: ArrayLike, limits: EnduranceLimits, *,
                    time_axis: int) -> tuple[DangVanResult, CrosslandResult]:
    """Dang Van and Crossland indices of each material point, one ball per point for both.

    The same as ``(dang_van(...), crossland(...))`` (bit-identical), at the cost of one
    minimum-ball computation per point instead of two.

    Parameters
    ----------
    stress_history : array_like (..., 6)
        Stress components (11 22 33 12 13 23, tensor shears, Pa) over time along
        ``time_axis``; every other leading axis indexes material points.
    limits : EnduranceLimits
        ``f₋₁`` and ``t₋₁``.
    time_axis : int
        The time axis of ``stress_history`` (not the last one).

    Returns
    -------
    (DangVanResult, CrosslandResult)
        Arrays over the material-point axes (in their order, time axis removed).
    """
    flat, lead = _history(stress_history, time_axis)
    dv = _dang_van_flat(flat, limits, lead)
    return dv, _crossland_from(flat, dv.radius.reshape(-1), limits, lead)
