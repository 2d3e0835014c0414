"""Shared pieces of the comparison stages: errors, run access, step choice, result metadata.

Computation and metadata are separate layers: the stages compute bare arrays and hand
them to :func:`build`, which attaches ``units`` and ``long_name`` from the one table
:data:`RESULTS` (falling back on the run-file table
:data:`sacflow.storage.run_variables.RUN_VARIABLES`
for the quantities a result shares with a run, e.g. ``pressure``). Long names and units may hold
``{placeholders}`` filled from the ``context`` given to :func:`build` (a tensor component, the
units of a compared variable).

Conventions: SI units, x3 depth positive into the body, stress positive in tension,
residual displacement positive into the body (an indent is positive).

Step choice, used by every stage:

* *max-load step*: the last step of the first uninterrupted run of steps at the maximum load
  (load ≥ (1 − 1e-9) · max): the end of loading, or of a hold, or of the rolling at that load;
* *last step*: the last stored step; for volume fields the last step where they were stored
  (volume output may be written every k steps, NaN elsewhere).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import xarray as xr
from pydantic import ValidationError

from sacflow.config.schema import Case
from sacflow.errors import InputError
from sacflow.storage.run_reader import RunFileError, open_run
from sacflow.storage.run_variables import COORDINATES, RUN_VARIABLES

__all__ = [
    "RESULTS",
    "CompareError",
    "RunLike",
    "build",
    "case_name",
    "case_of",
    "cell_bounds",
    "finite_steps",
    "load_run",
    "max_load_index",
    "nearest",
    "nearest_inside",
    "require",
    "step_index",
]

#: A run: an opened Dataset (from :func:`sacflow.storage.run_reader.open_run`) or the path of a run
#: file.
RunLike = xr.Dataset | str | Path

#: Relative tolerance defining "at the maximum load".
MAX_LOAD_RTOL = 1e-9
#: Slack of the stored-range check, in cell sizes (round-off of a position given on a bound).
RANGE_SLACK = 1e-9
#: What each coordinate of a run covers, for the messages of :func:`nearest_inside`.
COVERED = {"x1": "surface grid", "x2": "surface grid", "x3": "cuboid box"}


class CompareError(InputError):
    """A comparison cannot be made: wrong file, missing variable or output, bad option."""


class Meta(NamedTuple):
    """Units and long name of one result variable (``{placeholders}`` allowed)."""

    units: str
    long_name: str


#: Units and long names of every result variable. The only place result metadata lives.
RESULTS: dict[str, Meta] = {
    # coordinates
    "when": Meta("1", "state at which the profiles are taken"),
    "offset": Meta("m", "lateral offset of the profile from the load axis along x1"),
    "profile_x1": Meta("m", "x1 position of the profile"),
    "branch": Meta("1", "load path branch of the step"),
    "x1_vertical": Meta("m", "x1 of the vertical-loading run (body frame)"),
    "x1_rolling": Meta("m", "x1 of the rolling run (body frame)"),
    "track_distance": Meta("m", "distance from the start of the rolled track"),
    "hertz_point": Meta("1", "point of the Hertz load-approach curve"),
    "reference_point": Meta("1", "point of the reference load-approach curve"),
    "point": Meta("1", "reference point"),
    "case": Meta("1", "case name"),
    "case_id": Meta("1", "case id (hash of the canonical case JSON)"),
    # hertz_check
    "approach_hertz": Meta("m", "Hertz approach at the same load, (9 W² / 16 R E*²)^(1/3)"),
    "approach_error": Meta("1", "relative error of the approach against Hertz"),
    "pressure_hertz": Meta("Pa", "Hertz pressure at the same points"),
    "p0": Meta("Pa", "peak pressure of the run at the maximum load"),
    "p0_hertz": Meta("Pa", "Hertz peak pressure p0 at the maximum load"),
    "p0_error": Meta("1", "relative error of the peak pressure against Hertz"),
    "contact_radius": Meta("m", "contact radius (contact_area / π)^½ at the maximum load"),
    "contact_radius_hertz": Meta("m", "Hertz contact radius a at the maximum load"),
    "contact_radius_error": Meta("1", "relative error of the contact radius against Hertz"),
    "approach_max": Meta("m", "approach at the maximum load"),
    "approach_max_hertz": Meta("m", "Hertz approach at the maximum load"),
    "approach_max_error": Meta("1", "relative error of the approach at the maximum load"),
    "profile_error": Meta("1", "max |p − p_Hertz| / p0_Hertz along the profile"),
    # load_approach
    "approach_shifted": Meta("m", "unloading-branch approach shifted onto Hertz at max load"),
    "hertz_approach": Meta("m", "approach of the elastic Hertz curve"),
    "hertz_load": Meta("N", "load of the elastic Hertz curve"),
    "reference_approach": Meta("m", "approach of the reference curve"),
    "reference_load": Meta("N", "load of the reference curve"),
    "max_load": Meta("N", "maximum load"),
    "residual_approach": Meta("m", "approach at the end of the last unloading step"),
    "unloading_shift": Meta("m", "shift of the unloading branch: δ(W_max) − δ_Hertz(W_max)"),
    "unloading_deviation": Meta(
        "1", "max |δ_shifted − δ_Hertz(W)| over the unloading branch / δ_Hertz(W_max)"
    ),
    # indentation
    "residual_stress_11": Meta("Pa", "residual stress σ11"),
    "residual_stress_33": Meta("Pa", "residual stress σ33"),
    "max_plastic_strain": Meta("1", "maximum equivalent plastic strain (last step)"),
    "max_plastic_strain_x1": Meta("m", "x1 of the maximum equivalent plastic strain"),
    "max_plastic_strain_x2": Meta("m", "x2 of the maximum equivalent plastic strain"),
    "max_plastic_strain_depth": Meta("m", "depth x3 of the maximum equivalent plastic strain"),
    "max_plastic_strain_refined": Meta(
        "1", "maximum equivalent plastic strain, refined below the cell size (refined_peak)"
    ),
    "max_plastic_strain_refined_depth": Meta("m", "depth of the refined maximum"),
    "print_depth": Meta("m", "residual print depth: max residual displacement (last step)"),
    "print_depth_refined": Meta(
        "m", "residual print depth refined below the cell size (refined_peak): at the axis"
    ),
    "residual_stress_11_first_layer": Meta("Pa", "residual σ11 on the axis, first layer"),
    "residual_stress_33_first_layer": Meta("Pa", "residual σ33 on the axis, first layer"),
    "residual_stress_11_axis_min": Meta("Pa", "minimum residual σ11 on the axis"),
    "residual_stress_11_axis_min_depth": Meta("m", "depth of the minimum residual σ11 on the axis"),
    "residual_stress_11_axis_min_refined": Meta(
        "Pa", "minimum residual σ11 on the axis, quadratic to the axis and refined in depth"
    ),
    "residual_stress_11_axis_max": Meta("Pa", "maximum residual σ11 on the axis"),
    "residual_stress_33_axis_min": Meta("Pa", "minimum residual σ33 on the axis"),
    "residual_stress_33_axis_max": Meta("Pa", "maximum residual σ33 on the axis"),
    # elastic_vs_plastic
    "pressure_elastic": Meta("Pa", "contact pressure of the elastic run at the maximum load"),
    "pressure_plastic": Meta("Pa", "contact pressure of the elastic-plastic run at max load"),
    "peak_elastic": Meta("Pa", "peak pressure along the profile, elastic run"),
    "peak_plastic": Meta("Pa", "peak pressure along the profile, elastic-plastic run"),
    "peak_elastic_x1": Meta("m", "x1 of the elastic peak pressure"),
    "peak_plastic_x1": Meta("m", "x1 of the elastic-plastic peak pressure"),
    "peak_ratio": Meta("1", "elastic peak pressure / elastic-plastic peak pressure"),
    # vertical_vs_rolling
    "residual_stress_11_vertical": Meta("Pa", "residual σ11 of the vertical-loading run"),
    "residual_stress_11_rolling": Meta("Pa", "residual σ11 of the rolling run"),
    "min_vertical": Meta("Pa", "minimum residual σ11, vertical loading"),
    "min_vertical_x1": Meta("m", "x1 of the minimum residual σ11, vertical loading"),
    "min_rolling": Meta("Pa", "minimum residual σ11, rolling"),
    "min_rolling_x1": Meta("m", "x1 of the minimum residual σ11, rolling"),
    "min_ratio": Meta("1", "minimum residual σ11 rolling / vertical"),
    "asymmetry_vertical": Meta(
        "1", "max |σ(c+s) − σ(c−s)| / |min σ| about the centre c, vertical loading"
    ),
    "asymmetry_rolling": Meta("1", "max |σ(c+s) − σ(c−s)| / |min σ| about the centre c, rolling"),
    # track
    "plateau": Meta("m", "steady-state residual displacement (median over 2nd half of track)"),
    "steady_state_distance": Meta("m", "rolled distance after which the profile is steady"),
    "steady_state_distance_over_a": Meta("1", "steady-state distance / Hertz contact radius"),
    "track_start": Meta("m", "x1 of the load at the start of the rolled track"),
    "track_end": Meta("m", "x1 of the load at the end of the rolled track"),
    "hertz_radius": Meta("m", "Hertz contact radius a at the maximum load"),
    # residual_map
    "residual_stress_map": Meta("Pa", "residual stress σ{component} in the plane x3 = {depth}"),
    "map_min": Meta("Pa", "minimum residual σ{component} in the plane"),
    "map_min_x1": Meta("m", "x1 of the minimum"),
    "map_min_x2": Meta("m", "x2 of the minimum"),
    "map_max": Meta("Pa", "maximum residual σ{component} in the plane"),
    "map_max_x1": Meta("m", "x1 of the maximum"),
    "map_max_x2": Meta("m", "x2 of the maximum"),
    # campaign_summary
    "residual_stress_11_min": Meta("Pa", "minimum residual σ11 in the body (last step)"),
    "residual_stress_11_max": Meta("Pa", "maximum residual σ11 in the body (last step)"),
    "dent_depth": Meta("m", "residual dent depth: max residual displacement (last step)"),
    "peak_pressure": Meta("Pa", "highest contact pressure over all steps"),
    "contact_iterations_total": Meta("1", "contact iterations, sum over steps"),
    "plasticity_iterations_total": Meta("1", "plasticity iterations, sum over steps"),
    "iterations_total": Meta("1", "contact + plasticity iterations, sum over steps"),
    "wall_time": Meta("s", "wall time of the run"),
    "steps": Meta("1", "number of stored steps"),
    # fatigue
    "dang_van": Meta("1", "Dang Van index max_t [τ(t) + a p(t)] / b over the stored steps"),
    "crossland": Meta("1", "Crossland index [√J2,a + α p_max] / β"),
    "sqrt_j2_amplitude": Meta("Pa", "√J2,a: radius of the minimum ball of the deviatoric path"),
    "hydrostatic_max": Meta("Pa", "maximum over the steps of the hydrostatic stress tr σ / 3"),
    "dang_van_step": Meta("1", "step at which the Dang Van index is reached"),
    "dang_van_max": Meta("1", "maximum Dang Van index in the body"),
    "dang_van_max_x1": Meta("m", "x1 of the maximum Dang Van index"),
    "dang_van_max_x2": Meta("m", "x2 of the maximum Dang Van index"),
    "dang_van_max_depth": Meta("m", "depth x3 of the maximum Dang Van index"),
    "dang_van_max_step": Meta("1", "step at which the maximum Dang Van index is reached"),
    "dang_van_track_max": Meta("1", "maximum Dang Van index in the middle of the rolled track"),
    "dang_van_track_max_x1": Meta("m", "x1 of the maximum in the middle of the track"),
    "dang_van_track_max_x2": Meta("m", "x2 of the maximum in the middle of the track"),
    "dang_van_track_max_depth": Meta("m", "depth x3 of the maximum in the middle of the track"),
    "crossland_max": Meta("1", "maximum Crossland index in the body"),
    "crossland_track_max": Meta("1", "maximum Crossland index in the middle of the rolled track"),
    "crossland_track_max_x1": Meta("m", "x1 of the Crossland maximum in the middle of the track"),
    "crossland_track_max_x2": Meta("m", "x2 of the Crossland maximum in the middle of the track"),
    "crossland_track_max_depth": Meta("m", "depth of the Crossland maximum, middle of the track"),
    "crossland_max_x1": Meta("m", "x1 of the maximum Crossland index"),
    "crossland_max_x2": Meta("m", "x2 of the maximum Crossland index"),
    "crossland_max_depth": Meta("m", "depth x3 of the maximum Crossland index"),
    # case_vs_reference
    "reference_value": Meta("{units}", "reference {variable}"),
    "run_value": Meta("{units}", "{variable} of the run at the reference points"),
    "difference": Meta("{units}", "run − reference"),
    "max_abs_difference": Meta("{units}", "max |run − reference|"),
    "rms_difference": Meta("{units}", "RMS of run − reference"),
    "max_relative_difference": Meta("1", "max |run − reference| / max |reference|"),
    "points": Meta("1", "reference points compared"),
    "points_outside": Meta("1", "reference points outside the run grid (not compared)"),
}


def metadata(name: str, context: Mapping[str, Any] | None = None) -> dict[str, str]:
    """``units`` and ``long_name`` of a result or run variable, placeholders filled."""
    if name in RESULTS:
        meta = RESULTS[name]
    elif name in RUN_VARIABLES:
        meta = Meta(RUN_VARIABLES[name].units, RUN_VARIABLES[name].long_name)
    elif name in COORDINATES:
        meta = Meta(COORDINATES[name].units, COORDINATES[name].long_name)
    else:
        raise KeyError(f"no metadata for result variable {name!r}; add it to compare.RESULTS")
    context = dict(context or {})
    return {"units": meta.units.format(**context), "long_name": meta.long_name.format(**context)}


def build(
    data_vars: Mapping[str, Any],
    coords: Mapping[str, Any] | None = None,
    attrs: Mapping[str, Any] | None = None,
    context: Mapping[str, Any] | None = None,
    metadata_of: Mapping[str, str] | None = None,
) -> xr.Dataset:
    """Assemble a result Dataset and attach ``units``/``long_name`` to every variable.

    Parameters
    ----------
    data_vars, coords : mapping
        As for :class:`xarray.Dataset`; a bare scalar is a 0-d variable (a summary number).
    attrs : mapping
        Global attributes (``stage``, ``case``, selections); ``None`` values are dropped and
        booleans stored as 0/1 so that the result writes to netCDF.
    context : mapping
        Values for the ``{placeholders}`` of :data:`RESULTS`.
    metadata_of : mapping
        Variables (e.g. swept parameters) whose metadata is given here as a long name (units 1).
    """
    variables = {k: v if isinstance(v, tuple) else ((), v) for k, v in data_vars.items()}
    ds = xr.Dataset(variables, coords=coords)
    extra = dict(metadata_of or {})
    for name in list(ds.variables):
        if name in extra:
            ds[name].attrs.update(units="1", long_name=extra[name])
        else:
            ds[name].attrs.update(metadata(str(name), context))
    ds.attrs.update(
        {k: int(v) if isinstance(v, bool) else v for k, v in (attrs or {}).items() if v is not None}
    )
    ds.attrs.setdefault("Conventions", "CF-1.10")
    return ds


# --------------------------------------------------------------------------- runs
def load_run(run: RunLike) -> xr.Dataset:
    """Return the Dataset of a run (opened by :func:`sacflow.storage.run_reader.open_run`)."""
    if isinstance(run, xr.Dataset):
        ds = run
    else:
        path = Path(run)
        try:
            ds = open_run(path)
        except FileNotFoundError:
            raise CompareError(f"{path}: no such run file") from None
        except RunFileError as exc:  # damaged, or not a run: what it is, what to do
            raise CompareError(str(exc)) from None
        ds.attrs.setdefault("source", str(path))
    if "case" not in ds.attrs or "step" not in ds.dims:
        raise CompareError(
            f"{_where(ds)}is not a sacflow run (no 'case' attribute or no 'step' dimension)"
        )
    return ds


def _where(ds: xr.Dataset) -> str:
    source = ds.attrs.get("source") or ds.encoding.get("source")
    return f"{source}: " if source else ""


def case_of(ds: xr.Dataset) -> Case:
    """Return the :class:`~sacflow.config.schema.Case` stored in the run's attributes."""
    try:
        return Case.model_validate_json(ds.attrs["case"])
    except (KeyError, ValidationError, ValueError) as exc:
        raise CompareError(
            f"{_where(ds)}cannot rebuild the case from the 'case' attribute "
            f"({str(exc).splitlines()[0]})"
        ) from None


