r"""Melan's static shakedown theorem for steady rolling: a lower bound with its residual field.

The load domain of steady free rolling over a long track is the elastic stress field of the
contact at every position s of the load along x1, σ̂(x1 − s, x2, x3) per unit peak pressure,
and the unloaded state. Melan's theorem (Melan 1938; Johnson, *Contact Mechanics*, 1985,
§9.3): an elastic–perfectly plastic body shakes down at the load factor λ (peak pressure
λ, from any initial state) if there is a time-independent self-equilibrated residual stress ρ,
traction-free on the surface, with

.. math:: \sigma_{vM}\bigl(\lambda\,\hat\sigma(x_1 - s, x_2, x_3) + \rho\bigr) \le \sigma_Y
          \quad\text{for every point and every } s,

and (with Koiter's kinematic theorem bounding it from above) the largest such λ is the
shakedown limit. The load domain does not change under a shift
of x1 and the yield condition is convex, so averaging a safe ρ over its shifts gives a safe ρ
that does not depend on x1: the search runs over fields ρ(x2, x3) of the half-plane. With
∂/∂x1 = 0 the equilibrium equations and the traction-free surface x3 = 0 are solved exactly by
three stress functions:

.. math::

    \rho_{11} = s, \qquad
    \rho_{12} = \partial_3\psi,\ \rho_{13} = -\partial_2\psi \quad (\psi = 0 \text{ on } x_3 = 0),

    \rho_{22} = \partial_{33}\phi,\ \rho_{33} = \partial_{22}\phi,\ \rho_{23} = -\partial_{23}\phi
    \quad (\phi = \partial_3\phi = 0 \text{ on } x_3 = 0).

No compatibility is asked (Melan's theorem does not need it). Here s, ψ and φ are tensor
products of clamped cubic B-splines on the box |x2| ≤ L, 0 ≤ x3 ≤ D; ψ, φ and ∂φ vanish on the
box's far edges as well, so ρ is zero outside the box and self-equilibrated in the whole
half-space, exactly: the stress functions are differentiated in closed form, not by differences.
To these the ``"full"`` class adds ρ11(x3) and ρ22(x3), functions of depth only, which are
admissible in a body of unbounded width (φ = φ(x3)); the ``"depth"`` class is that part alone.

The largest von Mises stress over the samples is minimised over the spline coefficients; the
maximum is smoothed by a log-sum-exp of the squared von Mises stress with a rising sharpness,
each stage minimised by L-BFGS. Whatever the optimiser reaches, the field it returns is
self-equilibrated and its largest von Mises stress is evaluated exactly at every sample: the
bound σ_Y / max σ_vM is a lower bound of the shakedown limit (to the sampling of the load
positions and points), never an extrapolation. A better optimiser or a richer basis can only
raise it.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Literal

import numpy as np
from numpy.typing import NDArray
from scipy.interpolate import BSpline
from scipy.optimize import minimize

from sacflow.kernels.convolution import Convolution
from sacflow.kernels.shear import surface_load_stress_coefficients
from sacflow.mechanics.hertz import hertz_subsurface_stress, line_contact_stress

__all__ = [
    "MelanBound",
    "SteadyResidualField",
    "melan_bound",
    "moving_pressure_bound",
    "pressure_stress",
    "rolling_shakedown_bound",
]

#: Sharpness of the smoothed maximum (log-sum-exp of the squared von Mises stress over its
#: largest value), raised stage by stage; each stage starts from the last one's coefficients.
SHARPNESS_STAGES: tuple[float, ...] = (10.0, 30.0, 100.0, 300.0, 1e3, 3e3, 1e4, 3e4)
#: Stages of the whole class started from the depth-only optimum (already near the sharp end).
WARM_STAGES: tuple[float, ...] = SHARPNESS_STAGES[3:]
#: L-BFGS iteration limit of one stage.
STAGE_MAX_ITERATIONS = 3000
#: L-BFGS memory (correction pairs).
LBFGS_MEMORY = 30
#: Degree of the B-splines of the stress functions (cubic: ρ continuous).
SPLINE_DEGREE = 3

FieldClass = Literal["full", "depth"]


def _spline_basis(
    low: float, high: float, intervals: int, points: NDArray[np.float64],
    drop_low: int, drop_high: int,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Clamped cubic B-splines on [low, high] at ``points``: values, first, second derivatives.

    ``drop_low`` (``drop_high``) basis functions are removed at the low (high) end: 1 makes
    every combination vanish there, 2 also its first derivative (on a clamped knot vector only
    the first k of them are non-zero or have a non-zero derivative at the end).
    """
    step = (high - low) / intervals
    knots = np.concatenate([
        np.full(SPLINE_DEGREE, low), low + step * np.arange(intervals + 1),
        np.full(SPLINE_DEGREE, high),
    ])
    count = knots.size - SPLINE_DEGREE - 1
    spline = BSpline(knots, np.eye(count), SPLINE_DEGREE, extrapolate=False)
    keep = slice(drop_low, count - drop_high)
    out = []
    for order in range(3):
        f = spline if order == 0 else spline.derivative(order)
        out.append(np.nan_to_num(f(points))[:, keep])  # outside the box: zero
    return out[0], out[1], out[2]


