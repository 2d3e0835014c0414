"""Stages on the volume fields of one run: :func:`indentation`, :func:`residual_map`.

Profiles off the grid points are linear interpolations between cell centres (fields are constant
per cuboid, so this is the natural continuous reading); maps are taken in the cuboid layer
nearest to the requested depth, whose actual depth is recorded in the attributes. A depth
outside the cuboid box is an error (never its bottom layer read as that depth); by default the
map is taken in the layer of the extreme residual stress.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, Literal

import numpy as np
import xarray as xr

from sacflow.compare.core import (
    CompareError,
    RunLike,
    build,
    case_name,
    load_run,
    max_load_index,
    nearest_inside,
    require,
    step_index,
)
from sacflow.solver.state import COMPONENTS

__all__ = ["column_at", "indentation", "quadratic_at", "refined_peak", "residual_map"]

#: Points of the Lagrange interpolation of :func:`quadratic_at` along each axis.
QUADRATIC_POINTS = 3


def refined_peak(values: np.ndarray, coords: Sequence[np.ndarray]) -> tuple[float, list[float]]:
    """Maximum of a cell-centred field refined below the cell size, and where it lies.

    A parabola through the largest cell value and its two neighbours along each axis (uniform
    spacing) gives a sub-cell offset ``s = (f₋ − f₊) / (2 (f₋ − 2f₀ + f₊))`` and a value gain
    ``−(f₋ − f₊) s / 4`` (≥ 0); the gains of the axes add (a separable quadratic model). At the
    edge of the grid, or where the three values are not concave, that axis is left as is. The raw
    maximum of piecewise-constant cells depends on where the cell centres fall relative to the
    true peak, which makes it converge erratically under refinement; this estimate does not.

    Parameters
    ----------
    values : ndarray
        Cell values, one axis per entry of ``coords``.
    coords : sequence of ndarray
        Uniformly spaced cell-centre coordinates of each axis.

    Returns
    -------
    value : float
        Refined maximum.
    position : list of float
        Its coordinates.
    """
    values = np.asarray(values, dtype=float)
    index = np.unravel_index(int(np.nanargmax(values)), values.shape)
    peak = float(values[index])
    value, position = peak, []
    for axis, x in enumerate(coords):
        i = index[axis]
        offset = 0.0
        if 0 < i < values.shape[axis] - 1:
            below = list(index)
            above = list(index)
            below[axis], above[axis] = i - 1, i + 1
            f_minus, f_plus = float(values[tuple(below)]), float(values[tuple(above)])
            curvature = f_minus - 2.0 * peak + f_plus
            if curvature < 0.0:
                offset = 0.5 * (f_minus - f_plus) / curvature
                value -= 0.25 * (f_minus - f_plus) * offset
        position.append(float(x[i]) + offset * float(x[1] - x[0]) if len(x) > 1 else float(x[i]))
    return value, position


def quadratic_at(values: np.ndarray, coords: Sequence[np.ndarray],
                 point: Sequence[float]) -> np.ndarray:
    """Value of a cell-centred field at ``point`` by quadratic interpolation along each axis.

    Along each of the leading ``len(coords)`` axes, the Lagrange parabola through the cell
    centre nearest to the point and its two neighbours (the three first or last at the edge,
    fewer on a grid of fewer cells) is evaluated there; the
    axes are done one after the other (a tensor-product rule, exact for a field quadratic in
    each coordinate). Read on the load axis of an even grid, which lies on a cell corner, the
    nearest cell is half a cell off along each direction (an error of order h², with the
    field's curvature across the axis); linear interpolation halves that error, the parabola
    removes it to order h³.

    Parameters
    ----------
    values : ndarray
        Cell values; the first ``len(coords)`` axes are interpolated, the others kept.
    coords : sequence of ndarray
        Increasing cell-centre coordinates of the interpolated axes.
    point : sequence of float
        Where to evaluate, one coordinate per entry of ``coords`` (inside the first and last
        centres, or at most half a cell beyond them).

    Returns
    -------
    ndarray
        The remaining axes of ``values`` at ``point``.
    """
    out = np.asarray(values, dtype=float)
    for x, x0 in zip(coords, point, strict=True):
        x = np.asarray(x, dtype=float)
        count = min(QUADRATIC_POINTS, x.size)
        nearest = int(np.argmin(np.abs(x - x0)))
        first = min(max(nearest - count // 2, 0), x.size - count)
        nodes = x[first:first + count]
        weights = np.array([np.prod([(x0 - nodes[m]) / (nodes[k] - nodes[m])
                                     for m in range(count) if m != k]) for k in range(count)])
        out = np.tensordot(weights, out[first:first + count], axes=(0, 0))
    return out


def column_at(column: np.ndarray, x3: np.ndarray, depths: Sequence[float]) -> list[float]:
    """Values of a layer-centred column at ``depths`` [m] by :func:`quadratic_at` along depth.

    NaN above the first layer centre or below the last (no extrapolation): how the convergence
    study reads the residual σ11 profile on the load axis.
    """
    return [float(quadratic_at(column, (x3,), (z,))) if x3[0] <= z <= x3[-1] else math.nan
            for z in depths]


def _argext(field: xr.DataArray, fn) -> tuple[float, dict[str, float]]:
    """Extreme value of ``field`` (``np.nanargmin``/``np.nanargmax``) and its coordinates."""
    values = np.asarray(field.values, dtype=float)
    if not np.isfinite(values).any():
        return np.nan, {str(d): np.nan for d in field.dims}
    flat = int(fn(values))
    where = np.unravel_index(flat, values.shape)
    coords = {str(d): float(field[d].values[i]) for d, i in zip(field.dims, where, strict=True)}
    return float(values.flat[flat]), coords


def indentation(
    run: RunLike,
    offsets: Sequence[float] = (0.0, 2e-6),
    method: Literal["linear", "nearest"] = "linear",
) -> xr.Dataset:
    """Equivalent plastic strain and residual σ11, σ33 versus depth (seed Figs. 13–16).

    Profiles on the load axis (the load point at the maximum load) and at lateral ``offsets``
    along x1 from it, at the maximum load and at the last step.

    Parameters
    ----------
    run : Dataset or path
        An elastic-plastic run with volume output at the maximum load and at the end.
    offsets : sequence of float
        x1 offsets of the profiles from the axis [m] (seed: 0 and 2 µm ≈ 0.25 a).
    method : {"linear", "nearest"}
        Lateral interpolation between cell centres.

    Returns
    -------
    xarray.Dataset
        ``equivalent_plastic_strain``, ``residual_stress_11``, ``residual_stress_33`` on
        (``when`` = max_load, last; ``offset``; ``x3``); summary numbers at the last step:
        ``max_plastic_strain`` and its position (``_x1``, ``_x2``, ``_depth``) over the whole
        body, ``print_depth`` (max residual displacement) and ``print_depth_refined`` (the
        same refined below the cell size: with an even number of cells the axis lies on a
        cell corner, half a cell from the nearest centres), on the axis
        ``residual_stress_11_first_layer``, ``residual_stress_33_first_layer``,
        ``residual_stress_11_axis_min`` (and ``_depth``; ``_refined``: the column
        interpolated to the axis by :func:`quadratic_at` instead of linearly, its minimum
        refined between layer centres by :func:`refined_peak`), ``residual_stress_11_axis_max``,
        ``residual_stress_33_axis_min``, ``residual_stress_33_axis_max``.
    """
    ds = load_run(run)
    stage = "indentation"
    require(
        ds, "load", "load_x1", "load_x2", "residual_stress", "residual_displacement", stage=stage
    )
    name = "equivalent_plastic_strain"
    steps = {w: step_index(ds, name, w, stage) for w in ("max_load", "last")}
    axis = ds.isel(step=max_load_index(ds))
    c1, c2 = float(axis["load_x1"]), float(axis["load_x2"])
    offset = np.atleast_1d(np.asarray(offsets, dtype=float))
    lateral = {"x1": xr.DataArray(c1 + offset, dims="offset"), "x2": c2}

    def at(index: int, var: str, component: str | None = None, where=lateral) -> xr.DataArray:
        da = ds[var].isel(step=index)
        if component is not None:
            da = da.sel(component=component)
        return da.interp(where, method=method)

    profiles: dict[str, list[np.ndarray]] = {}
    for index in steps.values():
        for var, key, comp in (
            (name, name, None),
            ("residual_stress", "residual_stress_11", "11"),
            ("residual_stress", "residual_stress_33", "33"),
        ):
            da = at(index, var, comp).transpose("offset", "x3")
            profiles.setdefault(key, []).append(np.asarray(da.values, dtype=float))

    last = steps["last"]
    peak, where = _argext(ds[name].isel(step=last), np.nanargmax)
    field = ds[name].isel(step=last).transpose("x1", "x2", "x3")
    refined, refined_at = refined_peak(
        field.values, [np.asarray(field[d].values, dtype=float) for d in ("x1", "x2", "x3")]
    )
    surface = step_index(ds, "residual_displacement", "last", stage)
    residual = ds["residual_displacement"].isel(step=surface).transpose("x1", "x2")
    print_refined, _ = refined_peak(
        residual.values, [np.asarray(residual[d].values, dtype=float) for d in ("x1", "x2")]
    )
    on_axis = {"x1": c1, "x2": c2}
    s11 = np.asarray(at(last, "residual_stress", "11", on_axis).values, dtype=float)
    stress_11 = ds["residual_stress"].isel(step=last).sel(component="11")
    stress_11 = stress_11.transpose("x1", "x2", "x3")
    s11_refined = quadratic_at(stress_11.values, [np.asarray(stress_11[d].values, dtype=float)
                                                  for d in ("x1", "x2")], (c1, c2))
    s33 = np.asarray(at(last, "residual_stress", "33", on_axis).values, dtype=float)
    x3 = np.asarray(ds["x3"].values, dtype=float)
    finite = np.isfinite(s11).any()
    data: dict[str, Any] = {
        k: (("when", "offset", "x3"), np.stack(v)) for k, v in profiles.items()
    }
    data.update(
        max_plastic_strain=peak,
        max_plastic_strain_x1=where["x1"],
        max_plastic_strain_x2=where["x2"],
        max_plastic_strain_depth=where["x3"],
        max_plastic_strain_refined=refined,
        max_plastic_strain_refined_depth=refined_at[2],
        print_depth=float(np.nanmax(residual.values)),
        print_depth_refined=print_refined,
        residual_stress_11_first_layer=float(s11[0]),
        residual_stress_33_first_layer=float(s33[0]),
        residual_stress_11_axis_min=float(np.nanmin(s11)) if finite else np.nan,
        residual_stress_11_axis_min_depth=float(x3[np.nanargmin(s11)]) if finite else np.nan,
        residual_stress_11_axis_min_refined=(-refined_peak(-s11_refined, (x3,))[0] if finite
                                             else np.nan),
        residual_stress_11_axis_max=float(np.nanmax(s11)) if finite else np.nan,
        residual_stress_33_axis_min=float(np.nanmin(s33)) if finite else np.nan,
        residual_stress_33_axis_max=float(np.nanmax(s33)) if finite else np.nan,
    )
    return build(
        data,
        coords={
            "when": list(steps),
            "step": ("when", [int(ds["step"].values[i]) for i in steps.values()]),
            "offset": offset,
            "profile_x1": ("offset", c1 + offset),
            "x3": x3,
        },
        attrs={
            "stage": stage,
            "case": case_name(ds),
            "axis_x1": c1,
            "axis_x2": c2,
            "first_layer_depth": float(x3[0]),
            "interpolation": method,
        },
    )


def residual_map(
    run: RunLike, depth: float | None = None, component: str = "11", step: str | int = "last"
) -> xr.Dataset:
    """Residual stress map in the plane x3 = ``depth`` (nearest layer) (seed Fig. 21).

    The seed's map (σ11 down to ≈ −500 MPa at x3 ≈ 50–65 µm under a dent) shows the layer where
    the residual stress is largest; without ``depth`` the map is taken there, in the layer
    holding the largest |residual σ_component| of the step, wherever the run's box lies.

    Parameters
    ----------
    run : Dataset or path
        An elastic-plastic run.
    depth : float, optional
        Depth of the plane [m]; the nearest cuboid layer is used. It must lie inside the cuboid
        box of the run (else :class:`~sacflow.compare.core.CompareError`). Default: the layer
        of the extreme residual stress component (attribute ``depth_choice``).
    component : {"11", "22", "33", "12", "13", "23"}
        Residual stress component.
    step : "last", "max_load" or int
        Step (see :func:`sacflow.compare.core.step_index`).

    Returns
    -------
    xarray.Dataset
        ``residual_stress_map`` (x1, x2); ``map_min``/``map_max`` and their positions;
        attributes ``depth`` (the layer used), ``requested_depth`` (if given), ``depth_choice``.
    """
    ds = load_run(run)
    stage = "residual-map"
    if str(component) not in COMPONENTS:
        raise CompareError(f"component must be one of {', '.join(COMPONENTS)}, not {component!r}")
    index = step_index(ds, "residual_stress", step, stage)
    volume = ds["residual_stress"].isel(step=index).sel(component=str(component))
    if depth is None:
        layer = _extreme_layer(volume)
        choice = f"layer of the extreme residual stress {component}"
    else:
        layer = nearest_inside(
            ds, "x3", float(depth), "--depth",
            fix="(or leave it out: the layer of the extreme residual stress)",
        )
        choice = "requested"
    field = volume.isel(x3=layer).transpose("x1", "x2")
    low, at_low = _argext(field, np.nanargmin)
    high, at_high = _argext(field, np.nanargmax)
    actual = float(ds["x3"].values[layer])
    return build(
        {
            "residual_stress_map": (("x1", "x2"), np.asarray(field.values, dtype=float)),
            "map_min": low,
            "map_min_x1": at_low["x1"],
            "map_min_x2": at_low["x2"],
            "map_max": high,
            "map_max_x1": at_high["x1"],
            "map_max_x2": at_high["x2"],
        },
        coords={"x1": ds["x1"].values, "x2": ds["x2"].values},
        attrs={
            "stage": stage,
            "case": case_name(ds),
            "component": str(component),
            "depth": actual,
            "requested_depth": None if depth is None else float(depth),
            "depth_choice": choice,
            "step": int(ds["step"].values[index]),
        },
        context={"component": component, "depth": f"{actual * 1e6:.4g} µm"},
    )


def _extreme_layer(volume: xr.DataArray) -> int:
    """Index along x3 of the layer holding the largest |value| of ``volume`` (x1, x2, x3)."""
    magnitude = np.abs(np.asarray(volume.transpose("x1", "x2", "x3").values, dtype=float))
    if not np.isfinite(magnitude).any():
        return 0
    return int(np.unravel_index(int(np.nanargmax(magnitude)), magnitude.shape)[2])
