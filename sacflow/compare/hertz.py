"""Stages against the elastic Hertz solution: :func:`hertz_check`, :func:`load_approach`.

The Hertz quantities come from :mod:`sacflow.mechanics.hertz` (one closed form, used by the tests
and
the stages alike) with the effective radius R and the contact modulus E* of the case
stored in the run (:meth:`sacflow.config.schema.Case.hertz`): δ = a²/R = (9 W² / 16 R E*²)^(1/3),
a = (3 W R / 4 E*)^(1/3), p0 = 3 W / (2 π a²).
"""

from __future__ import annotations

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from sacflow.compare.core import (
    RunLike,
    build,
    case_name,
    case_of,
    load_run,
    max_load_index,
    nearest,
    require,
)
from sacflow.mechanics.hertz import hertz_contact, hertz_pressure

__all__ = ["hertz_approach", "hertz_check", "load_approach"]


def hertz_approach(load: np.ndarray, radius: float, e_star: float) -> np.ndarray:
    """Hertz approach δ(W) [m] for each load [N] (:func:`sacflow.mechanics.hertz.hertz_contact`)."""
    loads = np.asarray(load, dtype=float)
    out = [hertz_contact(max(w, 0.0), radius, e_star).approach for w in loads.ravel()]
    return np.reshape(np.array(out, dtype=float), loads.shape)


