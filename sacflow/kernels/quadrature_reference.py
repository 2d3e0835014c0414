"""Slow references by quadrature, independent of the closed forms they check (tests only).

* :func:`eigenstrain_stress_by_quadrature`: the stress of a cuboid of uniform eigenstrain from
  Kelvin's point-force solution (:func:`kelvin_displacement_gradient`) integrated over the
  cuboid's faces (Mura, *Micromechanics of Defects in Solids*, 1987, §11), against
  :func:`sacflow.kernels.cuboid.cuboid_stress`.
* :func:`surface_displacement_by_quadrature`: the residual surface displacement of a buried
  cuboid from Boussinesq's stress by the reciprocal theorem (seed eq. 1.23), integrated over
  the cuboid with Duffy-transformed pyramids, against
  :func:`sacflow.kernels.residual_displacement.cuboid_surface_displacement`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sacflow.kernels.cuboid import COMPONENTS, SHEAR_WEIGHTS, lame_lambda, unit_eigenstrain
from sacflow.kernels.surface import boussinesq_stress

__all__ = [
    "eigenstrain_stress_by_quadrature",
    "kelvin_displacement_gradient",
    "surface_displacement_by_quadrature",
]

#: Float arrays of nodes and weights.
FloatArray = NDArray[np.float64]


def kelvin_displacement_gradient(r1: ArrayLike, r2: ArrayLike, r3: ArrayLike, nu: float,
                                 mu: float) -> np.ndarray:
    r"""Gradient of Kelvin's point-force solution in an infinite isotropic space.

    ``u_i(x) = G_ij(x − x') F_j`` with
    ``G_ij(r) = [(3 − 4ν) δ_ij / r + r_i r_j / r³] / (16 π μ (1 − ν))`` (Mura 1987, eq. 5.19),
    and

    .. math::

        G_{ij,k} = \frac{-(3 - 4ν) δ_{ij} r_k + δ_{ik} r_j + δ_{jk} r_i - 3 r_i r_j r_k / r^2}
                        {16 π μ (1 - ν) r^3}.

    Parameters
    ----------
    r1, r2, r3 : array_like
        Field point minus source point [m], broadcastable, nonzero.
    nu, mu : float
        Poisson ratio and shear modulus [Pa].

    Returns
    -------
    ndarray, shape ``(..., 3, 3, 3)``
        ``G[..., i, j, k] = ∂G_ij / ∂x_k`` [m/N per m].
    """
    r = np.stack(np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (r1, r2, r3))), -1)
    rr = np.sqrt(np.sum(r * r, axis=-1))[..., None, None, None]
    eye = np.eye(3)
    ri = r[..., :, None, None]
    rj = r[..., None, :, None]
    rk = r[..., None, None, :]
    g = (
        -(3.0 - 4.0 * nu) * eye[:, :, None] * rk
        + eye[:, None, :] * rj
        + eye[None, :, :] * ri
        - 3.0 * ri * rj * rk / rr**2
    )
    gradient: np.ndarray = g / (16.0 * math.pi * mu * (1.0 - nu) * rr**3)
    return gradient


def eigenstrain_stress_by_quadrature(x: ArrayLike, half: Sequence[float], nu: float, mu: float,
                                     source: int, order: int, panels: int = 1) -> np.ndarray:
    r"""Slow reference: stress of a cuboid eigenstrain by quadrature of Kelvin's solution.

    Independent of the potentials used by :func:`cuboid_stress`: a uniform eigenstrain ``ε*`` in
    ``V`` is equivalent to the surface tractions ``t = (C:ε*) n`` on ``∂V`` (outward normal), so

    .. math::

        u_{i,k}(x) = \oint_{∂V} G_{ij,k}(x - x') (C:ε^*)_{jl} n_l\, dS',\qquad
        σ = C:(\operatorname{sym}∇u − ε^* H),

    integrated with Gauss–Legendre rules (``order`` points per direction on each of
    ``panels × panels`` panels of every face).  Smooth, hence spectrally convergent, for points
    away from the faces, inside or outside.  For tests only (O(points × order² × panels²)).

    Parameters
    ----------
    x : array_like, shape ``(..., 3)``
        Field points relative to the cuboid centre [m].
    half : sequence of 3 floats
        Half sizes [m].
    nu, mu : float
        Poisson ratio and shear modulus [Pa].
    source : int
        Eigenstrain component 0..5 (unit tensor value).
    order : int
        Gauss–Legendre points per direction per panel.
    panels : int, optional
        Panels per face direction (composite rule), default 1.

    Returns
    -------
    ndarray, shape ``(..., 6)``
        Stress components (11, 22, 33, 12, 13, 23) [Pa].
    """
    x = np.asarray(x, dtype=float)
    halves = np.asarray(half, dtype=float)
    lam = lame_lambda(nu, mu)
    e_star = unit_eigenstrain(source)
    s = lam * np.trace(e_star) * np.eye(3) + 2.0 * mu * e_star
    t, w = np.polynomial.legendre.leggauss(int(order))
    edges = np.linspace(-1.0, 1.0, int(panels) + 1)
    mid, width = 0.5 * (edges[1:] + edges[:-1]), 0.5 * (edges[1:] - edges[:-1])
    t_all = (mid[:, None] + width[:, None] * t[None, :]).ravel()
    w_all = (width[:, None] * w[None, :]).ravel()
    pts = x.reshape(-1, 3)
    grad = np.zeros((pts.shape[0], 3, 3))
    for axis in range(3):
        b, c = (axis + 1) % 3, (axis + 2) % 3
        tb, tc = np.meshgrid(t_all * halves[b], t_all * halves[c], indexing="ij")
        area = np.outer(w_all, w_all).ravel() * halves[b] * halves[c]
        for side in (-1.0, 1.0):
            nodes = np.zeros((tb.size, 3))
            nodes[:, axis] = side * halves[axis]
            nodes[:, b], nodes[:, c] = tb.ravel(), tc.ravel()
            traction = s[:, axis] * side  # (C:ε*)_jl n_l
            for start in range(0, pts.shape[0], 16):
                r = pts[start : start + 16, None, :] - nodes[None, :, :]
                g = kelvin_displacement_gradient(r[..., 0], r[..., 1], r[..., 2], nu, mu)
                grad[start : start + 16] += np.einsum("pnijk,j,n->pik", g, traction, area)
    strain = 0.5 * (grad + np.swapaxes(grad, -1, -2))
    inside = np.all(np.abs(pts) < halves, axis=-1)
    sig = 2.0 * mu * strain + lam * np.trace(strain, axis1=-2, axis2=-1)[:, None, None] * np.eye(3)
    sig = sig - inside[:, None, None] * s
    out = np.stack([sig[:, i, j] for i, j in COMPONENTS], axis=-1)
    return out.reshape(*x.shape[:-1], 6)


def _graded_panels(scale: float, ratio: float = 0.3) -> NDArray[np.float64]:
    """Breakpoints of [0, 1] graded geometrically toward 0 down to about ``scale``."""
    if scale >= ratio:
        return np.array([0.0, 1.0])
    n = int(np.ceil(np.log(scale) / np.log(ratio)))
    return np.concatenate(([0.0], ratio ** np.arange(n, -1, -1)))


def _gauss(breaks: FloatArray, t: FloatArray, w: FloatArray) -> tuple[FloatArray, FloatArray]:
    a, b = breaks[:-1, None], breaks[1:, None]
    return (0.5 * (a + b) + 0.5 * (b - a) * t).ravel(), (0.5 * (b - a) * w).ravel()


def _pyramid_rule(apex: FloatArray, edge: FloatArray, axis: int, dist: float, order: int
                  ) -> tuple[FloatArray, FloatArray]:
    """Nodes and weights of the pyramid of a box with vertex ``apex`` and edge vector ``edge``.

    The pyramid has its apex at ``apex`` and its base on the face opposite to it normal to
    ``axis``; x = apex + s (e_k, u e_i, v e_j) (Duffy), Jacobian s² |e_1 e_2 e_3|, which
    cancels the 1/r² singularity of the point-force stress at the apex.  s is graded toward 0
    when the load point is at a distance ``dist`` > 0 from the apex, u and v when the pyramid
    is flat (|e_k| small against |e_i|).
    """
    t, w = np.polynomial.legendre.leggauss(order)
    i, j = (axis + 1) % 3, (axis + 2) % 3
    e = np.abs(edge)
    length = float(np.linalg.norm(edge))
    s_br = np.array([0.0, 1.0]) if dist == 0.0 else _graded_panels(0.1 * dist / length)
    s, ws = _gauss(s_br, t, w)
    u, wu = _gauss(_graded_panels(0.25 * e[axis] / e[i]), t, w)
    v, wv = _gauss(_graded_panels(0.25 * e[axis] / e[j]), t, w)
    S, U, V = np.meshgrid(s, u, v, indexing="ij")
    W = (ws[:, None, None] * wu[None, :, None] * wv[None, None, :]) * S * S
    pts = np.empty((*S.shape, 3))
    pts[..., axis] = apex[axis] + S * edge[axis]
    pts[..., i] = apex[i] + S * U * edge[i]
    pts[..., j] = apex[j] + S * V * edge[j]
    return pts.reshape(-1, 3), W.ravel() * float(np.prod(e))


def surface_displacement_by_quadrature(
    x1: float,
    x2: float,
    c3: float,
    half: tuple[float, float, float],
    nu: float,
    source: ArrayLike,
    order: int = 12,
    integrand: Callable[[FloatArray, FloatArray, FloatArray], FloatArray] | None = None,
) -> float | NDArray[np.float64]:
    r"""Slow reference: u3 at (x1, x2, 0) by quadrature of Boussinesq's stress over a cuboid.

    Computes :math:`u_3 = \int ε^*_{ij} σ^B_{ij}(ξ - x)\, dξ` over the cuboid
    |ξ1| <= half[0], |ξ2| <= half[1], |ξ3 − c3| <= half[2] by tensor-product Gauss–Legendre
    rules, independently of :func:`cuboid_surface_displacement`.  The cuboid is split at the
    point p nearest to the load point A (up to 8 sub-boxes with p as a vertex); each sub-box is
    split into the three pyramids with apex p and a far face as base, mapped to the unit cube
    (Duffy transform, Jacobian ∝ s², which cancels the 1/r² singularity when A = p, i.e. when
    the cuboid touches the surface below A); panels are graded geometrically toward the apex
    in s when A is near but outside the cuboid, and in the base coordinates of flat pyramids.

    Parameters
    ----------
    x1, x2 : float
        Surface point relative to the lateral centre of the cuboid [m].
    c3 : float
        Depth of the cuboid centre [m], c3 >= half[2].
    half : (float, float, float)
        Half sizes [m] (> 0).
    nu : float
        Poisson's ratio (used by the default integrand).
    source : array_like, shape (6,) or (n, 6)
        Eigenstrain(s), tensor components (11, 22, 33, 12, 13, 23); shear pairs are counted
        twice.
    order : int, optional
        Gauss–Legendre points per panel and direction.
    integrand : callable, optional
        ``f(X, Y, Z) -> (..., 6)``, the stress-like field of the unit force at the origin
        contracted with ε*; default ``boussinesq_stress(X, Y, Z, nu)``.

    Returns
    -------
    float or ndarray, shape (n,)
        u3 [m], positive into the body.
    """
    h = np.asarray(half, dtype=float)
    lo = np.array([-h[0] - x1, -h[1] - x2, c3 - h[2]])
    hi = np.array([h[0] - x1, h[1] - x2, c3 + h[2]])
    if lo[2] < -1e-12 * max(abs(c3), h[2]):
        raise ValueError("the cuboid must lie in the half-space: c3 - half[2] >= 0")
    lo[2] = max(lo[2], 0.0)
    p = np.clip(0.0, lo, hi)
    dist = float(np.linalg.norm(p))
    if integrand is None:

        def integrand(a: FloatArray, b: FloatArray, c: FloatArray) -> FloatArray:
            return boussinesq_stress(a, b, c, nu)

    pts, wts = [], []
    for c1 in (lo[0], hi[0]):
        for c2 in (lo[1], hi[1]):
            for c3_ in (lo[2], hi[2]):
                edge = np.array([c1, c2, c3_]) - p
                if np.any(edge == 0.0):
                    continue  # empty sub-box (p on that face)
                for axis in range(3):
                    q, wq = _pyramid_rule(p, edge, axis, dist, order)
                    pts.append(q)
                    wts.append(wq)
    P = np.concatenate(pts)
    Wt = np.concatenate(wts)
    sig = Wt @ integrand(P[:, 0], P[:, 1], np.maximum(P[:, 2], 0.0))
    src = np.asarray(source, dtype=float)
    res = (src * SHEAR_WEIGHTS) @ sig
    return float(res) if res.ndim == 0 else res
