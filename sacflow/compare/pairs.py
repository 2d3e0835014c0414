"""Stages comparing two runs: :func:`elastic_vs_plastic`, :func:`vertical_vs_rolling`.

Each run keeps its own grid; a profile is read on the row of cells nearest to the requested x2
and, for volume fields, in the cuboid layer nearest to the requested depth (recorded in the
attributes). A requested x2 or depth outside a run's stored cells is an error, never the edge
row or the bottom layer read as that position.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from sacflow.compare.core import (
    CompareError,
    RunLike,
    build,
    case_name,
    case_of,
    load_run,
    max_load_index,
    nearest,
    nearest_inside,
    require,
    step_index,
)

__all__ = ["asymmetry", "elastic_vs_plastic", "vertical_vs_rolling"]


def _pressure_profile(ds: xr.Dataset, stage: str) -> tuple[xr.DataArray, dict[str, float]]:
    """Pressure along x1 through the load point at the maximum load."""
    require(ds, "pressure", "load", "load_x2", stage=stage)
    index = step_index(ds, "pressure", "max_load", stage)
    c2 = float(ds["load_x2"].values[max_load_index(ds)])
    row = nearest(ds["x2"].values, c2)
    profile = ds["pressure"].isel(step=index, x2=row)
    return profile, {"step": int(ds["step"].values[index]), "x2": float(ds["x2"].values[row])}


def elastic_vs_plastic(elastic: RunLike, plastic: RunLike) -> xr.Dataset:
    """Pressure profiles of an elastic and an elastic-plastic run at the maximum load.

    Seed Fig. 20: on the dented contact the elastic pressure peaks are ≈ 10 % higher
    (``peak_ratio`` ≈ 1.1).

    Parameters
    ----------
    elastic, plastic : Dataset or path
        The two runs of the same contact (e.g. hardening ``elastic`` vs Swift).

    Returns
    -------
    xarray.Dataset
        ``pressure_elastic`` and ``pressure_plastic`` along the elastic run's ``x1`` (the
        plastic profile linearly interpolated if its grid differs), each on the row of cells
        through its load point; ``peak_elastic``, ``peak_plastic`` (profile maxima), their
        ``_x1`` positions and ``peak_ratio`` = elastic / plastic.
    """
    stage = "elastic-vs-plastic"
    ds_e, ds_p = load_run(elastic), load_run(plastic)
    p_e, at_e = _pressure_profile(ds_e, stage)
    p_p, at_p = _pressure_profile(ds_p, stage)
    x1 = np.asarray(p_e["x1"].values, dtype=float)
    same = p_p.sizes["x1"] == x1.size and np.allclose(p_p["x1"].values, x1, rtol=0, atol=1e-12)
    values_p = np.asarray((p_p if same else p_p.interp(x1=x1)).values, dtype=float)
    values_e = np.asarray(p_e.values, dtype=float)
    if not (np.isfinite(values_e).any() and np.isfinite(values_p).any()):
        raise CompareError("the two runs share no x1 positions; compare runs of the same window")
    ie, ip = int(np.nanargmax(values_e)), int(np.nanargmax(values_p))
    return build(
        {
            "pressure_elastic": ("x1", values_e),
            "pressure_plastic": ("x1", values_p),
            "peak_elastic": values_e[ie],
            "peak_plastic": values_p[ip],
            "peak_elastic_x1": x1[ie],
            "peak_plastic_x1": x1[ip],
            "peak_ratio": values_e[ie] / values_p[ip] if values_p[ip] > 0 else np.nan,
        },
        coords={"x1": x1},
        attrs={
            "stage": stage,
            "case": f"{case_name(ds_e)} vs {case_name(ds_p)}",
            "case_elastic": case_name(ds_e),
            "case_plastic": case_name(ds_p),
            "step_elastic": at_e["step"],
            "step_plastic": at_p["step"],
            "profile_x2_elastic": at_e["x2"],
            "profile_x2_plastic": at_p["x2"],
            "plastic_interpolated": not same,
        },
    )


def asymmetry(x: np.ndarray, values: np.ndarray, centre: float) -> float:
    """Return max |f(c + s) − f(c − s)| / |min f| over the points whose mirror is on the profile.

    ``f(c − s)`` is linearly interpolated; 0 for a profile symmetric about ``centre``.
    """
    x, values = np.asarray(x, dtype=float), np.asarray(values, dtype=float)
    order = np.argsort(x)
    x, values = x[order], values[order]
    mirror = np.interp(2.0 * centre - x, x, values, left=np.nan, right=np.nan)
    diff = np.abs(values - mirror)
    scale = abs(np.nanmin(values)) if np.isfinite(values).any() else np.nan
    if not np.isfinite(diff).any() or not scale > 0:
        return np.nan
    return float(np.nanmax(diff) / scale)


def _sigma11_profile(
    ds: xr.Dataset, depth: float, x2: float, stage: str
) -> tuple[np.ndarray, np.ndarray, dict[str, float]]:
    """Residual σ11 along x1 at the nearest layer and row, last step with volume output.

    Raises :class:`~sacflow.compare.core.CompareError` when ``depth`` or ``x2`` lies outside
    the run's stored cells.
    """
    index = step_index(ds, "residual_stress", "last", stage)
    layer = nearest_inside(ds, "x3", depth, "--depth", fix=_DEPTH_FIX)
    row = nearest_inside(ds, "x2", x2, "--x2")
    da = ds["residual_stress"].isel(step=index, x3=layer, x2=row).sel(component="11")
    chosen = {
        "step": int(ds["step"].values[index]),
        "depth": float(ds["x3"].values[layer]),
        "x2": float(ds["x2"].values[row]),
    }
    return np.asarray(da["x1"].values, dtype=float), np.asarray(da.values, dtype=float), chosen


#: What to do about a depth outside a run's box, besides giving one inside it.
_DEPTH_FIX = "(or leave it out: the depth of the vertical run's minimum residual σ11)"


def _compressive_depth(ds: xr.Dataset, x2: float, stage: str) -> float:
    """Depth [m] of the layer of the minimum residual σ11 on the row nearest to ``x2``.

    The depth of the seed's Fig. 22: the compressive residual stress under the dent, where
    vertical loading and rolling differ most.
    """
    index = step_index(ds, "residual_stress", "last", stage)
    row = nearest_inside(ds, "x2", x2, "--x2")
    s11 = ds["residual_stress"].isel(step=index, x2=row).sel(component="11")
    values = np.asarray(s11.transpose("x1", "x3").values, dtype=float)
    if not np.isfinite(values).any():
        raise CompareError(f"run {case_name(ds)!r} stores no finite residual σ11 on x2 = {x2:g} m")
    layer = np.unravel_index(int(np.nanargmin(values)), values.shape)[1]
    return float(ds["x3"].values[layer])


def _default_centre(ds: xr.Dataset) -> float:
    """Return the first dent's x1 if the case is dented, else the load x1 at the maximum load."""
    surface = case_of(ds).surface
    if surface.kind == "dented":
        return float(surface.dents[0].x1)
    require(ds, "load_x1", stage="vertical-vs-rolling")
    return float(ds["load_x1"].values[max_load_index(ds)])


