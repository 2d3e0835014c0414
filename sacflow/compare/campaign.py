"""Stage :func:`campaign_summary`: scalar results of many runs along a ``case`` dimension.

Swept parameters become coordinates along ``case``. They are read from

* a campaign manifest (JSON file or the equivalent mapping): a list of entries, or a mapping
  ``{"cases": [...]}`` / ``{"runs": [...]}``, or ``{name_or_id: parameters}``; an entry is a
  mapping with ``parameters`` (or ``params``/``overrides``: dotted key -> value) and any of
  ``case_id``, ``name``, ``path`` to find its run, and optionally ``wall_time`` [s];
* a list of dotted keys of the case (e.g. ``["load_path.0.to", "body.hardening.n"]``), read
  from the case JSON stored in each run;
* by default, every dotted key of the stored case JSON whose value differs between the runs
  (``name`` and ``description`` aside).
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from sacflow.compare.core import RESULTS, CompareError, RunLike, build, case_name, load_run
from sacflow.config.dotted import cf_names, flatten
from sacflow.storage.run_reader import RunFileError, open_run

__all__ = [
    "RESULT_NAMES",
    "campaign_summary",
    "fill_wall_times",
    "flatten",
    "run_results",
    "summary_dataset",
]

Parameters = str | Path | Mapping[str, Any] | Sequence[str] | None
_IGNORED = {"name", "description"}
_WALL_TIME_ATTRS = ("wall_time", "wall_time_s", "elapsed")
_PARAMETER_KEYS = ("parameters", "params", "overrides")
#: The scalar results of one run (:func:`run_results`), in order.
RESULT_NAMES = (
    "max_plastic_strain", "max_plastic_strain_x1", "max_plastic_strain_x2",
    "max_plastic_strain_depth", "residual_stress_11_min", "residual_stress_11_max",
    "dent_depth", "peak_pressure", "contact_iterations_total", "plasticity_iterations_total",
    "iterations_total", "steps", "wall_time",
)


def _open(source: RunLike) -> xr.Dataset:
    if isinstance(source, xr.Dataset):
        return load_run(source)
    path = Path(source)
    if not path.exists():
        return load_run(path)  # interrupted run (parts) or a clear error
    try:
        ds = open_run(path, lazy=True)
    except RunFileError as exc:  # damaged, or not a run: what it is, what to do
        raise CompareError(str(exc)) from None
    ds.attrs.setdefault("source", str(path))
    return load_run(ds)


def _last_stored(ds: xr.Dataset, name: str) -> xr.DataArray | None:
    """``ds[name]`` at the last step where it holds finite values (None if never)."""
    if name not in ds.variables:
        return None
    for index in range(ds.sizes["step"] - 1, -1, -1):
        values = ds[name].isel(step=index).load()
        if np.isfinite(values.values).any():
            return values
    return None


def run_results(ds: xr.Dataset) -> dict[str, float]:
    """Scalar results of one run; NaN where the run lacks the output."""
    out: dict[str, float] = {}
    eps = _last_stored(ds, "equivalent_plastic_strain")
    keys = (
        "max_plastic_strain",
        "max_plastic_strain_x1",
        "max_plastic_strain_x2",
        "max_plastic_strain_depth",
    )
    if eps is not None:
        values = np.asarray(eps.transpose("x1", "x2", "x3").values, dtype=float)
        i1, i2, i3 = np.unravel_index(int(np.nanargmax(values)), values.shape)
        found = (values[i1, i2, i3], eps.x1.values[i1], eps.x2.values[i2], eps.x3.values[i3])
        out.update(zip(keys, map(float, found), strict=True))
    else:
        out.update(dict.fromkeys(keys, np.nan))
    stress = _last_stored(ds, "residual_stress")
    s11 = None if stress is None else np.asarray(stress.sel(component="11").values, dtype=float)
    out["residual_stress_11_min"] = np.nan if s11 is None else float(np.nanmin(s11))
    out["residual_stress_11_max"] = np.nan if s11 is None else float(np.nanmax(s11))
    dent = _last_stored(ds, "residual_displacement")
    out["dent_depth"] = np.nan if dent is None else float(np.nanmax(dent.values))

    def total(name: str) -> float:
        return float(np.nansum(ds[name].values)) if name in ds.variables else np.nan

    peak = ds["max_pressure"].values if "max_pressure" in ds.variables else [np.nan]
    out["peak_pressure"] = float(np.nanmax(peak)) if np.isfinite(peak).any() else np.nan
    out["contact_iterations_total"] = total("contact_iterations")
    out["plasticity_iterations_total"] = total("plasticity_iterations")
    out["iterations_total"] = out["contact_iterations_total"] + out["plasticity_iterations_total"]
    out["steps"] = float(ds.sizes["step"])
    wall = next((ds.attrs[k] for k in _WALL_TIME_ATTRS if k in ds.attrs), np.nan)
    try:
        out["wall_time"] = float(wall)
    except (TypeError, ValueError):
        out["wall_time"] = np.nan
    return out


def _manifest_entries(manifest: Any) -> list[dict[str, Any]]:
    """Normalise the accepted manifest layouts to a list of entries with ``parameters``."""
    if isinstance(manifest, Mapping):
        for key in ("cases", "runs"):
            if key in manifest:
                return _manifest_entries(manifest[key])
        return [
            {"name": key, "case_id": key, "parameters": dict(value)}
            for key, value in manifest.items()
            if isinstance(value, Mapping)
        ]
    if isinstance(manifest, list):
        entries: list[dict[str, Any]] = []
        for item in manifest:
            if not isinstance(item, Mapping):
                raise CompareError("manifest entries must be tables (JSON objects)")
            params: Mapping[str, Any] = next(
                (item[k] for k in _PARAMETER_KEYS if k in item), {}
            )
            entries.append({**item, "parameters": dict(params)})
        return entries
    raise CompareError("the campaign manifest must be a JSON object or list of cases")


def _manifest_runs(path: Path) -> list[Path]:
    """Run files of the finished cases of a campaign manifest (paths next to it)."""
    try:
        entries = _manifest_entries(json.loads(path.read_text()))
    except (OSError, ValueError) as exc:
        raise CompareError(f"{path}: not a readable JSON manifest ({exc})") from None
    runs = [
        path.parent / Path(str(e.get("path") or e.get("file") or f"{e['name']}.nc")).name
        for e in entries
        if e.get("status", "done") in ("done", "skipped") and (e.get("path") or e.get("name"))
    ]
    if not runs:
        raise CompareError(f"{path}: no finished case in the manifest")
    return runs


def _match(entries: list[dict[str, Any]], ds: xr.Dataset, source: Any) -> dict[str, Any]:
    """Return the manifest entry of a run: by case id, case name or run-file name."""
    keys = {str(ds.attrs.get("case_id", "")), case_name(ds)}
    stem = Path(str(source)).stem if not isinstance(source, xr.Dataset) else None
    for entry in entries:
        ids = {str(entry.get("case_id", "")), str(entry.get("name", ""))} - {""}
        path = entry.get("path") or entry.get("file")
        if ids & keys or (path is not None and Path(str(path)).stem in {stem, case_name(ds)}):
            return entry
    raise CompareError(f"run {case_name(ds)!r} is not listed in the campaign manifest")


def _coordinate(values: list[Any]) -> np.ndarray:
    """Numeric array if every value is a number, else strings."""
    if all(isinstance(v, int | float) and not isinstance(v, bool) for v in values):
        return np.asarray(values, dtype=float)
    return np.asarray([json.dumps(v) if not isinstance(v, str) else v for v in values])


def campaign_summary(
    runs: Sequence[RunLike] | RunLike, parameters: Parameters = None
) -> xr.Dataset:
    """Scalar results of the runs of a campaign along a ``case`` dimension.

    Parameters
    ----------
    runs : sequence of Dataset or path, or a manifest path
        The run files (or opened runs) of the campaign; or the campaign manifest
        ``<campaign>.manifest.json`` alone: its finished cases, with its parameters.
    parameters : path, mapping, sequence of str or None
        Where the swept parameters come from (see the module docstring).

    Returns
    -------
    xarray.Dataset
        Along ``case`` (case names; ``case_id`` coordinate; one coordinate per swept
        parameter, named by its dotted key): ``max_plastic_strain`` and its position,
        ``residual_stress_11_min``/``_max``, ``dent_depth``, ``peak_pressure``, iteration
        totals, ``steps`` and ``wall_time`` (NaN where a run lacks the output). Attribute
        ``parameters`` lists the swept keys in order.
    """
    runs, parameters = _run_sources(runs, parameters)
    datasets = [_open(r) for r in runs]
    try:
        cases = [flatten(json.loads(ds.attrs["case"])) for ds in datasets]
        entries, dotted = _parameter_sources(parameters)
        matched = (
            [_match(entries, ds, r) for ds, r in zip(datasets, runs, strict=True)]
            if (entries is not None)
            else None
        )
        keys, values = _swept(cases, matched, dotted)
        rows = [run_results(ds) for ds in datasets]
    finally:
        for ds, source in zip(datasets, runs, strict=True):
            if not isinstance(source, xr.Dataset):
                ds.close()
    if matched is not None:
        fill_wall_times(rows, matched)
    names = [case_name(ds) for ds in datasets]
    ids = [str(ds.attrs.get("case_id", "")) for ds in datasets]
    labels = (
        names
        if len(set(names)) == len(names)
        else [f"{n}-{i}" for n, i in zip(names, ids, strict=True)]
    )
    return summary_dataset(
        labels, rows, {k: values[k] for k in keys}, {"case_id": ids},
        attrs={"stage": "campaign-summary", "case": f"campaign of {len(rows)} runs"},
    )


def summary_dataset(
    cases: Sequence[str],
    rows: Sequence[Mapping[str, float]],
    parameters: Mapping[str, Sequence[Any]],
    labels: Mapping[str, Sequence[str]],
    attrs: Mapping[str, Any],
) -> xr.Dataset:
    """Assemble per-case scalar results along ``case``, swept parameters as CF-named coordinates.

    Parameters
    ----------
    cases : sequence of str
        Case labels (the ``case`` coordinate).
    rows : sequence of mapping
        One mapping of result name -> value per case (the keys of :func:`run_results`).
    parameters : mapping
        Dotted parameter path -> its value in each case. Each becomes a coordinate named by
        :func:`sacflow.config.dotted.cf_names` (``load_path.0.to`` -> ``load_path_0_to``) with the
        dotted path in its ``parameter_path`` attribute.
    labels : mapping
        Further string coordinates along ``case`` (``case_id``, ``status``...).
    attrs : mapping
        Global attributes; ``parameters`` (the coordinate names, in order) and
        ``parameter_paths`` (the dotted paths) are added.

    Returns
    -------
    xarray.Dataset
        Every name CF-valid; every variable with ``units`` and ``long_name``.
    """
    keys = list(parameters)
    results = list(rows[0]) if rows else list(RESULT_NAMES)
    names = cf_names(keys, taken=["case", *labels, *results])
    coords: dict[str, Any] = {"case": list(cases)}
    coords.update({k: ("case", np.asarray(list(v), dtype=str)) for k, v in labels.items()})
    coords.update({names[k]: ("case", _coordinate(list(parameters[k]))) for k in keys})
    data = {k: ("case", np.array([row[k] for row in rows], dtype=float)) for k in results}
    ds = build(
        data,
        coords=coords,
        attrs={**attrs, "parameters": " ".join(names[k] for k in keys),
               "parameter_paths": " ".join(keys)},
        metadata_of={names[k]: f"swept parameter {k}" for k in keys}
        | {k: k.replace("_", " ") for k in labels if k not in RESULTS},
    )
    for key in keys:
        ds[names[key]].attrs["parameter_path"] = key
    return ds


def _run_sources(
    runs: Sequence[RunLike] | RunLike, parameters: Parameters
) -> tuple[list[RunLike], Parameters]:
    """Return the runs as a list and the parameter source; a lone manifest gives both."""
    if isinstance(runs, str | Path | xr.Dataset):
        runs = [runs]
    runs = list(runs)
    first = runs[0] if len(runs) == 1 else None
    if first is not None and not isinstance(first, xr.Dataset) and str(first).endswith(".json"):
        parameters = first if parameters is None else parameters
        runs = list(_manifest_runs(Path(first)))
    if not runs:
        raise CompareError("campaign-summary needs at least one run")
    return runs, parameters


def _parameter_sources(
    parameters: Parameters,
) -> tuple[list[dict[str, Any]] | None, list[str] | None]:
    """Split ``parameters`` into manifest entries or dotted keys of the case (else both None).

    None for both: the swept parameters are the keys whose values differ between the runs.
    """
    if isinstance(parameters, str | Path):
        try:
            manifest = json.loads(Path(parameters).read_text())
        except (OSError, ValueError) as exc:
            raise CompareError(f"{parameters}: not a readable JSON manifest ({exc})") from None
        return _manifest_entries(manifest), None
    if isinstance(parameters, Mapping):
        return _manifest_entries(parameters), None
    if parameters is None:
        return None, None
    return None, [str(k) for k in parameters]


def _swept(
    cases: list[dict[str, Any]], matched: list[dict[str, Any]] | None, dotted: list[str] | None
) -> tuple[list[str], dict[str, list[Any]]]:
    """Return the swept keys and their value in each run.

    From the matched manifest entries, else the ``dotted`` keys of the flattened ``cases``,
    else every key whose value differs between the cases (``name`` and ``description`` aside).
    """
    if matched is not None:
        keys = list(dict.fromkeys(k for e in matched for k in e["parameters"]))
        return keys, {k: [e["parameters"].get(k) for e in matched] for k in keys}
    if dotted is not None:
        unknown = [k for k in dotted if any(k not in c for c in cases)]
        if unknown:
            raise CompareError(f"not a (scalar) field of every case: {', '.join(unknown)}")
        return dotted, {k: [c[k] for c in cases] for k in dotted}
    keys = [
        k
        for k in dict.fromkeys(k for c in cases for k in c)
        if k not in _IGNORED and len({json.dumps(c.get(k)) for c in cases}) > 1
    ]
    return keys, {k: [c.get(k) for c in cases] for k in keys}


def fill_wall_times(rows: list[dict[str, float]], matched: list[dict[str, Any]]) -> None:
    """Take a run's wall time from its manifest entry when the run file lacks it (in place)."""
    for row, entry in zip(rows, matched, strict=True):
        if entry.get("wall_time") is not None and not np.isfinite(row["wall_time"]):
            row["wall_time"] = float(entry["wall_time"])