def case_name(ds: xr.Dataset) -> str:
    """Name of the run's case (``"run"`` if it cannot be read)."""
    try:
        return str(json.loads(ds.attrs["case"])["name"])
    except (KeyError, TypeError, ValueError):
        return str(ds.attrs.get("title", "run"))


def require(ds: xr.Dataset, *names: str, stage: str) -> None:
    """Raise a :class:`CompareError` naming the variables of ``names`` missing from ``ds``."""
    missing = [n for n in names if n not in ds.variables]
    if missing:
        raise CompareError(
            f"{_where(ds)}run {case_name(ds)!r} has no variable(s) {', '.join(missing)} "
            f"needed by {stage} (add them to [output] fields of the case and run it again)"
        )


def finite_steps(da: xr.DataArray) -> np.ndarray:
    """Positions along ``step`` where ``da`` holds at least one finite value."""
    finite = np.isfinite(da.transpose("step", ...).values)
    return np.flatnonzero(finite.reshape(finite.shape[0], -1).any(axis=1))


def max_load_index(ds: xr.Dataset) -> int:
    """Position of the max-load step (see the module docstring)."""
    load = np.asarray(ds["load"].values, dtype=float)
    if load.size == 0 or not np.isfinite(load).any():
        raise CompareError(f"{_where(ds)}run {case_name(ds)!r} has no stored step with a load")
    at_max = np.flatnonzero(load >= np.nanmax(load) * (1.0 - MAX_LOAD_RTOL))
    first = at_max[0]
    run = at_max[at_max - first == np.arange(at_max.size)]  # first uninterrupted run
    return int(run[-1])