def vertical_vs_rolling(
    vertical: RunLike,
    rolling: RunLike,
    depth: float | None = None,
    x2: float = 0.0,
    centre: float | None = None,
) -> xr.Dataset:
    """Residual σ11 along x1 after vertical loading and after rolling (seed Fig. 22).

    Parameters
    ----------
    vertical, rolling : Dataset or path
        The two runs (e.g. ``dent-vertical`` and ``dent-rolling``).
    depth : float, optional
        Depth of the profile [m]; nearest cuboid layer of each run, which must lie inside both
        runs' cuboid boxes. Default: the depth of the minimum residual σ11 of the vertical run
        on the row of ``x2`` (seed Fig. 22: 75 µm under the dent); attribute ``depth_choice``.
    x2 : float
        Lateral position of the profile [m]; nearest row of cells (inside both grids).
    centre : float, optional
        x1 about which the asymmetry is measured; default: the first dent's x1 of the
        vertical case, else its load x1 at the maximum load.

    Returns
    -------
    xarray.Dataset
        ``residual_stress_11_vertical`` (``x1_vertical``) and ``residual_stress_11_rolling``
        (``x1_rolling``) at the last step of each run; ``min_vertical``, ``min_rolling``,
        their ``_x1`` positions, ``min_ratio`` = rolling / vertical (seed: ≈ 1.3) and
        ``asymmetry_vertical``, ``asymmetry_rolling`` (see :func:`asymmetry`).
    """
    stage = "vertical-vs-rolling"
    ds_v, ds_r = load_run(vertical), load_run(rolling)
    choice = "requested"
    if depth is None:
        depth = _compressive_depth(ds_v, x2, stage)
        choice = "minimum residual σ11 of the vertical run"
    x_v, s_v, at_v = _sigma11_profile(ds_v, depth, x2, stage)
    x_r, s_r, at_r = _sigma11_profile(ds_r, depth, x2, stage)
    if not (np.isfinite(s_v).any() and np.isfinite(s_r).any()):
        raise CompareError(f"no residual stress stored at x3 ≈ {depth:g} m in one of the runs")
    c = _default_centre(ds_v) if centre is None else float(centre)
    iv, ir = int(np.nanargmin(s_v)), int(np.nanargmin(s_r))
    return build(
        {
            "residual_stress_11_vertical": ("x1_vertical", s_v),
            "residual_stress_11_rolling": ("x1_rolling", s_r),
            "min_vertical": s_v[iv],
            "min_vertical_x1": x_v[iv],
            "min_rolling": s_r[ir],
            "min_rolling_x1": x_r[ir],
            "min_ratio": s_r[ir] / s_v[iv] if s_v[iv] != 0 else np.nan,
            "asymmetry_vertical": asymmetry(x_v, s_v, c),
            "asymmetry_rolling": asymmetry(x_r, s_r, c),
        },
        coords={"x1_vertical": x_v, "x1_rolling": x_r},
        attrs={
            "stage": stage,
            "case": f"{case_name(ds_v)} vs {case_name(ds_r)}",
            "case_vertical": case_name(ds_v),
            "case_rolling": case_name(ds_r),
            "centre": c,
            "requested_depth": float(depth),
            "depth_choice": choice,
            "requested_x2": float(x2),
            **{f"{k}_vertical": v for k, v in at_v.items()},
            **{f"{k}_rolling": v for k, v in at_r.items()},
        },
    )
