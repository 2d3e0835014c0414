"""Melan's static shakedown check of a run's contact pressure, rolled steadily (``melan``).

``sacflow compare melan RUN.nc [--step N]``: the contact pressure stored at one step (default:
the middle rolling step of the last pass at full load, where a repeated-rolling run is closest
to its steady cycle) is taken as a load that rolls along x1 over an unbounded track, on the
surface as the run left it. :func:`sacflow.mechanics.shakedown.moving_pressure_bound` then finds
the largest
factor λ on that pressure for which a steady self-equilibrated residual stress keeps the
elastic–perfectly plastic body below yield at every load position (Melan's theorem). λ ≥ 1
proves that the body shakes down under that pressure; λ < 1 says that no steady residual field
of the class was found that does, which near 1 is no proof of ratcheting (λ is a lower
bound of the shakedown factor). The stage also reports the kinematic-hardening ceiling on the same
samples (:func:`sacflow.mechanics.shakedown_ceiling.kinematic_ceiling`): no residual field
proves more, so a ceiling below 1 proves that the body does not shake down elastically under
that pressure; and the gap, ceiling / λ − 1, between the two. λ has its yield condition checked
at the samples only (cell centres across the track, every a/12 in depth, load positions at
whole cells); the certificate between samples of :mod:`sacflow.mechanics.shakedown_bracket`
needs the elastic field at any point and is made for the Hertz closed forms only. The ceiling
needs no such care: a subset of the load domain gives a valid, only looser, ceiling.

Why the stored pressure, not the Hertz one: in a repeated-rolling run the residual surface
displacement (the groove) is part of the gap, so the pressure flattens and spreads while the
load stays the same. Classical shakedown limits (p0 about 4.7 k for a sphere) are for the
elastic Hertz pressure; this stage answers the same question for the pressure the run found.

Output: ``load_factor`` λ, ``ceiling_factor``, ``gap``, the pressure's peak, λ × peak, the
first-yield factor, the step used; ``residual_stress`` (x2, x3, component) of the safe state
at λ; ``envelope`` (x2, x3), the largest von Mises stress over the load positions over σ_Y
at λ; the verdict in the attributes. Only elastic–perfectly plastic bodies with a uniform
yield stress and no friction, rolled along x1.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from sacflow.compare.core import CompareError, case_of, load_run, require

__all__ = ["melan", "plot_melan"]

STAGE = "melan"
VERDICT_RULE = (
    "shakes down: load_factor >= 1, a steady self-equilibrated residual stress keeps this "
    "pressure below yield at every load position sampled (Melan's theorem); does not shake "
    "down: ceiling_factor < 1, no residual stress whatever can (the kinematic-hardening "
    "ceiling); not proven safe: in between, no such field of the class was found (near 1 this "
    "is no proof of ratcheting)"
)


def _default_step(case: Any, steps: np.ndarray) -> int:
    """Return the middle rolling step of the last pass at full load."""
    from sacflow.config.solver_inputs import case_steps

    plan = case_steps(case)
    rolling = [i for i, s in enumerate(plan) if case.load_path[s.segment].kind == "roll"]
    if not rolling:
        raise CompareError(f"{STAGE}: the run has no roll segment; give --step")
    last = max(plan[i].pass_index for i in rolling)
    top = max(plan[i].load for i in rolling)
    chosen = [i for i in rolling if plan[i].pass_index == last and plan[i].load >= top
              and i in steps]
    if not chosen:
        raise CompareError(f"{STAGE}: the last pass's rolling steps are not stored; the run is "
                           "unfinished, or give --step")
    return chosen[len(chosen) // 2]


def check_melan_case(case: Any) -> float:
    """σ_Y of an elastic–perfectly plastic, frictionless case rolled along x1, else an error."""
    law = case.body.hardening
    if getattr(law, "law", None) != "perfectly_plastic" or law.depth_profile is not None \
            or law.kinematic is not None:
        raise CompareError(f"{STAGE}: Melan's theorem is applied here to an elastic-perfectly "
                           "plastic body with a uniform yield stress; this case's body.hardening "
                           "is not one")
    if case.body.initial_residual_stress is not None or case.body.initial_hardening is not None:
        raise CompareError(f"{STAGE}: the case has an initial residual stress or hardening, "
                           "which this check leaves out")
    if case.friction is not None:
        raise CompareError(f"{STAGE}: the case has a surface traction ([friction]); this check "
                           "is for free (frictionless) rolling")
    for segment in case.load_path:
        if segment.kind == "roll" and abs(segment.direction[1]) > 1e-12:
            raise CompareError(f"{STAGE}: the roll segments must run along x1 (direction "
                               f"[1, 0] or [-1, 0]), got {list(segment.direction)}")
    return float(law.yield_stress)


def _pressure_patch(ds: xr.Dataset, step: int) -> tuple[np.ndarray, tuple[float, float]]:
    """Return the loaded cells of the step's pressure, symmetric about the track centre."""
    at = ds.sel(step=step)
    pressure = np.nan_to_num(at["pressure"].values)
    if not (pressure > 0).any():
        raise CompareError(f"{STAGE}: no contact pressure at step {step}")
    x1, x2 = ds["x1"].values, ds["x2"].values
    cell = (float(np.diff(x1).mean()), float(np.diff(x2).mean()))
    rows = np.nonzero((pressure > 0).any(axis=1))[0]
    rows = np.arange(max(rows[0] - 1, 0), min(rows[-1] + 2, x1.size))
    offsets = x2 - float(at["load_x2"])
    reach = min(offsets.max(), -offsets.min()) + 1e-6 * cell[1]
    cols = np.abs(offsets) <= reach
    if abs(offsets[cols].sum()) > 1e-6 * cell[1] * cols.sum():
        raise CompareError(f"{STAGE}: the track centre x2 = {float(at['load_x2']):.4g} m is not "
                           "on a symmetry line of the cells")
    patch = pressure[np.ix_(rows, np.nonzero(cols)[0])]
    if (patch[:, [0, -1]] > 0).any():
        raise CompareError(f"{STAGE}: the pressure reaches the edge of the grid across the "
                           "track; widen the run's window (grid.half_width)")
    return patch, cell


