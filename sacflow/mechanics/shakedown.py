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
shakedown limit. The load domain does not change under a shift of x1 and the yield condition
is convex, so averaging a safe ρ over its shifts gives a safe ρ that does not depend on x1: the
search runs over fields ρ(x2, x3) of the half-plane, those of
:class:`sacflow.mechanics.steady_residual.SteadyResidualField` (three stress functions as
B-splines on a box, and a part of depth only).

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
from scipy.optimize import minimize

from sacflow.kernels.convolution import Convolution
from sacflow.kernels.shear import surface_load_stress_coefficients
from sacflow.mechanics.hertz import hertz_subsurface_stress, line_contact_stress
from sacflow.mechanics.steady_residual import FieldClass, SteadyResidualField
from sacflow.mechanics.stress_measures import squared_von_mises_and_gradient

__all__ = [
    "MelanBound",
    "melan_bound",
    "moving_pressure_bound",
    "moving_pressure_samples",
    "pressure_stress",
    "knot_intervals",
    "rolling_samples",
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
    elastic_peak = float(np.sqrt(squared_von_mises_and_gradient(sig)[0].max()))
    sig = sig / elastic_peak

    def smoothed(c: NDArray[np.float64], sharpness: float) -> tuple[float, NDArray[np.float64]]:
        q, grad = squared_von_mises_and_gradient(sig + field.stress(c)[None])
        top = float(q.max())
        w = np.exp(sharpness * (q - top))
        total = float(w.sum())
        g = np.einsum("ijk,ijkc->jkc", w, grad) / total
        return top + np.log(total) / sharpness, field.adjoint(g)

    def largest(c: NDArray[np.float64]) -> float:
        return float(np.sqrt(squared_von_mises_and_gradient(sig + field.stress(c)[None])[0].max()))

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
    envelope = np.sqrt(squared_von_mises_and_gradient(sig + residual[None])[0].max(axis=0)) / best
    return MelanBound(
        load_factor=1.0 / (best * elastic_peak), elastic_limit=1.0 / elastic_peak,
        residual=residual * elastic_peak, coefficients=best_c * elastic_peak, stages=history,
        envelope=envelope,
    )


def knot_intervals(half_width: float, depth: float, knot_step: float) -> tuple[int, int]:
    """Knot intervals of the residual field's box along x2 and x3, about ``knot_step`` each."""
    return max(1, round(2 * half_width / knot_step)), max(1, round(depth / knot_step))


def rolling_samples(contact: Literal["point", "line"], nu: float, half_width: float,
                    depth: float, sample_step: float, track: float
                    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Elastic Hertz stress per unit p0 at the samples of :func:`rolling_shakedown_bound`.

    Returns the stress, shape (n1, n2, n3, 6) over load offsets x1 ∈ [−track, track], and the
    sample coordinates x2, x3 (one x2 = 0 for the line contact), lengths in a.
    """
    x1 = np.arange(-track, track + 0.5 * sample_step, sample_step)
    x3 = np.arange(0.5 * sample_step, depth, sample_step)
    if contact == "line":
        x2 = np.zeros(1)
        return line_contact_stress(x1[:, None], x3[None, :], 1.0, 1.0, nu)[:, None], x2, x3
    x2 = np.arange(-half_width, half_width + 0.5 * sample_step, sample_step)
    X1, X2, X3 = np.meshgrid(x1, x2, x3, indexing="ij")
    return hertz_subsurface_stress(X1, X2, X3, 1.0, 1.0, nu), x2, x3


def _solve(elastic: NDArray[np.float64], x2: NDArray[np.float64], x3: NDArray[np.float64],
           half_width: float, depth: float, knot_step: float,
           kind: FieldClass) -> MelanBound:
    """:func:`melan_bound` on a class; the whole class starts from the depth-only optimum."""
    intervals = knot_intervals(half_width, depth, knot_step)
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
    if contact == "line" and kind != "depth":
        raise ValueError("a line contact has plane-strain fields: use kind='depth'")
    elastic, x2, x3 = rolling_samples(contact, nu, half_width, depth, sample_step, track)
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


def moving_pressure_samples(
    pressure: NDArray[np.float64], cell: tuple[float, float], nu: float, *, a: float,
    track: float = 3.0, half_width: float = 3.0, depth: float = 3.0,
    depth_step: float = 1.0 / 12.0,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Sample the load domain of :func:`moving_pressure_bound`.

    Returns the elastic stress (n1, n2, n3, 6) in the unit of ``pressure``, and the sample
    coordinates x2, x3 in the length unit of ``cell`` and ``a``.
    """
    m1, m2 = pressure.shape
    pad1 = max(0, int(np.ceil(track * a / cell[0] - m1 / 2)))
    pad2 = max(0, int(np.ceil(half_width * a / cell[1] - m2 / 2)))
    x3 = np.arange(0.5 * depth_step, depth, depth_step) * a
    elastic = pressure_stress(pressure, cell, x3, nu, (pad1, pad2))
    x2 = (np.arange(m2 + 2 * pad2) - (m2 + 2 * pad2 - 1) / 2) * cell[1]
    inside = np.abs(x2) <= half_width * a
    return elastic[:, inside], x2[inside], x3


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
    is the whole steady class on that box (:class:`SteadyResidualField`). Yield is checked
    at these samples only: the factor is not certified between them (that certificate,
    :mod:`sacflow.mechanics.shakedown_bracket`, needs the elastic field at any point, which
    the Hertz closed forms give).

    Returns
    -------
    MelanBound
        ``load_factor``: the factor by which ``pressure`` can be scaled and still shake down,
        in units of σ_Y when ``pressure`` is given in units of σ_Y.
    """
    elastic, x2, x3 = moving_pressure_samples(pressure, cell, nu, a=a, track=track,
                                              half_width=half_width, depth=depth,
                                              depth_step=depth_step)
    bound = _solve(elastic, x2 / a, x3 / a, half_width, depth, knot_step, "full")
    return replace(bound, x2=x2, x3=x3)