def step_index(ds: xr.Dataset, name: str, which: str | int, stage: str) -> int:
    """Position along ``step`` of the step whose values of ``name`` a stage uses.

    Parameters
    ----------
    which : {"last", "max_load"} or int
        ``"last"``: the last step where ``name`` is stored (not all NaN); ``"max_load"``: the
        last such step in the first run of steps at the maximum load; an int: that step number.
    """
    require(ds, name, stage=stage)
    stored = finite_steps(ds[name])
    what = f"{_where(ds)}run {case_name(ds)!r}"
    if isinstance(which, int | np.integer):
        found = np.flatnonzero(ds["step"].values == which)
        if found.size == 0 or found[0] not in stored:
            raise CompareError(f"{what} has no {name!r} at step {which}")
        return int(found[0])
    if which == "last":
        if stored.size == 0:
            raise CompareError(f"{what} stores no values of {name!r} on any step")
        return int(stored[-1])
    if which != "max_load":
        raise CompareError(f"step must be 'last', 'max_load' or a step number, not {which!r}")
    end = max_load_index(ds)
    load = np.asarray(ds["load"].values, dtype=float)
    start = end
    while start > 0 and load[start - 1] >= load[end] * (1.0 - MAX_LOAD_RTOL):
        start -= 1
    inside = stored[(stored >= start) & (stored <= end)]
    if inside.size == 0:
        raise CompareError(
            f"{what} has no {name!r} output at the maximum load (step {int(ds.step[end])}); "
            "store volume fields there (output.volume_every)"
        )
    return int(inside[-1])


