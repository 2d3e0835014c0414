r"""A certified largest von Mises stress of elastic field + steady residual field, everywhere.

Melan's optimiser (:mod:`sacflow.mechanics.shakedown`) checks yield at samples only. Its bound
becomes a proof once the largest value of g = σ_vM(σ̂(t, x2, x3) + ρ(x2, x3)) is bounded over
the whole domain: every load offset t = x1 − s ∈ ℝ (the load domain of steady rolling depends
on x1 − s only and ρ not on x1), every x2 and every depth x3 ≥ 0. Then λ = 1/M, M ≥ sup g,
is safe: λ(σ̂ + ρ) stays within yield at every point and load position, and so does λρ alone
(the unloaded state, g as t → ∞).

**Inside a large box** T = [−T, T] × [−W', W'] × [0, D'] the box is split into cells that lie
within one knot cell of the residual field (and on one side of its faces |x2| = L, x3 = D,
where ρ11, ρ22 may jump). On a cell of sides h_k, with q = g² = σ:A:σ (A ≥ 0), the multilinear
interpolant of the corner values is at most the largest of them, and it differs from q by at
most Σ h_k²/8 sup|∂_kk q| (the one-dimensional bound h²/8 |f''| applied along each axis in
turn; interpolation does not raise a maximum). With Cauchy–Schwarz for A,

.. math:: |\partial_{kk} q| \le 2\,\sigma_{vM}(\partial_k\sigma)^2
          + 2\,\sigma_{vM}(\sigma)\,\sigma_{vM}(\partial_{kk}\sigma),

so sup_cell q ≤ max_corners q + Σ_k h_k²/8 (2 S1_k² + 2 S0 S2_k), where S0, S1_k, S2_k bound
σ_vM of σ = σ̂ + ρ and of its first and second derivatives over the cell (σ_vM is a seminorm:
the bounds of σ̂ and ρ add). For ρ they are **proved**: within a knot cell every component is
a polynomial bounded by its B-spline coefficients
(:meth:`~sacflow.mechanics.steady_residual.SteadyResidualField.derivative_bounds`), and the von
Mises stress of a tensor with bounded components is maximised at a corner of the box of
components. For the elastic field they are the largest of the closed form's derivatives
(differences of step :data:`DIFFERENCE_STEP`) at eight points inside the cell
(:data:`DERIVATIVE_POINTS`): σ̂ is smooth below the surface, and what these points miss of its
derivatives enters the bound at third order in the cell size. **This is the one part that is an
estimate, not a proof** (a proof would need bounds of the Hertz fields' derivatives over each
cell, e.g. by interval arithmetic on the closed forms). At the surface, on the contact's edge,
the Hertz field's derivatives are unbounded (the pressure's slope is); there the bound falls
like √h as the cells shrink, and the refinement reaches it because g there is well below the
maximum. Cells whose bound exceeds the target (and the largest g found so far, by more than a
tolerance: no bound can be lower than a value g takes) are split in two along each axis, level
by level; the cells still above it after the last level enter M with their bound.

**Outside that box** a point lies at a distance R ≥ R_c = min(T, W', D') from the contact's
centre. The elastic stress is the superposition of point (line) loads over the contact, and the
von Mises stress is a seminorm, so σ_vM(σ̂) ≤ ∫ p σ_vM(K) ≤ C P/(R − a)^n with the Boussinesq
(n = 2) or Flamant (n = 1) kernel K and its largest von Mises stress C at unit distance
(:func:`far_field_bound`); and σ_vM(ρ) there is at most the certified sup of σ_vM(ρ) over the
half-plane (the same cell bound with σ̂ = 0, proved). Their sum bounds g outside.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from itertools import product
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from sacflow.mechanics.steady_residual import SteadyResidualField
from sacflow.mechanics.stress_measures import von_mises

__all__ = [
    "CertifiedMaximum",
    "breakpoints",
    "certified_maximum",
    "far_field_bound",
    "von_mises_of_bounds",
]

#: Elastic stress per unit peak pressure at points (t, x2, x3) (three arrays) → (n, 6).
ElasticField = Callable[[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]],
                        NDArray[np.float64]]

#: Step of the central differences of the elastic closed forms [contact radii].
DIFFERENCE_STEP = 1e-4
#: Corners are moved this fraction of the cell into it, so that a field that jumps on a cell's
#: face is read from the cell's side; the sliver left out is added to the bound.
CORNER_NUDGE = 1e-9
#: Cells bounded at once (bounds the memory of the field evaluations).
CELL_CHUNK = 8192
#: The elastic field's derivatives are estimated at the 8 points of the cell at these fractions
#: of its sides (inside it: at the contact's edge on the surface, where they are unbounded,
#: a cell corner may sit on the edge).
DERIVATIVE_POINTS = (0.25, 0.75)
#: The largest von Mises stress of Boussinesq's field at unit distance per unit load is
#: reached on the load's axis, (3 + (1 − 2ν)/2)/(2π) (σ_r − σ_z there); a scan of the polar
#: angle shows it for 0 ≤ ν ≤ 0.5 (tests/test_melan.py). This factor covers the scan.
KERNEL_SAFETY = 1.01


def von_mises_of_bounds(bounds: NDArray[np.float64]) -> NDArray[np.float64]:
    """Largest von Mises stress of a tensor with |σ_i| ≤ bounds_i (..., 6): a box corner."""
    b = np.asarray(bounds, dtype=float)
    normal = np.zeros(b.shape[:-1])
    for signs in ((1, 1, 1), (1, 1, -1), (1, -1, 1), (-1, 1, 1)):
        a, c, d = (s * b[..., i] for i, s in enumerate(signs))
        normal = np.maximum(normal, 0.5 * ((a - c) ** 2 + (c - d) ** 2 + (d - a) ** 2))
    return np.asarray(np.sqrt(normal + 3.0 * (b[..., 3:] ** 2).sum(axis=-1)))


def far_field_bound(contact: Literal["point", "line"], nu: float, distance: float) -> float:
    """Bound of σ_vM of the Hertz (p0 = 1, a = 1) field at ``distance`` > 1 from its centre.

    Point contact: load P = 2π/3, Boussinesq's field, σ_vM ≤ C P/(R − 1)² with
    C = (3 + (1 − 2ν)/2)/(2π) (its value on the load's axis, the largest over the polar
    angle) × :data:`KERNEL_SAFETY`. Line contact: P = π/2, Flamant's radial field
    σ_rr = −2P cos θ/(π r) with σ22 = ν σ_rr in plane strain, σ_vM = |σ_rr| √(1 − ν + ν²),
    so σ_vM ≤ √(1 − ν + ν²)/(R − 1). Each point of the contact lies within 1 of its centre.
    """
    if distance <= 1.0:
        raise ValueError("the far field bound needs a distance beyond the contact radius")
    if contact == "line":
        return float(np.sqrt(1.0 - nu + nu * nu) / (distance - 1.0))
    c = (3.0 + 0.5 * (1.0 - 2.0 * nu)) / (2.0 * np.pi) * KERNEL_SAFETY
    return float(c * (2.0 * np.pi / 3.0) / (distance - 1.0) ** 2)


def breakpoints(low: float, high: float, cells: int, outer: float, growth: float
                ) -> NDArray[np.float64]:
    """Cell faces: ``cells`` equal cells on [low, high], then cells growing by ``growth``.

    The growing cells reach out to ``outer`` beyond ``high``, and to −``outer`` below
    ``low`` when ``low`` < 0 (a range across the track; a depth range starts at the surface).
    """
    step = (high - low) / cells
    up = [high]
    h = step
    while up[-1] < outer - 1e-12:
        h *= growth
        up.append(min(up[-1] + h, outer))
    middle = low + step * np.arange(cells + 1)
    if low >= 0.0:
        return np.concatenate([middle, up[1:]])
    down = [low]
    h = step
    while down[-1] > -outer + 1e-12:
        h *= growth
        down.append(max(down[-1] - h, -outer))
    return np.concatenate([down[:0:-1], middle, up[1:]])


@dataclass(frozen=True)
class CertifiedMaximum:
    """Result of :func:`certified_maximum`.

    Attributes
    ----------
    bound : float
        Upper bound of sup g over the cells (module docstring).
    sampled : float
        Largest g at the cells' corners (a value g takes: sup g lies in [sampled, bound]).
    cells : int
        Cells checked, all levels.
    unresolved : int
        Cells of the last level whose bound still exceeded the target.
    """

    bound: float
    sampled: float
    cells: int
    unresolved: int


def _elastic_derivatives(elastic: ElasticField, x: NDArray[np.float64], axes: list[int]
                         ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """σ_vM of the first and second derivatives of σ̂ along ``axes`` at points x (n, 3).

    Central differences; along the depth, forward ones within a step of the surface.
    """
    value = elastic(x[:, 0], x[:, 1], x[:, 2])
    first = np.zeros((x.shape[0], 3))
    second = np.zeros((x.shape[0], 3))
    h = DIFFERENCE_STEP
    for k in axes:
        e = np.zeros(3)
        e[k] = h
        forward = (x[:, 2] < h) if k == 2 else np.zeros(x.shape[0], dtype=bool)
        centre = x + forward[:, None] * e
        before, after = elastic(*(centre - e).T), elastic(*(centre + e).T)
        middle = value.copy()
        if forward.any():
            middle[forward] = elastic(*centre[forward].T)
        slope = np.where(forward[:, None], (-3 * before + 4 * middle - after) / (2 * h),
                         (after - before) / (2 * h))
        first[:, k] = von_mises(slope)
        second[:, k] = von_mises((before - 2 * middle + after) / (h * h))
    return first, second


def _cell_bounds(elastic: ElasticField | None, field: SteadyResidualField,
                 coefficients: NDArray[np.float64], lo: NDArray[np.float64],
                 hi: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Upper bound of g over each cell [lo, hi] (m, 3) and the largest g at its corners."""
    m = lo.shape[0]
    size = hi - lo
    axes = [k for k in range(3) if np.any(size[:, k] > 0)]
    fractions = np.array(list(product((CORNER_NUDGE, 1 - CORNER_NUDGE), repeat=3)))
    corners = (lo[:, None] + size[:, None] * fractions[None]).reshape(-1, 3)
    rho = field.stress_at(coefficients, corners[:, 1], corners[:, 2])
    first = second = np.zeros((m * 8, 3))
    sigma = rho
    if elastic is not None:
        sigma = rho + elastic(*corners.T)
        inner = np.array(list(product(DERIVATIVE_POINTS, repeat=3)))
        points = (lo[:, None] + size[:, None] * inner[None]).reshape(-1, 3)
        first, second = _elastic_derivatives(elastic, points, axes)
    g = von_mises(sigma).reshape(m, 8)
    centre = lo + size / 2
    rho_bounds = von_mises_of_bounds(field.derivative_bounds(coefficients, centre[:, 1],
                                                             centre[:, 2]))
    # S1, S2 along (t, x2, x3): ρ has no t-derivative; DERIVATIVES = (0, ∂2, ∂22, ∂3, ∂33)
    s1 = first.reshape(m, 8, 3).max(axis=1) + np.stack(
        [np.zeros(m), rho_bounds[:, 1], rho_bounds[:, 3]], axis=1)
    s2 = second.reshape(m, 8, 3).max(axis=1) + np.stack(
        [np.zeros(m), rho_bounds[:, 2], rho_bounds[:, 4]], axis=1)
    s0 = g.max(axis=1) + (size / 2 * s1).sum(axis=1)
    q = (g * g).max(axis=1) + (size ** 2 / 8 * (2 * s1 ** 2 + 2 * s0[:, None] * s2)).sum(axis=1)
    q += 2 * s0 * (CORNER_NUDGE * size * s1).sum(axis=1)  # the sliver left by the nudge
    bound = np.sqrt(q)
    return np.where(np.isfinite(bound), bound, np.inf), g.max(axis=1)