class SteadyResidualField:
    """Self-equilibrated residual stress ρ(x2, x3), independent of x1, on sample points.

    The coefficient vector holds, in order: the depth-only part ρ11(x3), ρ22(x3) (splines on
    [0, depth], free at both ends: admissible in a body of unbounded width), then, for
    ``"full"``, the stress functions s, φ, ψ of the box (module docstring). So the ``"full"``
    class contains the ``"depth"`` class, and a ``"depth"`` solution padded with zeros is a
    ``"full"`` one (:meth:`extend`).

    Parameters
    ----------
    x2, x3 : ndarray
        Sample coordinates (1-D, any units, x3 ≥ 0 the depth).
    half_width, depth : float
        The box |x2| ≤ half_width, 0 ≤ x3 ≤ depth outside which the box part vanishes; the
        depth-only part vanishes below ``depth``.
    intervals : (int, int)
        Knot intervals of the splines along x2 and x3.
    kind : {"full", "depth"}
        The whole class of the module docstring, or ρ11(x3), ρ22(x3) only.
    """

    def __init__(self, x2: NDArray[np.float64], x3: NDArray[np.float64], half_width: float,
                 depth: float, intervals: tuple[int, int], kind: FieldClass = "full") -> None:
        self.kind = kind
        self.points = (len(x2), len(x3))
        n2, n3 = intervals
        self._z_free = _spline_basis(0.0, depth, n3, x3, 0, 0)
        nz = self._z_free[0].shape[1]
        self.shapes = [(1, nz), (1, nz)]
        if kind == "full":
            self._y_free = _spline_basis(-half_width, half_width, n2, x2, 0, 0)
            self._y_phi = _spline_basis(-half_width, half_width, n2, x2, 2, 2)
            self._z_phi = _spline_basis(0.0, depth, n3, x3, 2, 2)
            self._y_psi = _spline_basis(-half_width, half_width, n2, x2, 1, 1)
            self._z_psi = _spline_basis(0.0, depth, n3, x3, 1, 1)
            self.shapes += [(b[0].shape[1], c[0].shape[1]) for b, c in (
                (self._y_free, self._z_free), (self._y_phi, self._z_phi),
                (self._y_psi, self._z_psi))]
        self.sizes = [p * q for p, q in self.shapes]
        self.size = sum(self.sizes)

    def _split(self, c: NDArray[np.float64]) -> list[NDArray[np.float64]]:
        out, start = [], 0
        for shape, size in zip(self.shapes, self.sizes, strict=True):
            out.append(c[start:start + size].reshape(shape))
            start += size
        return out

    def extend(self, depth_coefficients: NDArray[np.float64]) -> NDArray[np.float64]:
        """Coefficients of this class for a field of the ``"depth"`` class on the same knots."""
        out = np.zeros(self.size)
        out[:depth_coefficients.size] = depth_coefficients
        return out

    def stress(self, c: NDArray[np.float64]) -> NDArray[np.float64]:
        """ρ at the samples, shape (n2, n3, 6), components (11, 22, 33, 12, 13, 23)."""
        rho = np.zeros((*self.points, 6))
        z0 = self._z_free[0]
        parts = self._split(c)
        rho[..., 0] = (z0 @ parts[0][0])[None, :]
        rho[..., 1] = (z0 @ parts[1][0])[None, :]
        if self.kind == "depth":
            return rho
        s, phi, psi = parts[2:]
        a0, a1, a2 = self._y_phi
        b0, b1, b2 = self._z_phi
        c0, c1, _ = self._y_psi
        d0, d1, _ = self._z_psi
        rho[..., 0] += self._y_free[0] @ s @ z0.T
        rho[..., 1] += a0 @ phi @ b2.T
        rho[..., 2] = a2 @ phi @ b0.T
        rho[..., 5] = -(a1 @ phi @ b1.T)
        rho[..., 3] = c0 @ psi @ d1.T
        rho[..., 4] = -(c1 @ psi @ d0.T)
        return rho

    def adjoint(self, g: NDArray[np.float64]) -> NDArray[np.float64]:
        """Gradient with respect to the coefficients of Σ g·ρ (g of shape (n2, n3, 6))."""
        z0 = self._z_free[0]
        out = [g[..., 0].sum(axis=0) @ z0, g[..., 1].sum(axis=0) @ z0]
        if self.kind == "full":
            a0, a1, a2 = self._y_phi
            b0, b1, b2 = self._z_phi
            c0, c1, _ = self._y_psi
            d0, d1, _ = self._z_psi
            out.append((self._y_free[0].T @ g[..., 0] @ z0).ravel())
            out.append((a0.T @ g[..., 1] @ b2 + a2.T @ g[..., 2] @ b0
                        - a1.T @ g[..., 5] @ b1).ravel())
            out.append((c0.T @ g[..., 3] @ d1 - c1.T @ g[..., 4] @ d0).ravel())
        return np.concatenate(out)


