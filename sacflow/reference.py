"""Closed-form reference solutions (Hertz contact of elastic spheres/ellipsoid-free spheres).

Plain documented functions used by the tests, the schema checks and the comparison stages
(the habit of ContactMechanics ``ReferenceSolutions/Hertz.py``).

Conventions: SI units, contact pressure positive, x3 positive into the body, stress positive in
tension. References: H. Hertz (1882); K. L. Johnson, *Contact Mechanics*, CUP 1985, §4.2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = [
    "HertzContact",
    "composite_modulus",
    "effective_radius",
    "hertz_contact",
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

    @property
    def mean_pressure(self) -> float:
        """Mean pressure W / (π a²) = 2 p0 / 3."""
        return 2.0 * self.p0 / 3.0


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
