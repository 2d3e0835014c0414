"""Closed-form reference solutions: Hertz contact of spheres, its surface and subsurface fields.

Plain documented functions used by the tests, the schema checks and the comparison stages
(the habit of ContactMechanics ``ReferenceSolutions/Hertz.py``).

Conventions: SI units, contact pressure positive, x3 positive into the body, stress positive in
tension, normal displacement positive into the body; (..., 6) stress arrays in the component
order (11, 22, 33, 12, 13, 23).

References
----------
* H. Hertz, "Über die Berührung fester elastischer Körper", J. reine angew. Math. 92 (1882) 156.
* M. T. Huber, "Zur Theorie der Berührung fester elastischer Körper", Ann. Phys. 319 (1904) 153.
* K. L. Johnson, *Contact Mechanics*, CUP 1985, §3.4 (eqs. 3.41–3.45) and §4.2.
* G. M. Hamilton, "Explicit equations for the stresses beneath a sliding spherical contact",
  Proc. IMechE 197C (1983) 53.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "HertzContact",
    "composite_modulus",
    "effective_radius",
    "first_yield",
    "hertz_axis_stress",
    "hertz_contact",
    "hertz_pressure",
    "hertz_subsurface_stress",
    "hertz_surface_displacement",
    "line_contact_stress",
]


def composite_modulus(E1: float, nu1: float, E2: float | None = None, nu2: float = 0.0) -> float:
    """Return the contact modulus E* with 1/E* = (1-ν1²)/E1 + (1-ν2²)/E2 (Johnson eq. 4.22).

    ``E2=None`` (or ``inf``) stands for a rigid counter-body.
    """
    inv = (1.0 - nu1**2) / E1
    if E2 is not None and math.isfinite(E2):
        inv += (1.0 - nu2**2) / E2
    return 1.0 / inv


def effective_radius(*radii: float) -> float:
    """Return R with 1/R = Σ 1/R_i; infinite radii (flat bodies) contribute nothing."""
    curvature = sum(1.0 / r for r in radii if math.isfinite(r))
    if curvature <= 0.0:
        raise ValueError("at least one body must be curved (finite positive radius)")
    return 1.0 / curvature


@dataclass(frozen=True)
class HertzContact:
    """Hertz circular contact: radius ``a`` [m], peak pressure ``p0`` [Pa], approach [m]."""

    load: float
    radius: float
    e_star: float
    a: float
    p0: float
    approach: float


def hertz_contact(load: float, radius: float, e_star: float) -> HertzContact:
    """Hertz sphere-on-flat contact (Johnson eqs. 4.22–4.25).

    a = (3 W R / 4 E*)^(1/3), p0 = 3 W / (2 π a²), δ = a² / R.

    Parameters
    ----------
    load : float
        Normal load W [N], ≥ 0.
    radius : float
        Effective radius of curvature R [m].
    e_star : float
        Contact modulus E* [Pa].
    """
    if load < 0:
        raise ValueError("load must be non-negative")
    a = (3.0 * load * radius / (4.0 * e_star)) ** (1.0 / 3.0)
    p0 = 3.0 * load / (2.0 * math.pi * a**2) if a > 0 else 0.0
    return HertzContact(load, radius, e_star, a, p0, a**2 / radius)


def hertz_pressure(r: ArrayLike, a: float, p0: float) -> NDArray[np.float64]:
    """Hertz pressure p = p0 (1 - r²/a²)^½ for r < a, 0 outside (Johnson eq. 3.39 / 4.23).

    Parameters
    ----------
    r : array_like
        Distance from the contact centre [m].
    a : float
        Contact radius [m].
    p0 : float
        Peak pressure [Pa].

    Returns
    -------
    ndarray
        Pressure [Pa], shape of ``r``.
    """
    r = np.asarray(r, dtype=np.float64)
    return p0 * np.sqrt(np.clip(1.0 - (r / a) ** 2, 0.0, None))


def hertz_surface_displacement(
    r: ArrayLike, a: float, p0: float, e_star: float
) -> NDArray[np.float64]:
    r"""Compute the normal surface displacement of the Hertz pressure (Johnson eqs. 3.41a, 3.42a).

    Sum of both bodies' displacements (through E*), positive into the bodies:

    .. math::

        u_3 &= \frac{\pi p_0}{4 a E^*}(2a^2 - r^2), & r \le a, \\
        u_3 &= \frac{p_0}{2 a E^*}\left[(2a^2 - r^2)\arcsin\frac{a}{r}
               + a\sqrt{r^2 - a^2}\right], & r > a.

    With p0 = 2 a E*/(π R) the centre value is the approach δ = a²/R and inside the contact
    u3 = δ − r²/(2R), i.e. the surfaces conform.  For one body alone use E* = E/(1 − ν²).

    Parameters
    ----------
    r : array_like
        Distance from the contact centre [m].
    a : float
        Contact radius [m].
    p0 : float
        Peak pressure [Pa].
    e_star : float
        Contact modulus E* [Pa] (see :func:`composite_modulus`).

    Returns
    -------
    ndarray
        Normal displacement [m], shape of ``r``.
    """
    r = np.abs(np.asarray(r, dtype=np.float64))
    inside = np.pi * p0 * (2.0 * a * a - r * r) / (4.0 * a * e_star)
    ro = np.maximum(r, a)
    outside = (p0 / (2.0 * a * e_star)) * (
        (2.0 * a * a - ro * ro) * np.arcsin(a / ro) + a * np.sqrt(ro * ro - a * a)
    )
    return np.where(r <= a, inside, outside)


def hertz_subsurface_stress(
    x1: ArrayLike, x2: ArrayLike, x3: ArrayLike, a: float, p0: float, nu: float
) -> NDArray[np.float64]:
    r"""Full stress field of the Hertz pressure in a half-space (Huber 1904; Johnson eq. 3.44).

    In cylindrical coordinates (r, θ, z = x3), with u the positive root of
    r²/(a² + u) + z²/u = 1 and t = z/√u,

    .. math::

        \frac{\sigma_r}{p_0} &= \frac{1-2\nu}{3}\frac{a^2}{r^2}(1 - t^3)
            + t^3\frac{a^2 u}{u^2 + a^2 z^2}
            + t\left[\frac{(1-\nu) u}{a^2 + u} + (1+\nu)\frac{\sqrt u}{a}
              \arctan\frac{a}{\sqrt u} - 2\right], \\
        \frac{\sigma_\theta}{p_0} &= -\frac{1-2\nu}{3}\frac{a^2}{r^2}(1 - t^3)
            - t\left[2\nu + \frac{(1-\nu) u}{a^2 + u} - (1+\nu)\frac{\sqrt u}{a}
              \arctan\frac{a}{\sqrt u}\right], \\
        \frac{\sigma_z}{p_0} &= -t^3\frac{a^2 u}{u^2 + a^2 z^2}, \qquad
        \frac{\tau_{rz}}{p_0} = -\frac{r z^2}{u^2 + a^2 z^2}\frac{a^2\sqrt u}{a^2 + u},

    rotated to Cartesian components.  (The sign of the bracket in σθ is the one that gives
    σθ = σr on the axis and Johnson's surface values, eq. 3.43; the whole field is checked in the
    tests against quadrature of Boussinesq's point-load stresses.)  The evaluation uses
    cancellation-free forms: with s = r² + z² − a², D = (s² + 4a²z²)^½, c = a² + z² − r²,
    u = (D + s)/2 = 2a²z²/(D − s), t² = (D − s)/(2a²), u² + a²z² = uD and
    (1 − t²)/r² = 2t²/(D + c), so the axis r = 0 and the surface z = 0 need no special case.

    Parameters
    ----------
    x1, x2 : array_like
        Lateral coordinates relative to the contact centre [m].
    x3 : array_like
        Depth [m], >= 0.  All coordinate arrays broadcast.
    a : float
        Contact radius [m].
    p0 : float
        Peak pressure [Pa].
    nu : float
        Poisson's ratio of the body.

    Returns
    -------
    ndarray, shape (..., 6)
        Stress [Pa] in the order (11, 22, 33, 12, 13, 23), tension positive.

    Raises
    ------
    ValueError
        If any x3 < 0.
    """
    x1, x2, z = (np.asarray(v, dtype=np.float64) for v in (x1, x2, x3))
    if np.any(z < 0.0):
        raise ValueError("x3 is the depth below the surface and must be >= 0")
    x1, x2, z = np.broadcast_arrays(x1, x2, z)
    a2 = a * a
    r2 = x1 * x1 + x2 * x2
    z2 = z * z
    s = r2 + z2 - a2
    c = a2 + z2 - r2
    D = np.sqrt(s * s + 4.0 * a2 * z2)
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.where(s >= 0.0, 0.5 * (D + s), 2.0 * a2 * z2 / np.where(s < 0.0, D - s, 1.0))
        t2 = np.where(s <= 0.0, 0.5 * (D - s), 2.0 * a2 * z2 / np.where(s > 0.0, D + s, 1.0)) / a2
        t = np.sqrt(t2)
        # A = (a²/r²)(1 - t³), finite on the axis
        one_minus_t2_over_r2 = np.where(
            c > 0.0, 2.0 * t2 / np.where(c > 0.0, D + c, 1.0), (1.0 - t2) / np.where(c > 0, 1, r2)
        )
        A = a2 * one_minus_t2_over_r2 * (1.0 + t + t2) / (1.0 + t)
        Dsafe = np.where(D > 0.0, D, 1.0)
        B = np.where(D > 0.0, t2 * t * a2 / Dsafe, 0.0)  # t³ a²u/(u² + a²z²)
        su = np.sqrt(u)
        g = su / a * np.arctan2(a, su)
        h = (1.0 - nu) * u / (a2 + u)
        k = (1.0 - 2.0 * nu) / 3.0
        sig_r = k * A + B + t * (h + (1.0 + nu) * g - 2.0)
        sig_t = -k * A - t * (2.0 * nu + h - (1.0 + nu) * g)
        sig_z = -B
        tau_over_r = np.where(D > 0.0, -z * t * a2 / (Dsafe * (a2 + u)), 0.0)  # τ_rz / r
        cos2 = np.where(r2 > 0.0, x1 * x1 / np.where(r2 > 0.0, r2, 1.0), 1.0)
        sincos = np.where(r2 > 0.0, x1 * x2 / np.where(r2 > 0.0, r2, 1.0), 0.0)
    diff = sig_r - sig_t
    out = np.empty((*x1.shape, 6))
    out[..., 0] = sig_t + diff * cos2
    out[..., 1] = sig_r - diff * cos2
    out[..., 2] = sig_z
    out[..., 3] = diff * sincos
    out[..., 4] = tau_over_r * x1
    out[..., 5] = tau_over_r * x2
    return p0 * out


def hertz_axis_stress(
    x3: ArrayLike, a: float, p0: float, nu: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    r"""Stresses on the axis of a Hertz contact (Johnson eq. 3.45).

    .. math::

        \frac{\sigma_r}{p_0} = \frac{\sigma_\theta}{p_0}
          = -(1+\nu)\left[1 - \frac{z}{a}\arctan\frac{a}{z}\right]
            + \frac{1}{2}\left(1 + \frac{z^2}{a^2}\right)^{-1}, \qquad
        \frac{\sigma_z}{p_0} = -\left(1 + \frac{z^2}{a^2}\right)^{-1}.

    Parameters
    ----------
    x3 : array_like
        Depth [m], >= 0.
    a, p0, nu : float
        Contact radius [m], peak pressure [Pa], Poisson's ratio.

    Returns
    -------
    sigma_r, sigma_z : ndarray
        Radial (= hoop) and axial stress [Pa], shape of ``x3``.
    """
    zeta = np.asarray(x3, dtype=np.float64) / a
    q = 1.0 / (1.0 + zeta * zeta)
    sigma_r = -(1.0 + nu) * (1.0 - zeta * np.arctan2(1.0, zeta)) + 0.5 * q
    return p0 * sigma_r, -p0 * q


def line_contact_stress(
    x1: ArrayLike, x3: ArrayLike, a: float, p0: float, nu: float
) -> NDArray[np.float64]:
    r"""Plane-strain stress field of a Hertz line contact of half-width ``a`` (McEwen 1949).

    E. McEwen, "Stresses in elastic cylinders in contact along a generatrix", Phil. Mag. 40
    (1949) 454, with z = x3, x = x1:

    .. math::

        \sigma_{11} &= -\frac{p_0}{a}\left[m\left(1 + \frac{x_3^2 + n^2}{m^2 + n^2}\right)
            - 2x_3\right], \qquad
        \sigma_{33} = -\frac{p_0}{a}\, m\left(1 - \frac{x_3^2 + n^2}{m^2 + n^2}\right), \\
        \sigma_{13} &= -\frac{p_0}{a}\, n\,\frac{m^2 - x_3^2}{m^2 + n^2}, \qquad
        \sigma_{22} = \nu(\sigma_{11} + \sigma_{33}),

    with :math:`m^2, n^2 = \tfrac12\bigl[\sqrt{(a^2 - x_1^2 + x_3^2)^2 + 4x_1^2x_3^2}
    \pm (a^2 - x_1^2 + x_3^2)\bigr]`, m ≥ 0 and n of the sign of x1. The sign of σ13 is that
    of this module's convention (x3 into the body; the tests check the whole field against
    quadrature of Flamant's line-load stresses).

    Parameters
    ----------
    x1 : array_like
        Coordinate across the contact, relative to its centre [m].
    x3 : array_like
        Depth [m], >= 0. Broadcasts with ``x1``.
    a, p0, nu : float
        Contact half-width [m], peak pressure [Pa], Poisson's ratio.

    Returns
    -------
    ndarray, shape (..., 6)
        Stress [Pa] in the order (11, 22, 33, 12, 13, 23); σ12 = σ23 = 0.
    """
    x, z = np.broadcast_arrays(np.asarray(x1, dtype=np.float64), np.asarray(x3, dtype=np.float64))
    if np.any(z < 0.0):
        raise ValueError("x3 is the depth below the surface and must be >= 0")
    c = a * a - x * x + z * z
    root = np.sqrt(c * c + 4.0 * x * x * z * z)
    m = np.sqrt(0.5 * (root + c))
    n = np.sign(x) * np.sqrt(np.maximum(0.5 * (root - c), 0.0))
    ratio = (z * z + n * n) / (m * m + n * n)
    out = np.zeros((*x.shape, 6))
    out[..., 0] = -(m * (1.0 + ratio) - 2.0 * z)
    out[..., 2] = -m * (1.0 - ratio)
    out[..., 4] = -n * (m * m - z * z) / (m * m + n * n)
    out[..., 1] = nu * (out[..., 0] + out[..., 2])
    return (p0 / a) * out


def first_yield(nu: float) -> tuple[float, float, float]:
    """Onset of von Mises yield under a Hertz sphere contact, from the on-axis field.

    On the axis σr = σθ and there is no shear, so σ_vM = |σr − σz|; its maximum over depth
    (Johnson §6.2: 0.62 p0 at z ≈ 0.48 a for ν = 0.3) sets the first-yield peak pressure
    p0 = σ_Y / max(σ_vM/p0).  For the usual range of ν (the tests check ν = 0.3 on a 2-D grid)
    the on-axis maximum is the global maximum of the field.

    Parameters
    ----------
    nu : float
        Poisson's ratio.

    Returns
    -------
    p0_over_sy : float
        Peak pressure at first yield over the yield stress (≈ 1.60 for ν = 0.3).
    depth_over_a : float
        Depth of first yield over the contact radius (≈ 0.48).
    vm_over_p0 : float
        Maximum von Mises stress over p0 (≈ 0.62).
    """
    from scipy.optimize import minimize_scalar  # lazily: slow to import, only needed here

    def neg_vm(zeta: float) -> float:
        sr, sz = hertz_axis_stress(zeta, 1.0, 1.0, nu)
        return -abs(float(sr - sz))

    res = minimize_scalar(neg_vm, bounds=(1e-6, 5.0), method="bounded", options={"xatol": 1e-12})
    vm = -float(res.fun)
    return 1.0 / vm, float(res.x), vm
