"""Multiaxial high-cycle fatigue indices: Dang Van and Crossland (numerical core, issue #16).

A stress history is an array whose last axis holds the six components in the order
``11 22 33 12 13 23`` (tensor, not engineering, shears; Pa; tension positive) and one axis of
which is time (named explicitly by every function). Both criteria need the mesoscopic
*alternating* part of the deviator, found as the centre of the minimum ball enclosing the
deviatoric path (Papadopoulos et al. 1997; Bernasconi & Papadopoulos 2005):

* the deviator ``s`` is mapped isometrically onto the 5-vector
  ``S = (√3/2 s11, (s22 − s33)/2, s12, s13, s23)``, for which ``|S| = √J2 = √(½ s:s)``
  (:func:`deviatoric_vector`, inverse :func:`deviator_from_vector`);
* the minimum ball enclosing ``{S(t)}`` has centre ``S*`` and radius ``R = √J2,a``
  (:func:`min_enclosing_ball`, exact);
* **Dang Van** (Dang Van, Griveau & Message 1989): with ``ŝ(t) = s(t) − s*``,
  ``τ(t) = (ŝ_I − ŝ_III)/2`` (Tresca of ``ŝ``) and ``p(t) = tr σ(t)/3``, the index is
  ``DV = max_t [τ(t) + a p(t)] / b``, ``a = 3 (t₋₁/f₋₁ − ½)``, ``b = t₋₁``
  (:func:`dang_van`);
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
.. [BP05] A. Bernasconi, I. V. Papadopoulos, "Efficiency of algorithms for shear stress
   amplitude calculation in critical plane class fatigue criteria", *Comput. Mater. Sci.*
   34 (2005) 355–368.
.. [FGK03] K. Fischer, B. Gärtner, M. Kutz, "Fast smallest-enclosing-ball computation in
   high dimensions", *Algorithms – ESA 2003*, LNCS 2832, Springer, 2003, pp. 630–641.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "N_COMPONENTS",
    "N_DEVIATORIC",
    "CrosslandResult",
    "DangVanResult",
    "EnduranceLimits",
    "crossland",
    "dang_van",
    "deviator_from_vector",
    "deviatoric_vector",
    "fatigue_indices",
    "min_enclosing_ball",
]

#: Stress components per material point and time (order 11 22 33 12 13 23).
N_COMPONENTS = 6
#: Dimension of the deviatoric vector space (Papadopoulos' 5-vector).
N_DEVIATORIC = 5

_SQRT3 = math.sqrt(3.0)
_HALF_SQRT3 = 0.5 * _SQRT3

#: Relative tolerance (of the point set's extent) under which the ball centre is taken to lie
#: in the affine hull of its support set, and affine coefficients count as non-negative.
_BALL_TOL = 1.0e-12
#: Pivot steps of the ball algorithm before it gives up (never reached in the tests: a few
#: tens suffice for 200 points in 5-D); the ball returned then still encloses every point.
_BALL_MAX_ITER = 10_000
#: Jacobi sweeps for the 3 × 3 principal stresses (convergence is quadratic; 4–6 suffice).
_JACOBI_MAX_SWEEPS = 50


@dataclass(frozen=True)
class EnduranceLimits:
    """Fully reversed endurance limits of the material, the constants of both criteria.

    The core has no defaults: the caller supplies the limits of its material. The fatigue
    stage's order-of-magnitude defaults for bearing steel, and their source, are
    :data:`sacflow.compare.fatigue.DEFAULT_LIMITS` (published bending *and* torsion limits of
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
        return 3.0 * self.torsion / self.bending - _SQRT3

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
    """

    index: NDArray[np.float64]
    time_index: NDArray[np.intp]
    tau: NDArray[np.float64]
    pressure: NDArray[np.float64]
    centre: NDArray[np.float64]
    radius: NDArray[np.float64]


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


# --------------------------------------------------------------------------- deviatoric map


def deviatoric_vector(stress: ArrayLike) -> NDArray[np.float64]:
    """Papadopoulos' deviatoric 5-vector of stress tensors [Pa97]_.

    Parameters
    ----------
    stress : array_like (..., 6)
        Components ``11 22 33 12 13 23`` (tensor shears).

    Returns
    -------
    ndarray (..., 5)
        ``S = (√3/2 s11, (s22 − s33)/2, s12, s13, s23)`` with ``s`` the deviator, so that
        ``|S| = √J2 = √(½ s:s)``: the map is an isometry from deviators (norm ``√(½ s:s)``)
        onto R⁵, which is what makes the minimum enclosing ball meaningful.
    """
    sig = _as_components(stress)
    out = np.empty((*sig.shape[:-1], N_DEVIATORIC))
    s11 = sig[..., 0] - (sig[..., 0] + sig[..., 1] + sig[..., 2]) / 3.0
    out[..., 0] = _HALF_SQRT3 * s11
    out[..., 1] = 0.5 * (sig[..., 1] - sig[..., 2])
    out[..., 2:] = sig[..., 3:]
    return out


def deviator_from_vector(vector: ArrayLike) -> NDArray[np.float64]:
    """Inverse of :func:`deviatoric_vector`: the deviator's six components.

    Parameters
    ----------
    vector : array_like (..., 5)
        Deviatoric 5-vectors ``S``.

    Returns
    -------
    ndarray (..., 6)
        Traceless components ``11 22 33 12 13 23``:
        ``s11 = 2 S1/√3``, ``s22 = −S1/√3 + S2``, ``s33 = −S1/√3 − S2``.
    """
    v = np.asarray(vector, dtype=float)
    if v.shape[-1:] != (N_DEVIATORIC,):
        raise ValueError(f"expected a last axis of length {N_DEVIATORIC}, got shape {v.shape}")
    out = np.empty((*v.shape[:-1], N_COMPONENTS))
    third = v[..., 0] / _SQRT3
    out[..., 0] = 2.0 * third
    out[..., 1] = -third + v[..., 1]
    out[..., 2] = -third - v[..., 1]
    out[..., 3:] = v[..., 2:]
    return out


# --------------------------------------------------------------------- minimum enclosing ball


@numba.njit(cache=True, nogil=True)
def _solve_small(g: np.ndarray, b: np.ndarray, k: int) -> bool:  # pragma: no cover - compiled
    """Solve ``g[:k, :k] x = b[:k]`` in place (partial pivoting); False if singular."""
    for col in range(k):
        piv = col
        best = abs(g[col, col])
        for row in range(col + 1, k):
            if abs(g[row, col]) > best:
                best = abs(g[row, col])
                piv = row
        if best == 0.0:
            return False
        if piv != col:
            for j in range(k):
                g[col, j], g[piv, j] = g[piv, j], g[col, j]
            b[col], b[piv] = b[piv], b[col]
        for row in range(col + 1, k):
            f = g[row, col] / g[col, col]
            for j in range(col, k):
                g[row, j] -= f * g[col, j]
            b[row] -= f * b[col]
    for col in range(k - 1, -1, -1):
        acc = b[col]
        for j in range(col + 1, k):
            acc -= g[col, j] * b[j]
        b[col] = acc / g[col, col]
    return True


@numba.njit(cache=True, nogil=True)
def _circumcentre(q: np.ndarray, support: np.ndarray, m: int, cc: np.ndarray,
                  lam: np.ndarray, g: np.ndarray, rhs: np.ndarray,
                  diff: np.ndarray) -> bool:  # pragma: no cover - compiled
    """Centre ``cc`` of the sphere through the ``m`` support points lying in their affine hull.

    ``cc = q0 + Σ x_i (q_i − q0)`` with ``2 (q_i − q0)·(cc − q0) = |q_i − q0|²``: a Gram
    system of size ``m − 1``. ``lam`` receives the affine coefficients (``1 − Σx, x_1, …``).
    Returns False if the support set is (numerically) affinely dependent.
    """
    d = q.shape[1]
    q0 = support[0]
    k = m - 1
    for i in range(k):
        qi = support[i + 1]
        for c in range(d):
            diff[i, c] = q[qi, c] - q[q0, c]
    for i in range(k):
        for j in range(i, k):
            acc = 0.0
            for c in range(d):
                acc += diff[i, c] * diff[j, c]
            g[i, j] = acc
            g[j, i] = acc
        rhs[i] = 0.5 * g[i, i]
    if not _solve_small(g, rhs, k):
        return False
    total = 0.0
    for c in range(d):
        cc[c] = q[q0, c]
    for i in range(k):
        lam[i + 1] = rhs[i]
        total += rhs[i]
        for c in range(d):
            cc[c] += rhs[i] * diff[i, c]
    lam[0] = 1.0 - total
    for i in range(m):
        if not math.isfinite(lam[i]):
            return False
    return True


@numba.njit(cache=True, nogil=True)
def _ball_one(q: np.ndarray, centre: np.ndarray) -> float:  # noqa: C901  # pragma: no cover
    """Minimum ball of the rows of ``q`` (n, d), already centred and scaled to extent ~1.

    Pivoting algorithm of Fischer, Gärtner & Kutz [FGK03]_ (the one of Gärtner's *Seb*):
    the ball ``B(c, r)`` encloses every point and has its support set ``T`` (affinely
    independent, at most d + 1 points) on its boundary. While ``c`` is not the circumcentre
    of ``T`` in ``aff(T)``, ``c`` walks towards that circumcentre (staying equidistant from
    ``T``, the radius shrinking) until a point outside ``T`` reaches the boundary; that
    point joins ``T``. Once ``c`` is the circumcentre, its affine coefficients decide:
    all ≥ 0 means ``c ∈ conv(T)``, the optimality condition, otherwise the point with the
    most negative coefficient leaves ``T``. Returns the radius (the largest distance from
    the final centre, so the ball encloses every point whatever the rounding).
    """
    n, d = q.shape
    dmax = d + 1
    support = np.empty(dmax, dtype=np.int64)
    lam = np.empty(dmax)
    g = np.empty((d, d))
    rhs = np.empty(d)
    diff = np.empty((d, d))
    cc = np.empty(d)
    step = np.empty(d)
    tol2 = _BALL_TOL * _BALL_TOL
    # Start: centroid, support = the farthest point.
    for c in range(d):
        acc = 0.0
        for i in range(n):
            acc += q[i, c]
        centre[c] = acc / n
    far = 0
    best = -1.0
    for i in range(n):
        acc = 0.0
        for c in range(d):
            acc += (q[i, c] - centre[c]) ** 2
        if acc > best:
            best = acc
            far = i
    support[0] = far
    m = 1
    for _ in range(_BALL_MAX_ITER):
        if not _circumcentre(q, support, m, cc, lam, g, rhs, diff):
            # Affinely dependent support (rounding): drop the newest point and go on.
            m -= 1
            continue
        dist2 = 0.0
        for c in range(d):
            step[c] = cc[c] - centre[c]
            dist2 += step[c] * step[c]
        # A point whose offset from aff(T) along the walk is below _BALL_TOL (relative to the
        # unit extent) cannot stop it: this keeps T affinely independent (duplicates of
        # support points included) and leaves such a point outside by at most ~_BALL_TOL.
        den_min = 2.0 * _BALL_TOL * math.sqrt(dist2)
        if dist2 <= tol2:
            for c in range(d):
                centre[c] = cc[c]
            worst = 0
            for i in range(1, m):
                if lam[i] < lam[worst]:
                    worst = i
            if lam[worst] >= -_BALL_TOL or m == 1:
                break
            for i in range(worst, m - 1):
                support[i] = support[i + 1]
            m -= 1
            continue
        # Walk c → cc; a point p stops it at t_p = (r² − |p − c|²) / (2 (q0 − p)·step).
        q0 = support[0]
        r2 = 0.0
        for c in range(d):
            r2 += (q[q0, c] - centre[c]) ** 2
        t_best = 1.0
        stopper = -1
        if m < dmax:
            for i in range(n):
                insup = False
                for j in range(m):
                    if support[j] == i:
                        insup = True
                if insup:
                    continue
                den = 0.0
                p2 = 0.0
                for c in range(d):
                    den += (q[q0, c] - q[i, c]) * step[c]
                    p2 += (q[i, c] - centre[c]) ** 2
                den *= 2.0
                if den <= den_min:
                    continue
                t = (r2 - p2) / den
                if t < t_best:
                    t_best = max(t, 0.0)
                    stopper = i
        for c in range(d):
            centre[c] += t_best * step[c]
        if stopper >= 0:
            support[m] = stopper
            m += 1
    r2 = 0.0
    for i in range(n):
        acc = 0.0
        for c in range(d):
            acc += (q[i, c] - centre[c]) ** 2
        r2 = max(r2, acc)
    return math.sqrt(r2)


@numba.njit(cache=True, nogil=True)
def _normalised_ball(pts: np.ndarray, work: np.ndarray,
                     centre: np.ndarray) -> float:  # pragma: no cover - compiled
    """Ball of ``pts`` (n, d) in physical units, computed on centred, scaled coordinates."""
    n, d = pts.shape
    scale = 0.0
    for i in range(n):
        for c in range(d):
            work[i, c] = pts[i, c] - pts[0, c]
            scale = max(scale, abs(work[i, c]))
    if scale == 0.0:
        for c in range(d):
            centre[c] = pts[0, c]
        return 0.0
    for i in range(n):
        for c in range(d):
            work[i, c] /= scale
    radius = _ball_one(work, centre)
    for c in range(d):
        centre[c] = pts[0, c] + scale * centre[c]
    return scale * radius


@numba.njit(cache=True, nogil=True)
def _balls(points: np.ndarray, centres: np.ndarray,
           radii: np.ndarray) -> None:  # pragma: no cover - compiled
    """Minimum balls of ``points[j]`` (n, d) for every set j."""
    n_sets, n, d = points.shape
    work = np.empty((n, d))
    for j in range(n_sets):
        radii[j] = _normalised_ball(points[j], work, centres[j])


def min_enclosing_ball(points: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Exact minimum enclosing balls of many point sets (one per leading index).

    Parameters
    ----------
    points : array_like (..., n, d)
        ``n ≥ 1`` points of R^d per set; for the fatigue criteria ``d = 5`` and the ``n``
        points are the deviatoric vectors of one material point at successive times.

    Returns
    -------
    centres : ndarray (..., d)
    radii : ndarray (...)
        Centre and radius of the smallest ball containing all ``n`` points of each set.

    Notes
    -----
    The minimum ball of the deviatoric path gives the Crossland amplitude ``√J2,a`` (its
    radius) and the Dang Van mesoscopic mean deviator (its centre); Bernasconi &
    Papadopoulos [BP05]_ compare algorithms for it and recommend an exact one over the
    longest-chord or minimum-circumscribed-hypersphere approximations. This implementation
    is the pivoting algorithm of Fischer, Gärtner & Kutz [FGK03]_ (at most ``d + 1``
    support points, exact up to rounding: the returned centre lies in the convex hull of
    the support points on the sphere to a relative tolerance of 1e-12, the optimality
    condition), compiled with numba, one set at a time. Each set is shifted to its first
    point and scaled by its extent before the computation, so results do not depend on the
    units. The radius returned is the largest distance from the returned centre, so the
    ball contains every point.
    """
    pts = np.asarray(points, dtype=float)
    if pts.ndim < 2 or pts.shape[-2] < 1 or pts.shape[-1] < 1:
        raise ValueError(f"points must have shape (..., n >= 1, d >= 1), got {pts.shape}")
    if not np.all(np.isfinite(pts)):
        raise ValueError("points must be finite")
    lead = pts.shape[:-2]
    n, d = pts.shape[-2:]
    flat = np.ascontiguousarray(pts.reshape(-1, n, d))
    centres = np.empty((flat.shape[0], d))
    radii = np.empty(flat.shape[0])
    _balls(flat, centres, radii)
    return centres.reshape(*lead, d), radii.reshape(lead)


# ------------------------------------------------------------------------------ Dang Van


@numba.njit(cache=True, nogil=True)
def _tresca(a: np.ndarray) -> float:  # pragma: no cover - compiled
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
    hi = max(a[0, 0], max(a[1, 1], a[2, 2]))
    lo = min(a[0, 0], min(a[1, 1], a[2, 2]))
    return 0.5 * (hi - lo)


@numba.njit(cache=True, nogil=True)
def _dang_van_kernel(stress: np.ndarray, a_dv: float, index: np.ndarray,
                     time_index: np.ndarray, tau_out: np.ndarray, p_out: np.ndarray,
                     centres: np.ndarray, radii: np.ndarray) -> None:  # pragma: no cover
    """Per material point j of ``stress`` (P, T, 6): ball of the path, then ``max_t``."""
    n_pts, n_t, _ = stress.shape
    vec = np.empty((n_t, N_DEVIATORIC))
    work = np.empty((n_t, N_DEVIATORIC))
    mat = np.empty((3, 3))
    for j in range(n_pts):
        for t in range(n_t):
            s = stress[j, t]
            s11 = s[0] - (s[0] + s[1] + s[2]) / 3.0
            vec[t, 0] = _HALF_SQRT3 * s11
            vec[t, 1] = 0.5 * (s[1] - s[2])
            vec[t, 2] = s[3]
            vec[t, 3] = s[4]
            vec[t, 4] = s[5]
        radii[j] = _normalised_ball(vec, work, centres[j])
        c = centres[j]
        best = -np.inf
        for t in range(n_t):
            # ŝ = s − s*: back from 5-D (the isotropic part is irrelevant to the spread).
            v0 = vec[t, 0] - c[0]
            v1 = vec[t, 1] - c[1]
            third = v0 / _SQRT3
            mat[0, 0] = 2.0 * third
            mat[1, 1] = -third + v1
            mat[2, 2] = -third - v1
            mat[0, 1] = mat[1, 0] = vec[t, 2] - c[2]
            mat[0, 2] = mat[2, 0] = vec[t, 3] - c[3]
            mat[1, 2] = mat[2, 1] = vec[t, 4] - c[4]
            tau = _tresca(mat)
            s = stress[j, t]
            p = (s[0] + s[1] + s[2]) / 3.0
            value = tau + a_dv * p
            if value > best:
                best = value
                time_index[j] = t
                tau_out[j] = tau
                p_out[j] = p
        index[j] = best


def _as_components(stress: ArrayLike) -> NDArray[np.float64]:
    """Float array with a last axis of the six stress components."""
    sig = np.asarray(stress, dtype=float)
    if sig.shape[-1:] != (N_COMPONENTS,):
        raise ValueError(f"expected a last axis of {N_COMPONENTS} stress components "
                         f"(11 22 33 12 13 23), got shape {sig.shape}")
    return sig


def _history(stress: ArrayLike, time_axis: int) -> tuple[NDArray[np.float64], tuple[int, ...]]:
    """``stress`` as a contiguous (points, times, 6) array, and the shape of the point axes."""
    sig = _as_components(stress)
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

    Notes
    -----
    The mesoscopic mean deviator ``s*`` is the centre of the minimum ball enclosing the
    deviatoric path (Papadopoulos et al. [Pa97]_, computed exactly: see
    :func:`min_enclosing_ball`); ``ŝ(t) = s(t) − s*``, ``τ(t) = (ŝ_I − ŝ_III)/2`` (principal
    values by Jacobi rotations, accurate to rounding) and ``p(t) = tr σ(t)/3``;
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
    _dang_van_kernel(flat, limits.dang_van_a, index, time_index, tau, pressure, centres, radii)
    return DangVanResult(index=(index / limits.dang_van_b).reshape(lead),
                         time_index=time_index.reshape(lead), tau=tau.reshape(lead),
                         pressure=pressure.reshape(lead),
                         centre=centres.reshape(*lead, N_DEVIATORIC), radius=radii.reshape(lead))


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
    al. [Pa97]_ (exact, :func:`min_enclosing_ball`); ``p_max = max_t tr σ(t)/3``;
    ``CR = [√J2,a + α p_max] / β``.
    """
    flat, lead = _history(stress_history, time_axis)
    _, radii = min_enclosing_ball(deviatoric_vector(flat))
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