def _relative(value: ArrayLike, reference: ArrayLike) -> np.ndarray:
    """Return ``(value − reference) / reference``, NaN where the reference is 0."""
    value, reference = np.asarray(value, dtype=float), np.asarray(reference, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(reference != 0.0, (value - reference) / reference, np.nan)



def _curves(ds: xr.Dataset):
    """Per-step load and approach of a run, the Hertz approach at those loads, R and E*."""
    hertz = case_of(ds).hertz()
    radius, e_star = hertz.radius, hertz.e_star
    load = np.asarray(ds["load"].values, dtype=float)
    approach = np.asarray(ds["approach"].values, dtype=float)
    return load, approach, hertz_approach(load, radius, e_star), radius, e_star

def hertz_check(run: RunLike) -> xr.Dataset:
    """Compare a run with Hertz: load–approach curve and pressure profile at the maximum load.

    Parameters
    ----------
    run : Dataset or path
        A run (normally elastic; for an elastic-plastic run the errors measure plasticity).

    Returns
    -------
    xarray.Dataset
        ``load``, ``approach``, ``approach_hertz``, ``approach_error`` along ``step``;
        ``pressure`` and ``pressure_hertz`` along ``x1`` on the row of cells nearest to
        x2 = load_x2 at the max-load step, the Hertz pressure evaluated at the same cell centres;
        summary numbers ``p0`` (largest stored pressure) vs ``p0_hertz``, ``contact_radius``
        ((contact_area/π)^½) vs ``contact_radius_hertz``, ``approach_max`` vs
        ``approach_max_hertz``, their relative errors, and ``profile_error``
        (max |p − p_Hertz| / p0_Hertz along the profile).

    Notes
    -----
    Pressure is stored at cell centres: on a grid with no cell centre on the load axis the
    largest stored pressure lies a little below p0 (by ≈ (d/a)²/4 for a cell of size d at the
    centre), the profile comparison is exact.
    """
    ds = load_run(run)
    stage = "hertz-check"
    require(ds, "load", "approach", "load_x1", "load_x2", "contact_area", "pressure", stage=stage)
    load, approach, approach_h, radius, e_star = _curves(ds)

    index = max_load_index(ds)
    at = ds.isel(step=index)
    ref = hertz_contact(float(at["load"]), radius, e_star)
    c1, c2 = float(at["load_x1"]), float(at["load_x2"])
    row = nearest(ds["x2"].values, c2)
    x1 = np.asarray(ds["x1"].values, dtype=float)
    x2_row = float(ds["x2"].values[row])
    profile = np.asarray(at["pressure"].isel(x2=row).values, dtype=float)
    profile_h = hertz_pressure(np.hypot(x1 - c1, x2_row - c2), ref.a, ref.p0)
    p0 = float(np.nanmax(at["pressure"].values))
    radius_run = float(np.sqrt(float(at["contact_area"]) / np.pi))
    approach_max = float(at["approach"])
    return build(
        {
            "load": ("step", load),
            "approach": ("step", approach),
            "approach_hertz": ("step", approach_h),
            "approach_error": ("step", _relative(approach, approach_h)),
            "pressure": ("x1", profile),
            "pressure_hertz": ("x1", profile_h),
            "p0": p0,
            "p0_hertz": ref.p0,
            "p0_error": float(_relative(p0, ref.p0)),
            "contact_radius": radius_run,
            "contact_radius_hertz": ref.a,
            "contact_radius_error": float(_relative(radius_run, ref.a)),
            "approach_max": approach_max,
            "approach_max_hertz": ref.approach,
            "approach_max_error": float(_relative(approach_max, ref.approach)),
            "profile_error": float(np.nanmax(np.abs(profile - profile_h)) / ref.p0),
        },
        coords={"step": ds["step"].values, "x1": x1},
        attrs={
            "stage": stage,
            "case": case_name(ds),
            "step_max_load": int(ds["step"].values[index]),
            "load_max": float(at["load"]),
            "load_x1": c1,
            "load_x2": c2,
            "profile_x2": x2_row,
            "effective_radius": radius,
            "e_star": e_star,
        },
    )


def _branches(ds: xr.Dataset, index: int) -> np.ndarray:
    """Branch of each step from its load path segment: loading, unloading, hold or roll."""
    try:
        path = case_of(ds).load_path
        kinds = [path[int(s)].kind for s in ds["segment"].values]
    except (KeyError, IndexError, ValueError):  # no usable segment: split at the max load
        positions = np.arange(ds.sizes["step"])
        return np.where(positions <= index, "loading", "unloading")
    names = {"load": "loading", "unload": "unloading"}
    return np.array([names.get(k, k) for k in kinds])


def load_approach(run: RunLike, reference: RunLike | None = None) -> xr.Dataset:
    """Load–approach curve of a run: loading and unloading branches with the Hertz curve.

    The unloading branch is also given shifted by ``unloading_shift`` = δ(W_max) − δ_Hertz(W_max)
    so that it starts on the elastic curve (seed Fig. 11): if plasticity only shifted the body,
    the shifted unloading branch would lie on the Hertz curve; its distance from it
    (``unloading_deviation``) measures the effect of the changed surface geometry.

    Parameters
    ----------
    run : Dataset or path
        The run (e.g. ``nanoindentation-190mN``).
    reference : Dataset or path, optional
        Another curve to draw with it: a run, or any netCDF/CSV table with ``load`` [N] and
        ``approach`` [m] (e.g. finite-element results).

    Returns
    -------
    xarray.Dataset
        ``load``, ``approach``, ``approach_hertz`` (Hertz at the same load) and
        ``approach_shifted`` (unloading steps only, NaN elsewhere) along ``step`` with the
        ``branch`` coordinate; ``hertz_load``/``hertz_approach`` along ``hertz_point``;
        ``reference_load``/``reference_approach`` along ``reference_point`` if given; summary
        numbers ``max_load``, ``approach_max``, ``approach_max_hertz``, ``approach_max_error``,
        ``unloading_shift``, ``unloading_deviation``, ``residual_approach`` (NaN without
        unloading).
    """
    ds = load_run(run)
    stage = "load-approach"
    require(ds, "load", "approach", stage=stage)
    load, approach, approach_h, radius, e_star = _curves(ds)
    index = max_load_index(ds)
    branch = _branches(ds, index)
    unloading = (branch == "unloading") & (np.arange(load.size) > index)

    w_max, d_max, d_max_h = load[index], approach[index], approach_h[index]
    shifted = np.full(load.shape, np.nan)
    shift = deviation = residual = np.nan
    if unloading.any():
        shift = d_max - d_max_h
        shifted[unloading] = approach[unloading] - shift
        deviation = float(np.nanmax(np.abs(shifted - approach_h)[unloading]) / d_max_h)
        residual = float(approach[np.flatnonzero(unloading)[-1]])
    curve_load = np.linspace(0.0, w_max, 101)
    data = {
        "load": ("step", load),
        "approach": ("step", approach),
        "approach_hertz": ("step", approach_h),
        "approach_shifted": ("step", shifted),
        "hertz_load": ("hertz_point", curve_load),
        "hertz_approach": ("hertz_point", hertz_approach(curve_load, radius, e_star)),
        "max_load": w_max,
        "approach_max": d_max,
        "approach_max_hertz": d_max_h,
        "approach_max_error": float(_relative(d_max, d_max_h)),
        "unloading_shift": shift,
        "unloading_deviation": deviation,
        "residual_approach": residual,
    }
    attrs = {"stage": stage, "case": case_name(ds), "step_max_load": int(ds.step[index])}
    if reference is not None:
        from sacflow.compare.reference import read_table

        table, label = read_table(reference, ("load", "approach"))
        data["reference_load"] = ("reference_point", table["load"])
        data["reference_approach"] = ("reference_point", table["approach"])
        attrs["reference"] = label
    return build(data, coords={"step": ds["step"].values, "branch": ("step", branch)}, attrs=attrs)