def certified_maximum(elastic: ElasticField | None, field: SteadyResidualField,
                      coefficients: NDArray[np.float64],
                      faces: tuple[NDArray[np.float64], NDArray[np.float64],
                                   NDArray[np.float64]],
                      target: float, levels: int, tolerance: float) -> CertifiedMaximum:
    """Bound sup g = σ_vM(σ̂ + ρ) over the box spanned by ``faces`` (module docstring).

    Parameters
    ----------
    elastic : callable or None
        σ̂(t, x2, x3) per unit peak pressure; None for ρ alone.
    field, coefficients : SteadyResidualField, ndarray
        The residual field ρ(x2, x3).
    faces : (ndarray, ndarray, ndarray)
        Cell faces along t, x2, x3 (one face: that coordinate is fixed, e.g. x2 = 0 in plane
        strain). Knots and the residual box's faces must be among them.
    target : float
        Cells whose bound exceeds it are split, up to ``levels`` times (and exceeds the
        largest g found so far by more than ``tolerance``, relative).
    levels : int
        Refinement levels at most.
    tolerance : float
        See ``target``.
    """
    grids = [np.stack([f[:-1], f[1:]], axis=1) if f.size > 1 else np.array([[f[0], f[0]]])
             for f in faces]
    index = np.stack(np.meshgrid(*[np.arange(g.shape[0]) for g in grids], indexing="ij"),
                     axis=-1).reshape(-1, 3)
    lo = np.stack([grids[k][index[:, k], 0] for k in range(3)], axis=1)
    hi = np.stack([grids[k][index[:, k], 1] for k in range(3)], axis=1)
    best, sampled, checked = 0.0, 0.0, 0
    for level in range(levels + 1):
        parts = [_cell_bounds(elastic, field, coefficients, lo[i:i + CELL_CHUNK],
                              hi[i:i + CELL_CHUNK]) for i in range(0, lo.shape[0], CELL_CHUNK)]
        bound = np.concatenate([p[0] for p in parts])
        top = np.concatenate([p[1] for p in parts])
        checked += lo.shape[0]
        sampled = max(sampled, float(top.max()))
        # no bound can fall below a value g takes: refining below that is wasted
        over = bound > max(target, sampled * (1.0 + tolerance))
        best = max(best, float(bound[~over].max(initial=0.0)))
        if not over.any() or level == levels:
            break
        lo, hi = _split(lo[over], hi[over])
    unresolved = int(over.sum())
    if unresolved:
        best = max(best, float(bound[over].max()))
    return CertifiedMaximum(bound=best, sampled=sampled, cells=checked, unresolved=unresolved)


def _split(lo: NDArray[np.float64], hi: NDArray[np.float64]
           ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Halve every cell along each axis of non-zero size (8, 4 or 2 children)."""
    mid = (lo + hi) / 2
    out_lo, out_hi = [], []
    for choice in product((0, 1), repeat=3):
        pick = np.array(choice, dtype=bool)[None] & (hi > lo)
        out_lo.append(np.where(pick, mid, lo))
        out_hi.append(np.where(pick | (hi == lo), hi, mid))
    keep = np.concatenate([np.ones(lo.shape[0], dtype=bool)]
                          + [np.all((np.array(c, dtype=bool)[None] <= (hi > lo)), axis=1)
                             for c in list(product((0, 1), repeat=3))[1:]])
    return np.concatenate(out_lo)[keep], np.concatenate(out_hi)[keep]