def _squared_von_mises(s: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """σ_vM² of (..., 6) stresses and its gradient with respect to the six components."""
    a, b, c, d, e, f = (s[..., i] for i in range(6))
    q = 0.5 * ((a - b) ** 2 + (b - c) ** 2 + (c - a) ** 2) + 3.0 * (d * d + e * e + f * f)
    grad = np.stack([2 * a - b - c, 2 * b - c - a, 2 * c - a - b, 6 * d, 6 * e, 6 * f], axis=-1)
    return q, grad


@dataclass(frozen=True)
class MelanBound:
    """Result of :func:`melan_bound`.

    Attributes
    ----------
    load_factor : float
        σ_Y / max σ_vM(σ̂ + ρ) over the samples, σ̂ per unit peak pressure: the peak pressure
        at which this ρ proves shakedown, in units of σ_Y.
    elastic_limit : float
        σ_Y / max σ_vM(σ̂) over the same samples (first yield, ρ = 0).
    residual : ndarray, shape (n2, n3, 6)
        The residual stress per unit peak pressure at the load factor.
    coefficients : ndarray
        Its spline coefficients.
    stages : list of (sharpness, iterations, load factor)
        The continuation, stage by stage.
    envelope : ndarray, shape (n2, n3)
        Largest von Mises stress over the load positions (and the unloaded state) of the safe
        state at the load factor, over σ_Y: 1 where the bound is set.
    x2, x3 : ndarray or None
        The sample coordinates of ``residual`` and ``envelope`` (set by the callers that know
        them, in their length unit).
    """

    load_factor: float
    elastic_limit: float
    residual: NDArray[np.float64]
    coefficients: NDArray[np.float64]
    stages: list[tuple[float, int, float]]
    envelope: NDArray[np.float64]
    x2: NDArray[np.float64] | None = None
    x3: NDArray[np.float64] | None = None


def melan_bound(elastic: NDArray[np.float64], field: SteadyResidualField,
                start: NDArray[np.float64] | None = None,
                stages: tuple[float, ...] = SHARPNESS_STAGES) -> MelanBound:
    """Largest load factor with a safe steady residual field (module docstring).

    Parameters
    ----------
    elastic : ndarray, shape (n1, n2, n3, 6)
        Elastic stress per unit peak pressure at the samples: n1 load positions (or, the
        same, x1 offsets from the load), the (n2, n3) points of ``field``. A zero slice for
        the unloaded state is added here.
    field : SteadyResidualField
        The residual stress class on those points.
    start : ndarray, optional
        Coefficients to start from (default: zero, the elastic state).
    stages : tuple of float
        Sharpness of the smoothed maximum, stage by stage.

    Returns
    -------
    MelanBound
    """
    sig = np.concatenate([elastic, np.zeros((1, *elastic.shape[1:]))], axis=0)
    # Work on the elastic field over its largest von Mises stress: the optimisation is then
    # the same, bit for bit, for any scale of the load (and the coefficients are of order 1).
    elastic_peak = float(np.sqrt(_squared_von_mises(sig)[0].max()))
    sig = sig / elastic_peak

    def smoothed(c: NDArray[np.float64], sharpness: float) -> tuple[float, NDArray[np.float64]]:
        q, grad = _squared_von_mises(sig + field.stress(c)[None])
        top = float(q.max())
        w = np.exp(sharpness * (q - top))
        total = float(w.sum())
        g = np.einsum("ijk,ijkc->jkc", w, grad) / total
        return top + np.log(total) / sharpness, field.adjoint(g)

    def largest(c: NDArray[np.float64]) -> float:
        return float(np.sqrt(_squared_von_mises(sig + field.stress(c)[None])[0].max()))

    c = (np.zeros(field.size) if start is None
         else np.asarray(start, dtype=float) / elastic_peak)
    best, best_c = largest(c), c
    history = []
    for sharpness in stages:
        res = minimize(smoothed, c, args=(sharpness,), jac=True, method="L-BFGS-B",
                       options={"maxiter": STAGE_MAX_ITERATIONS, "maxcor": LBFGS_MEMORY})
        c = res.x
        value = largest(c)
        history.append((sharpness, int(res.nit), 1.0 / (value * elastic_peak)))
        if value < best:
            best, best_c = value, c
    residual = field.stress(best_c)
    envelope = np.sqrt(_squared_von_mises(sig + residual[None])[0].max(axis=0)) / best
    return MelanBound(
        load_factor=1.0 / (best * elastic_peak), elastic_limit=1.0 / elastic_peak,
        residual=residual * elastic_peak, coefficients=best_c * elastic_peak, stages=history,
        envelope=envelope,
    )


def _solve(elastic: NDArray[np.float64], x2: NDArray[np.float64], x3: NDArray[np.float64],
           half_width: float, depth: float, knot_step: float,
           kind: FieldClass) -> MelanBound:
    """:func:`melan_bound` on a class; the whole class starts from the depth-only optimum."""
    intervals = (max(1, round(2 * half_width / knot_step)), max(1, round(depth / knot_step)))
    depth_only = SteadyResidualField(x2, x3, half_width, depth, intervals, "depth")
    first = melan_bound(elastic, depth_only)
    if kind == "depth":
        return replace(first, x2=x2, x3=x3)
    field = SteadyResidualField(x2, x3, half_width, depth, intervals, "full")
    bound = melan_bound(elastic, field, start=field.extend(first.coefficients),
                        stages=WARM_STAGES)
    return replace(bound, stages=first.stages + bound.stages, x2=x2, x3=x3)


def rolling_shakedown_bound(
    contact: Literal["point", "line"], nu: float = 0.3, *, kind: FieldClass = "full",
    half_width: float = 3.0, depth: float = 3.0, sample_step: float = 1.0 / 12.0,
    knot_step: float = 0.25, track: float = 3.0,
) -> MelanBound:
    """Melan bound of steady free rolling of a Hertz contact, lengths in contact half-widths a.

    Parameters
    ----------
    contact : {"point", "line"}
        A circular Hertz contact (:func:`sacflow.mechanics.hertz.hertz_subsurface_stress`) or a
        plane-strain line contact rolling across its length
        (:func:`sacflow.mechanics.hertz.line_contact_stress`; ``kind`` must be ``"depth"``, the
        samples lie on one x2).
    nu : float
        Poisson's ratio.
    kind : {"full", "depth"}
        Residual field class (:class:`SteadyResidualField`).
    half_width, depth : float
        The residual field's box [a].
    sample_step : float
        Spacing of the samples along x1, x2 and x3 [a].
    knot_step : float
        Spacing of the spline knots [a].
    track : float
        The load positions sampled lie within ± ``track`` of each point [a].

    Returns
    -------
    MelanBound
        ``load_factor`` in units of σ_Y; times √3 for k = σ_Y/√3.
    """
    x1 = np.arange(-track, track + 0.5 * sample_step, sample_step)
    x3 = np.arange(0.5 * sample_step, depth, sample_step)
    if contact == "line":
        if kind != "depth":
            raise ValueError("a line contact has plane-strain fields: use kind='depth'")
        x2 = np.zeros(1)
        elastic = line_contact_stress(x1[:, None], x3[None, :], 1.0, 1.0, nu)[:, None]
    else:
        x2 = np.arange(-half_width, half_width + 0.5 * sample_step, sample_step)
        X1, X2, X3 = np.meshgrid(x1, x2, x3, indexing="ij")
        elastic = hertz_subsurface_stress(X1, X2, X3, 1.0, 1.0, nu)
    return _solve(elastic, x2, x3, half_width, depth, knot_step, kind)


def pressure_stress(pressure: NDArray[np.float64], cell: tuple[float, float],
                    x3: NDArray[np.float64], nu: float, pad: tuple[int, int]
                    ) -> NDArray[np.float64]:
    """Elastic stress of a cell-wise uniform surface pressure, at cell centres around it.

    Superposition of Love's rectangles by FFT convolution, exact for the piecewise-constant
    pressure: the operator and coefficients of the solver's contact stress
    (:func:`sacflow.kernels.shear.surface_load_stress_coefficients`).

    Parameters
    ----------
    pressure : ndarray, shape (m1, m2)
        Pressure on cells of size ``cell`` (compressive positive, any unit).
    cell : (float, float)
        Cell sizes along x1 and x2.
    x3 : ndarray
        Depths (> 0) of the points, same length unit as ``cell``.
    nu : float
        Poisson's ratio.
    pad : (int, int)
        Cells added on each side of the pressure's grid along x1 and x2.

    Returns
    -------
    ndarray, shape (m1 + 2 pad1, m2 + 2 pad2, len(x3), 6)
        Stress in the unit of ``pressure`` at the centres of the padded grid.
    """
    m1, m2 = pressure.shape
    out_shape = (m1 + 2 * pad[0], m2 + 2 * pad[1])
    operator = Convolution(surface_load_stress_coefficients(cell, x3, nu), (m1, m2), out_shape,
                           offset=(-pad[0], -pad[1]), block=6)
    stress = operator(pressure[None]).reshape(len(x3), 6, *out_shape)
    return np.moveaxis(stress, (0, 1), (2, 3))


def moving_pressure_bound(
    pressure: NDArray[np.float64], cell: tuple[float, float], nu: float, *, a: float,
    track: float = 3.0, half_width: float = 3.0, depth: float = 3.0,
    depth_step: float = 1.0 / 12.0, knot_step: float = 0.25,
) -> MelanBound:
    """Melan bound of a surface pressure of any shape rolled steadily along x1.

    The load domain is ``pressure`` (cells of size ``cell``, centred on the load, x2 = 0 on
    the track's centre line) at every position along the track, sampled at whole cells, and the
    unloaded state. Points: cell centres across the track within ± ``half_width``, depths
    every ``depth_step`` down to ``depth`` (all in units of ``a``); the residual field class
    is the whole steady class on that box (:class:`SteadyResidualField`).

    Returns
    -------
    MelanBound
        ``load_factor``: the factor by which ``pressure`` can be scaled and still shake down,
        in units of σ_Y when ``pressure`` is given in units of σ_Y.
    """
    m1, m2 = pressure.shape
    pad1 = max(0, int(np.ceil(track * a / cell[0] - m1 / 2)))
    pad2 = max(0, int(np.ceil(half_width * a / cell[1] - m2 / 2)))
    x3 = np.arange(0.5 * depth_step, depth, depth_step) * a
    elastic = pressure_stress(pressure, cell, x3, nu, (pad1, pad2))
    x2 = (np.arange(m2 + 2 * pad2) - (m2 + 2 * pad2 - 1) / 2) * cell[1]
    inside = np.abs(x2) <= half_width * a
    elastic, x2 = elastic[:, inside], x2[inside]
    bound = _solve(elastic, x2 / a, x3 / a, half_width, depth, knot_step, "full")
    return replace(bound, x2=x2, x3=x3)
