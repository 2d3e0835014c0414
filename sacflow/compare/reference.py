"""Stage :func:`case_vs_reference`: a stored field or profile against reference points.

References are tables of points: a CSV file (header row of column names, ``#`` comments, comma-
or whitespace-separated), a netCDF file or Dataset (a variable with coordinates; a run file is
selected at the same step and positions as the run), in SI units unless scaled.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from sacflow.compare.core import (
    CompareError,
    RunLike,
    build,
    case_name,
    load_run,
    nearest_inside,
    require,
    step_index,
)

__all__ = ["case_vs_reference", "read_table", "select_field"]

_NETCDF = {".nc", ".nc4", ".cdf", ".netcdf", ".h5", ".hdf5"}


def _read_csv(path: Path) -> pd.DataFrame:
    try:
        frame = pd.read_csv(path, comment="#", sep=None, engine="python", skipinitialspace=True)
    except (OSError, ValueError, pd.errors.ParserError) as exc:
        raise CompareError(f"{path}: not a readable CSV table ({exc})") from None
    frame.columns = [str(c).strip() for c in frame.columns]
    return frame


def _open_dataset(source: RunLike) -> tuple[xr.Dataset, str]:
    """Open a reference Dataset: a run (via open_run) or any netCDF file, and its label."""
    if isinstance(source, xr.Dataset):
        return source, case_name(source) if "case" in source.attrs else "reference"
    path = Path(source)
    if not path.is_file():
        raise CompareError(f"{path}: no such reference file")
    try:
        with xr.open_dataset(path) as ds:
            is_run = "case" in ds.attrs and "step" in ds.dims
            data = None if is_run else ds.load()
    except (OSError, ValueError, RuntimeError) as exc:
        problem = "its format is not netCDF" if "IO backends" in str(exc) else str(exc)
        raise CompareError(f"{path}: not a readable netCDF file ({problem}); give a netCDF or "
                           "CSV reference") from None
    if data is None:  # a run: opened again with its steps
        return load_run(path), str(path)
    return data, str(path)


def read_table(source: RunLike, columns: Sequence[str]) -> tuple[dict[str, np.ndarray], str]:
    """Columns ``columns`` of a reference (CSV path, netCDF path or Dataset) and its label."""
    if isinstance(source, xr.Dataset) or Path(source).suffix.lower() in _NETCDF:
        ds, label = _open_dataset(source)
        missing = [c for c in columns if c not in ds.variables]
        if missing:
            raise CompareError(f"{label}: no variable(s) {', '.join(missing)} in the reference")
        return {c: np.asarray(ds[c].values, dtype=float).ravel() for c in columns}, label
    path = Path(source)
    if not path.is_file():
        raise CompareError(f"{path}: no such reference file")
    frame = _read_csv(path)
    missing = [c for c in columns if c not in frame.columns]
    if missing:
        raise CompareError(
            f"{path}: no column(s) {', '.join(missing)} (found {', '.join(frame.columns)})"
        )
    return {c: frame[c].to_numpy(dtype=float) for c in columns}, str(path)


def select_field(
    ds: xr.Dataset,
    variable: str,
    step: str | int = "last",
    select: Mapping[str, Any] | None = None,
    stage: str = "case-vs-reference",
) -> tuple[xr.DataArray, dict[str, Any]]:
    """``ds[variable]`` at one step and at the positions of ``select`` (nearest cell).

    A position outside the stored cells of its coordinate raises
    :class:`~sacflow.compare.core.CompareError` (never the edge cell read as that position).

    Returns the selected field and the values actually selected (``step`` and each key of
    ``select``), for the result attributes.
    """
    require(ds, variable, stage=stage)
    da = ds[variable]
    chosen: dict[str, Any] = {}
    if "step" in da.dims:
        index = step_index(ds, variable, step, stage)
        da = da.isel(step=index)
        chosen["step"] = int(ds["step"].values[index])
    for key, value in (select or {}).items():
        if key not in da.dims:
            dims = ", ".join(map(str, da.dims))
            raise CompareError(f"cannot select {key}={value!r}: {variable!r} has dimensions {dims}")
        coord = da[key]
        if np.issubdtype(coord.dtype, np.number):
            index = nearest_inside(ds, key, float(value), f"--select {key}")
            da = da.isel({key: index})
            chosen[key] = float(da[key])
        else:
            if str(value) not in [str(v) for v in coord.values]:
                raise CompareError(
                    f"{key}={value!r} not found; choose one of {', '.join(map(str, coord.values))}"
                )
            da = da.sel({key: str(value)})
            chosen[key] = str(value)
    return da, chosen


def _reference_points(
    reference: RunLike,
    value_name: str,
    step: str | int,
    select: Mapping[str, Any] | None,
) -> tuple[pd.DataFrame, str]:
    """Return the reference as a table: coordinate columns and a ``value_name`` column."""
    if isinstance(reference, xr.Dataset) or Path(reference).suffix.lower() in _NETCDF:
        ref, label = _open_dataset(reference)
        if value_name not in ref.variables:
            raise CompareError(f"{label}: no variable {value_name!r} in the reference")
        if "case" in ref.attrs and "step" in ref[value_name].dims:  # another run
            da, _ = select_field(ref, value_name, step, select)
        else:
            da = ref[value_name]
        frame = da.reset_coords(drop=False).to_dataframe().reset_index()
        return frame, label
    path = Path(reference)
    if not path.is_file():
        raise CompareError(f"{path}: no such reference file")
    frame = _read_csv(path)
    if value_name not in frame.columns:
        raise CompareError(
            f"{path}: no column {value_name!r} (found {', '.join(frame.columns)}); "
            "name the value column with reference_variable"
        )
    return frame, str(path)


def case_vs_reference(
    run: RunLike,
    reference: RunLike,
    variable: str,
    *,
    step: str | int = "last",
    select: Mapping[str, Any] | None = None,
    reference_variable: str | None = None,
    value_scale: float = 1.0,
    coord_scale: float = 1.0,
) -> xr.Dataset:
    """Interpolate a stored field onto reference points and report the differences.

    Parameters
    ----------
    run : Dataset or path
        The run.
    reference : Dataset or path
        CSV or netCDF table of points: one column/coordinate per remaining dimension of the
        selected field (e.g. ``x1`` for a profile, ``x1, x2`` for a map) and a value column.
        A run file is taken at the same ``step`` and ``select`` as ``run``.
    variable : str
        Stored variable of the run, e.g. ``pressure``, ``residual_stress``.
    step : "last", "max_load" or int
        Step of the run (see :func:`sacflow.compare.core.step_index`).
    select : mapping, optional
        Fixed positions of the other dimensions, e.g. ``{"x2": 0.0, "component": "11"}``
        (nearest cell for coordinates).
    reference_variable : str, optional
        Name of the value column of the reference (default: ``variable``).
    value_scale, coord_scale : float
        Factors turning reference values and coordinates into SI units (e.g. 1e6 for MPa,
        1e-6 for µm).

    Returns
    -------
    xarray.Dataset
        Along ``point``: the coordinates, ``reference_value``, ``run_value`` (linear
        interpolation, NaN outside the run grid) and ``difference``; summary numbers
        ``max_abs_difference``, ``rms_difference``, ``max_relative_difference``
        (/ max |reference|), ``points``, ``points_outside``.
    """
    ds = load_run(run)
    stage = "case-vs-reference"
    field, chosen = select_field(ds, variable, step, select, stage)
    value_name = reference_variable or variable
    frame, label = _reference_points(reference, value_name, step, select)
    dims = [str(d) for d in field.dims]
    missing = [d for d in dims if d not in frame.columns]
    if missing:
        raise CompareError(
            f"{label}: no coordinate column(s) {', '.join(missing)} for the remaining "
            f"dimensions of {variable!r}; add them or fix them with select "
            f"(e.g. {missing[0]}=0)"
        )
    frame = frame[[*dims, value_name]].dropna()
    if frame.empty:
        raise CompareError(f"{label}: no reference point with a value of {value_name!r}")
    points = {d: ("point", frame[d].to_numpy(dtype=float) * coord_scale) for d in dims}
    ref_values = frame[value_name].to_numpy(dtype=float) * value_scale
    at = {d: xr.DataArray(v, dims="point") for d, (_, v) in points.items()}
    run_values = (
        np.asarray(field.interp(at).values, dtype=float)
        if dims
        else np.full(ref_values.shape, float(field))
    )
    diff = run_values - ref_values
    inside = np.isfinite(diff)
    if not inside.any():
        raise CompareError(f"{label}: every reference point lies outside the run grid")
    scale = float(np.max(np.abs(ref_values[inside])))
    max_abs = float(np.max(np.abs(diff[inside])))
    context = {"units": field.attrs.get("units", "1"), "variable": variable}
    return build(
        {
            "reference_value": ("point", ref_values),
            "run_value": ("point", run_values),
            "difference": ("point", diff),
            "max_abs_difference": max_abs,
            "rms_difference": float(np.sqrt(np.mean(diff[inside] ** 2))),
            "max_relative_difference": max_abs / scale if scale > 0 else np.nan,
            "points": int(inside.sum()),
            "points_outside": int((~inside).sum()),
        },
        coords={"point": np.arange(len(frame)), **points},
        attrs={
            "stage": stage,
            "case": case_name(ds),
            "variable": variable,
            "reference": label,
            "reference_variable": value_name,
            "interpolated_dims": " ".join(dims),
            **{f"selected_{k}": v for k, v in chosen.items()},
        },
        context=context,
    )