def melan(run: str | Path | xr.Dataset, step: int | None = None) -> xr.Dataset:
    """Check the stored pressure of one step with Melan's theorem (module docstring).

    Parameters
    ----------
    run : path or Dataset
        A finished or partial run with the ``pressure`` stored.
    step : int, optional
        The step whose pressure is rolled (default: the middle full-load rolling step of the
        last pass).

    Raises
    ------
    CompareError
        For cases the check does not cover (module docstring) or a step without pressure.
    """
    from sacflow.mechanics.shakedown import moving_pressure_bound, moving_pressure_samples
    from sacflow.mechanics.shakedown_ceiling import kinematic_ceiling

    ds = load_run(run)
    require(ds, "pressure", "load_x2", stage=STAGE)
    case = case_of(ds)
    yield_stress = check_melan_case(case)
    steps = ds["step"].values
    if step is None:
        step = _default_step(case, steps)
    elif not isinstance(step, int):
        raise CompareError(f"{STAGE}: give --step a step number (default: the middle rolling "
                           "step of the last pass at full load)")
    elif step not in steps:
        raise CompareError(f"{STAGE}: --step {step} is not a stored step (0 … {steps.max()})")
    patch, cell = _pressure_patch(ds, step)
    a = case.hertz().a
    bound = moving_pressure_bound(patch / yield_stress, cell, case.body.nu, a=a)
    elastic = moving_pressure_samples(patch / yield_stress, cell, case.body.nu, a=a)[0]
    ceiling = kinematic_ceiling(elastic).load_factor
    peak = float(patch.max())
    factor = bound.load_factor
    verdict = ("shakes down" if factor >= 1.0 else "does not shake down" if ceiling < 1.0
               else "not proven safe")
    result = xr.Dataset(
        {
            "load_factor": ((), factor, {"units": "1", "long_name": "largest factor on the "
                                         "pressure with a steady residual stress safe at "
                                         "the samples"}),
            "ceiling_factor": ((), ceiling, {"units": "1", "long_name": "kinematic-hardening "
                                             "ceiling: no residual stress proves a larger "
                                             "factor"}),
            "gap": ((), ceiling / factor - 1.0, {"units": "1", "long_name": "ceiling_factor "
                                                 "/ load_factor - 1"}),
            "peak_pressure": ((), peak, {"units": "Pa", "long_name": "peak of the rolled "
                                         "pressure"}),
            "shakedown_peak_pressure": ((), factor * peak, {
                "units": "Pa", "long_name": "peak pressure of that shape at the bound"}),
            "first_yield_factor": ((), bound.elastic_limit, {
                "units": "1", "long_name": "factor on the pressure at first yield"}),
            "step": ((), int(step), {"units": "1", "long_name": "step of the pressure"}),
            "residual_stress": (("x2", "x3", "component"),
                                bound.residual * factor * yield_stress, {
                "units": "Pa", "long_name": "safe steady residual stress at the bound"}),
            "envelope": (("x2", "x3"), bound.envelope, {
                "units": "1", "long_name": "largest von Mises stress over the load positions "
                "over the yield stress, at the bound"}),
        },
        coords={"x2": ("x2", np.asarray(bound.x2), {"units": "m",
                                                    "long_name": "across the track"}),
                "x3": ("x3", np.asarray(bound.x3), {"units": "m", "long_name": "depth"}),
                "component": ("component", ["11", "22", "33", "12", "13", "23"])},
    )
    result.attrs.update(stage=STAGE, case=case.name, Conventions="CF-1.10", verdict=verdict,
                        verdict_rule=VERDICT_RULE, yield_stress=yield_stress, contact_radius=a)
    return result


def plot_melan(result: xr.Dataset) -> Figure:
    """Safe residual stress on the track centre; where the safe state touches yield."""
    fig = Figure(figsize=(11.0, 4.2), layout="constrained")
    left, right = fig.subplots(1, 2)
    a = float(result.attrs["contact_radius"])
    x2, x3 = result["x2"].values / a, result["x3"].values / a
    centre = int(np.argmin(np.abs(x2)))
    for comp in ("11", "22", "33"):
        left.plot(x3, result["residual_stress"].sel(component=comp).values[centre] / 1e6,
                  label=f"ρ{comp}")
    left.set(xlabel="depth x3 / a", ylabel="residual stress [MPa] on the track centre",
             title=f"λ = {float(result['load_factor']):.3f} (ceiling "
             f"{float(result['ceiling_factor']):.3f}): {result.attrs['verdict']}")
    left.legend()
    left.grid(True, alpha=0.3)
    envelope = result["envelope"].values
    mesh = right.pcolormesh(x2, x3, envelope.T, shading="nearest", vmin=0, vmax=1)
    right.contour(x2, x3, envelope.T, levels=[0.99], colors="w", linewidths=0.8)
    right.invert_yaxis()
    fig.colorbar(mesh, ax=right, label="max over load positions of σ_vM / σ_Y")
    right.set(xlabel="x2 / a (across the track)", ylabel="depth x3 / a",
              title="safe state at the bound (white: within 1 % of yield)")
    fig.suptitle(f"{result.attrs.get('case', '')}: Melan check of the step "
                 f"{int(result['step'])} pressure, rolled steadily")
    return fig