def nearest(values: np.ndarray, target: float) -> int:
    """Index of the entry of ``values`` nearest to ``target``."""
    return int(np.argmin(np.abs(np.asarray(values, dtype=float) - target)))


def cell_bounds(values: np.ndarray, dim: str) -> tuple[float, float]:
    """Extent ``(low, high)`` [m] of the cells whose centres are ``values`` along ``dim``.

    Cells are uniform: each centre is half a spacing from its cell's faces. A single cuboid
    layer (``x3``) spans from the surface to twice its centre depth; a single surface cell has
    no known width (its centre only).
    """
    x = np.asarray(values, dtype=float)
    if x.size >= 2:
        half = 0.5 * (x[-1] - x[0]) / (x.size - 1)
        return float(x[0] - half), float(x[-1] + half)
    if dim == "x3":
        return 0.0, float(2.0 * x[0])
    return float(x[0]), float(x[0])


def nearest_inside(
    ds: xr.Dataset, dim: str, target: float, option: str, fix: str = ""
) -> int:
    """Index of the cell of ``dim`` nearest to ``target``, which must lie inside the stored cells.

    A position beyond the stored range is an error, not the edge cell: the nearest cell of a
    depth below the cuboid box is its bottom layer, whose numbers would be reported as those of
    the depth asked for (a 65 µm map read from the 13 µm layer of a 14 µm box).

    Parameters
    ----------
    ds : Dataset
        The run.
    dim : {"x1", "x2", "x3"}
        Coordinate searched.
    target : float
        Requested position [m].
    option : str
        How the user gave it (``"--depth"``), named in the message.
    fix : str
        What else to do, appended to the message (e.g. the default to fall back on).

    Raises
    ------
    CompareError
        Naming the option, the requested position and the stored range of the run.
    """
    values = np.asarray(ds[dim].values, dtype=float)
    low, high = cell_bounds(values, dim)
    slack = RANGE_SLACK * max(high - low, abs(high), 1e-300)
    if not (np.isfinite(target) and low - slack <= target <= high + slack):
        what = COVERED.get(dim, "grid")
        raise CompareError(
            f"{_where(ds)}{option} {target:.4g} m is outside the {what} of run "
            f"{case_name(ds)!r}: its cells cover {dim} in [{low:.4g}, {high:.4g}] m; "
            f"give {option} inside that range"
            + (f" {fix}" if fix else "")
        )
    return nearest(values, target)
