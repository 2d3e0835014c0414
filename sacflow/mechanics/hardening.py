"""Hardening laws of von Mises plasticity: isotropic σ_Y(p) and the kinematic backstress law.

Conventions
-----------
* SI units; ``equivalent_plastic_strain`` is the accumulated equivalent plastic strain
  p = ∫ sqrt(2/3 dεp:dεp), a plain (dimensionless) strain. The seed's Swift parameters use p in
  micro-strain; :class:`SwiftHardening` converts (``strain_unit``).
* ``depth`` (x3 [m], positive into the body) must broadcast against the plastic strain; only
  :class:`DepthScaledHardening` uses it.

Isotropic hardening: seed eq. (3.1) (Jacq et al., ASME J. Tribol. 124 (2002) 653,
doi:10.1115/1.1467920); σ_Y must be positive and non-decreasing in p, which every law checks of
its parameters at construction (a ``ValueError`` naming the law, the field, the rule and the
value). These are the rules of the case schema's hardening models (:mod:`sacflow.config.schema`),
which validate a case before it reaches here. Kinematic hardening: one Armstrong–Frederick
backstress (:class:`KinematicLaw`; Chaboche 1989, Lemaitre & Chaboche 1990 §5.4).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["STRAIN_SCALES", "DepthScaledHardening", "HardeningLaw", "KinematicLaw",
           "LinearHardening", "NoPlasticity", "PerfectPlasticity", "SwiftHardening",
           "TabularHardening"]

FloatArray = NDArray[np.float64]

#: Scale s of εp in the Swift law σ_Y = B (C + s εp)^n, per ``strain_unit``.
STRAIN_SCALES = {"microstrain": 1e6, "strain": 1.0}
#: What a tabular curve does beyond its last point (:class:`TabularHardening`).
BEYOND_LAST = ("constant", "extrapolate")


def invalid(what: str, field: str, rule: str, value: object) -> ValueError:
    """Return the error of a law parameter: ``what: field 'name': rule; got value``."""
    return ValueError(f"{what}: field {field!r}: {rule}; got {value!r:.60}")


def checked_number(what: str, field: str, value: object, low: float,
                   strict: bool = True) -> float:
    """Return ``value`` as a finite float above ``low`` (``>= low`` when not ``strict``)."""
    try:
        number = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise invalid(what, field, "must be a number", value) from None
    bound = f"> {low:g}" if strict else f">= {low:g}"
    if not math.isfinite(number) or not (number > low if strict else number >= low):
        raise invalid(what, field, f"must be a finite number {bound}", value)
    return number


def checked_points(what: str, field: str, values: ArrayLike, low: float, strict: bool,
                   least: int) -> FloatArray:
    """Return ``values`` as a 1-D float array of at least ``least`` finite numbers above ``low``."""
    points = [checked_number(what, f"{field}[{i}]", v, low, strict)
              for i, v in enumerate(np.asarray(values, dtype=object).reshape(-1))]
    if np.ndim(values) != 1 or len(points) < least:
        raise invalid(what, field, f"must be a list of at least {least} numbers", values)
    return np.array(points)


def strictly_increasing(values: FloatArray) -> bool:
    """Whether every value is larger than the one before."""
    return bool(np.all(np.diff(values) > 0.0))


class HardeningLaw(ABC):
    """Isotropic hardening law σ_Y(p) (seed eq. (3.1)); σ_Y must be positive and nondecreasing."""

    @abstractmethod
    def yield_stress(self, equivalent_plastic_strain: ArrayLike,
                     depth: ArrayLike | None = None) -> FloatArray:
        """Return σ_Y(p) [Pa] for the equivalent plastic strain p (dimensionless)."""

    @abstractmethod
    def slope(self, equivalent_plastic_strain: ArrayLike,
              depth: ArrayLike | None = None) -> FloatArray:
        """Return dσ_Y/dp [Pa] (right derivative at kinks)."""

    def yield_and_slope(self, equivalent_plastic_strain: ArrayLike,
                        depth: ArrayLike | None = None) -> tuple[FloatArray, FloatArray]:
        """Return ``(yield_stress, slope)``; laws override it to share work."""
        return (self.yield_stress(equivalent_plastic_strain, depth),
                self.slope(equivalent_plastic_strain, depth))


class JointHardeningLaw(HardeningLaw):
    """A law whose ``yield_and_slope`` is primary: yield stress and slope taken from it."""

    @abstractmethod
    def yield_and_slope(self, equivalent_plastic_strain: ArrayLike,
                        depth: ArrayLike | None = None) -> tuple[FloatArray, FloatArray]:
        """Return ``(yield_stress, slope)`` in one pass."""

    def yield_stress(self, equivalent_plastic_strain: ArrayLike,
                     depth: ArrayLike | None = None) -> FloatArray:
        """Return σ_Y(p) [Pa] (from :meth:`yield_and_slope`)."""
        return self.yield_and_slope(equivalent_plastic_strain, depth)[0]

    def slope(self, equivalent_plastic_strain: ArrayLike,
              depth: ArrayLike | None = None) -> FloatArray:
        """Return dσ_Y/dp [Pa] (from :meth:`yield_and_slope`)."""
        return self.yield_and_slope(equivalent_plastic_strain, depth)[1]


class SwiftHardening(JointHardeningLaw):
    """Swift law σ_Y = B (C + s p)^n, s = 1e6 for ``strain_unit="microstrain"`` (seed eq. (3.1)).

    The seed's bearing steel (B = 1240 MPa, C = 30, n = 0.085, micro-strain) has
    σ_Y0 = B C^n ≈ 1655.7 MPa. B > 0, C > 0, 0 < n < 1 and B C^n a finite positive stress;
    a ``ValueError`` names the field otherwise.
    """

    def __init__(self, B: float, C: float, n: float, strain_unit: str = "microstrain"):
        what = "hardening law 'swift'"
        self.B = checked_number(what, "B", B, 0.0)
        self.C = checked_number(what, "C", C, 0.0)
        self.n = checked_number(what, "n", n, 0.0)
        if not self.n < 1.0:
            raise invalid(what, "n", "must be < 1", n)
        if strain_unit not in STRAIN_SCALES:
            raise invalid(what, "strain_unit", f"must be one of {list(STRAIN_SCALES)}",
                          strain_unit)
        initial = self.B * self.C**self.n
        if not 0.0 < initial < math.inf:
            raise invalid(what, "B", f"the initial yield stress B C^n = {initial:g} Pa is not "
                          "a finite positive stress; check the magnitudes of B [Pa] and C", B)
        self.scale = STRAIN_SCALES[strain_unit]

    def yield_and_slope(self, equivalent_plastic_strain: ArrayLike,
                        depth: ArrayLike | None = None) -> tuple[FloatArray, FloatArray]:
        """Return σ_Y = B (C + s p)^n and its slope n s σ_Y / (C + s p) in one pass."""
        base = self.C + self.scale * np.asarray(equivalent_plastic_strain, dtype=float)
        y = self.B * base**self.n
        return y, (self.n * self.scale) * y / base

    def yield_stress(self, equivalent_plastic_strain: ArrayLike,
                     depth: ArrayLike | None = None) -> FloatArray:
        """Return B (C + s p)^n."""
        base = self.C + self.scale * np.asarray(equivalent_plastic_strain, dtype=float)
        y: FloatArray = self.B * base**self.n
        return y


class LinearHardening(HardeningLaw):
    """Linear hardening σ_Y = σ_Y0 + H p (σ_Y0 > 0, H >= 0)."""

    def __init__(self, yield_stress: float, modulus: float):
        what = "hardening law 'linear'"
        self.initial_yield_stress = checked_number(what, "yield_stress", yield_stress, 0.0)
        self.modulus = checked_number(what, "modulus", modulus, 0.0, strict=False)

    def yield_stress(self, equivalent_plastic_strain: ArrayLike,
                     depth: ArrayLike | None = None) -> FloatArray:
        """Return σ_Y0 + H p."""
        y: FloatArray = (self.initial_yield_stress
                         + self.modulus * np.asarray(equivalent_plastic_strain, dtype=float))
        return y

    def slope(self, equivalent_plastic_strain: ArrayLike,
              depth: ArrayLike | None = None) -> FloatArray:
        """Return H everywhere."""
        return np.full(np.shape(equivalent_plastic_strain), self.modulus)


class PerfectPlasticity(LinearHardening):
    """Perfect plasticity σ_Y = σ_Y0 > 0 (no hardening)."""

    def __init__(self, yield_stress: float):
        what = "hardening law 'perfectly_plastic'"
        self.initial_yield_stress = checked_number(what, "yield_stress", yield_stress, 0.0)
        self.modulus = 0.0


class NoPlasticity(HardeningLaw):
    """An elastic body: σ_Y = +inf (never yields), slope 0."""

    def yield_stress(self, equivalent_plastic_strain: ArrayLike,
                     depth: ArrayLike | None = None) -> FloatArray:
        """Return +inf everywhere (never yields)."""
        return np.full(np.shape(equivalent_plastic_strain), np.inf)

    def slope(self, equivalent_plastic_strain: ArrayLike,
              depth: ArrayLike | None = None) -> FloatArray:
        """Return 0 everywhere."""
        return np.zeros(np.shape(equivalent_plastic_strain))


class TabularHardening(JointHardeningLaw):
    """Piecewise-linear measured curve through (``plastic_strain``, ``stress``) points.

    Strains from 0, strictly increasing (finite slopes); stresses positive and non-decreasing,
    one per strain. Beyond the last point the curve stays at the last stress with slope 0
    (``beyond_last="constant"``, default) or continues with the last segment's slope
    (``"extrapolate"``); the return mapping's hardening modulus follows. At kinks ``slope``
    returns the slope of the segment on the right.
    """

    def __init__(self, plastic_strain: ArrayLike, stress: ArrayLike,
                 beyond_last: str = "constant"):
        what = "hardening law 'tabular'"
        self.strain = checked_points(what, "plastic_strain", plastic_strain, 0.0, False, 2)
        self.stress = checked_points(what, "stress", stress, 0.0, True, 2)
        if self.stress.size != self.strain.size:
            raise invalid(what, "stress", "must have one value per plastic_strain point", stress)
        if self.strain[0] != 0.0:
            raise invalid(what, "plastic_strain", "must start at 0 (the initial yield point)",
                          plastic_strain)
        if not strictly_increasing(self.strain):
            raise invalid(what, "plastic_strain", "must be strictly increasing", plastic_strain)
        if np.any(np.diff(self.stress) < 0.0):
            raise invalid(what, "stress", "must be non-decreasing (no softening)", stress)
        with np.errstate(over="ignore"):
            self.slopes = np.diff(self.stress) / np.diff(self.strain)
        if not np.all(np.isfinite(self.slopes)):
            i = int(np.flatnonzero(~np.isfinite(self.slopes))[0])
            raise invalid(what, "plastic_strain", f"points {i} and {i + 1} are too close for "
                          "their stress rise: the hardening slope is not a finite number; space "
                          "them further apart", plastic_strain)
        if beyond_last not in BEYOND_LAST:
            raise invalid(what, "beyond_last", f"must be one of {list(BEYOND_LAST)}", beyond_last)
        self.beyond_last = beyond_last

    def yield_and_slope(self, equivalent_plastic_strain: ArrayLike,
                        depth: ArrayLike | None = None) -> tuple[FloatArray, FloatArray]:
        """Return the interpolated stress and the slope of the segment on the right."""
        p = np.asarray(equivalent_plastic_strain, dtype=float)
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


class DepthScaledHardening(JointHardeningLaw):
    """σ_Y(p, x3) = factor(x3) · law(p): factor piecewise linear in depth, constant beyond ends.

    For surface-hardened steels (the seed's stated next step); ``depth`` is then required.
    Depths finite, >= 0 and strictly increasing; factors finite and > 0, one per depth.
    """

    def __init__(self, law: HardeningLaw, depth: Sequence[float] | FloatArray,
                 factor: Sequence[float] | FloatArray):
        what = "depth profile"
        self.law = law
        self.depth = checked_points(what, "depth", depth, 0.0, False, 1)
        self.factor = checked_points(what, "factor", factor, 0.0, True, 1)
        if self.factor.size != self.depth.size:
            raise invalid(what, "factor", "must have one value per depth", factor)
        if not strictly_increasing(self.depth):
            raise invalid(what, "depth", "must be strictly increasing", depth)

    def scale(self, depth: ArrayLike | None) -> FloatArray:
        """Return the factor at ``depth`` [m]."""
        if depth is None:
            raise ValueError("DepthScaledHardening needs the depth x3 of every point")
        factor: FloatArray = np.interp(np.asarray(depth, dtype=float), self.depth, self.factor)
        return factor

    def yield_and_slope(self, equivalent_plastic_strain: ArrayLike,
                        depth: ArrayLike | None = None) -> tuple[FloatArray, FloatArray]:
        """Return factor(x3) times the law's yield stress and slope."""
        y, h = self.law.yield_and_slope(equivalent_plastic_strain, depth)
        f = self.scale(depth)
        return f * y, f * h


@dataclass(frozen=True)
class KinematicLaw:
    """Armstrong–Frederick backstress: modulus C [Pa], dynamic recall γ (0: Prager–Ziegler).

    dX = 2/3 C dεp − γ X dp (:mod:`sacflow.mechanics.return_mapping` integrates it).
    """

    modulus: float
    recall: float = 0.0

    def __post_init__(self) -> None:
        """Refuse a negative modulus or recall."""
        if not (self.modulus >= 0.0 and self.recall >= 0.0):
            raise ValueError(f"kinematic hardening needs C >= 0 and gamma >= 0, got "
                             f"C = {self.modulus}, gamma = {self.recall}")
