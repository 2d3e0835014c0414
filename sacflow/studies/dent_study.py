"""The dented-surface study: how much a dent costs in rolling-contact fatigue.

A study is two campaigns on the same grid and load path (``pipelines/dent-study.toml``, dents
swept over depth × width × load, and ``pipelines/dent-study-smooth.toml``, the smooth surface at
each load), the fatigue stage (:func:`sacflow.compare.fatigue_index.fatigue`) on every run, and
one summary Dataset along ``case`` comparing each dented case with the smooth case at its load:

* ``dang_van_max`` and ``dang_van_ratio`` (over the smooth case), ``crossland_max`` and
  ``crossland_ratio``: maxima over the middle of the rolled track (cuboids more than two Hertz
  radii from both ends, :data:`~sacflow.compare.fatigue_index.TRACK_MARGIN_RADII`), which the whole
  contact passed: near the ends the load was put on and taken off in place, a cycle that is not
  the rolling one;
* where the maximum sits relative to the dent: ``dang_van_max_offset`` along the rolling
  direction (positive: downstream of the dent centre, the side the contact moves towards),
  ``dang_van_max_lateral`` across it and ``dang_van_max_depth``;
* ``residual_stress_11_min`` and its depth, ``max_plastic_strain``, each with the smooth value
  (in the middle of the track too);
* ``pressure_peak_ratio``: highest contact pressure over the pass over that of the smooth case.

Coordinates along ``case``: ``dent_depth`` A, ``dent_width`` w, ``dent_slope`` A/w and ``load``.
The dent profile is ``A cos(2π r/w) exp(−decay r²/w²)`` (Jacq et al. 2002, eq. 27): its slope
A/w is the parameter the pressure peak grows with (Coulon et al., "Effect of a dent on the
pressure distribution in dry point contacts").
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from sacflow.compare.core import case_of
from sacflow.compare.fatigue_index import fatigue, track_middle
from sacflow.compare.output import write
from sacflow.compare.plots import plot_fatigue
from sacflow.config.schema import Case
from sacflow.errors import SacflowError
from sacflow.storage.atomic_file import write_atomically

__all__ = [
    "STUDY_RESULTS",
    "DentStudyError",
    "case_metrics",
    "dent_summary",
    "fatigue_results",
    "plot_index_vs_slope",
    "plot_worst_case",
    "write_summary",
]

UM, MPA = 1e6, 1e-6


class DentStudyError(SacflowError):
    """The study cannot be summarised: a missing smooth reference, a run without results."""


#: Units and long names of the study summary variables.
STUDY_RESULTS: dict[str, tuple[str, str]] = {
    "dent_depth": ("m", "dent depth A"),
    "dent_width": ("m", "dent width w"),
    "dent_slope": ("1", "dent slope A / w"),
    "load": ("N", "normal load"),
    "dang_van_max": ("1", "maximum Dang Van index in the middle of the track"),
    "dang_van_max_smooth": ("1", "maximum Dang Van index of the smooth case"),
    "dang_van_ratio": ("1", "maximum Dang Van index / that of the smooth case"),
    "dang_van_max_offset": ("m", "position of the maximum downstream of the dent centre"),
    "dang_van_max_lateral": ("m", "position of the maximum across the track from the dent"),
    "dang_van_max_depth": ("m", "depth of the maximum Dang Van index"),
    "crossland_max": ("1", "maximum Crossland index in the middle of the track"),
    "crossland_ratio": ("1", "maximum Crossland index / that of the smooth case"),
    "residual_stress_11_min": ("Pa", "minimum residual σ11 after the pass"),
    "residual_stress_11_min_depth": ("m", "depth of the minimum residual σ11"),
    "residual_stress_11_min_smooth": ("Pa", "minimum residual σ11 of the smooth case"),
    "max_plastic_strain": ("1", "maximum equivalent plastic strain after the pass"),
    "max_plastic_strain_smooth": ("1", "maximum equivalent plastic strain, smooth case"),
    "peak_pressure": ("Pa", "highest contact pressure over the pass"),
    "pressure_peak_ratio": ("1", "highest contact pressure / that of the smooth case"),
}


@dataclass(frozen=True)
class StudyCase:
    """A finished run of the study: its name, file and case."""

    name: str
    path: Path
    case: Case


def _done_cases(manifest: str | Path) -> list[StudyCase]:
    """Return the finished runs of a campaign manifest, in campaign order."""
    manifest = Path(manifest)
    try:
        records = json.loads(manifest.read_text())["cases"]
    except (OSError, ValueError, KeyError) as exc:
        raise DentStudyError(f"{manifest}: not a campaign manifest ({exc})") from None
    cases = []
    for record in records:
        if record.get("status") not in ("done", "skipped"):
            continue
        path = manifest.parent / record["path"]
        with xr.open_dataset(path) as ds:
            cases.append(StudyCase(record["name"], path, case_of(ds)))
    return cases


def fatigue_results(
    manifest: str | Path,
    out_dir: str | Path,
    limits: tuple[float, float] | None = None,
    progress: bool = True,
) -> dict[str, Path]:
    """Fatigue stage on every finished run of a campaign; results kept when still valid.

    A result ``<out_dir>/<case>-fatigue.nc`` (and its ``.png``) is computed unless one is there
    for the same run (its ``case_id``) and the same endurance limits.

    Parameters
    ----------
    manifest : path
        ``<out>/<campaign>.manifest.json``.
    out_dir : path
        Folder of the fatigue results.
    limits : (bending, torsion), optional
        Endurance limits [Pa]; default those of the fatigue stage.
    progress : bool
        Print one line per computed result.

    Returns
    -------
    dict
        Case name -> result file.
    """
    bending, torsion = limits if limits is not None else (None, None)
    out = Path(out_dir)
    found = {}
    for item in _done_cases(manifest):
        target = out / f"{item.name}-fatigue.nc"
        with xr.open_dataset(item.path) as run:
            case_id = run.attrs.get("case_id")
        if not _still_valid(target, case_id, limits):
            result = fatigue(item.path, bending_limit=bending, torsion_limit=torsion)
            write(result, out, target.stem)
            if progress:
                print(f"fatigue: {item.name}: Dang Van max {float(result['dang_van_max']):.3f}",
                      flush=True)
        found[item.name] = target
    return found


def _still_valid(target: Path, case_id: Any, limits: tuple[float, float] | None) -> bool:
    if not target.exists():
        return False
    with xr.open_dataset(target) as old:
        same_run = old.attrs.get("case_id") == case_id
        same_limits = limits is None and old.attrs.get("limits_source") != "given" or (
            limits is not None
            and (old.attrs.get("bending_limit"), old.attrs.get("torsion_limit")) == limits
        )
    return bool(same_run and same_limits)


def case_metrics(run_path: str | Path, fatigue_path: str | Path) -> dict[str, float]:
    """Summary numbers of one run and its fatigue result (see the module docstring).

    Parameters
    ----------
    run_path : path
        The run file (residual σ11, plastic strain and contact pressure are read from it).
    fatigue_path : path
        Its fatigue-stage result.
    """
    with xr.open_dataset(run_path) as run, xr.open_dataset(fatigue_path) as fat:
        case = case_of(run)
        last = run.sizes["step"] - 1
        middle = track_middle(run, float(fat.attrs["track_margin"]))[:, :, None]
        s11 = _residual(run, last).sel(component="11").transpose("x1", "x2", "x3")
        k = np.unravel_index(int(np.argmin(np.where(middle, s11.values, np.inf))), s11.shape)
        eps = run["equivalent_plastic_strain"].isel(step=last).transpose("x1", "x2", "x3")
        eps_max = float(np.max(np.where(middle, eps.values, -np.inf)))
        origin, direction = _dent_frame(case)
        if not np.isfinite(float(fat["dang_van_track_max"])):
            raise DentStudyError(
                f"{run_path}: the rolled track is too short to have a middle (cuboids more than "
                f"{fat.attrs['track_margin'] * UM:.0f} µm from both ends); roll farther"
            )
        x1, x2 = float(fat["dang_van_track_max_x1"]), float(fat["dang_van_track_max_x2"])
        along = (x1 - origin[0]) * direction[0] + (x2 - origin[1]) * direction[1]
        across = -(x1 - origin[0]) * direction[1] + (x2 - origin[1]) * direction[0]
        return {
            "dang_van_max": float(fat["dang_van_track_max"]),
            "dang_van_max_offset": along,
            "dang_van_max_lateral": across,
            "dang_van_max_depth": float(fat["dang_van_track_max_depth"]),
            "crossland_max": float(fat["crossland_track_max"]),
            "residual_stress_11_min": float(s11.values[k]),
            "residual_stress_11_min_depth": float(s11["x3"].values[k[s11.dims.index("x3")]]),
            "max_plastic_strain": eps_max,
            "peak_pressure": float(np.nanmax(run["max_pressure"].values)),
        }


def _residual(run: xr.Dataset, last: int) -> xr.DataArray:
    """Return the residual stress after the pass: stored, or the total stress once unloaded."""
    if "residual_stress" in run.variables:
        return run["residual_stress"].isel(step=last)
    if float(run["load"].values[last]) == 0.0 and "stress" in run.variables:
        return run["stress"].isel(step=last)
    raise DentStudyError(f"{run.attrs.get('source', 'run')}: neither residual_stress nor the "
                         "stress after unloading is stored")


def _dent_frame(case: Case) -> tuple[tuple[float, float], tuple[float, float]]:
    """Centre of the first dent (origin for a smooth surface) and the rolling direction."""
    dents = getattr(case.surface, "dents", ())
    origin = (dents[0].x1, dents[0].x2) if dents else (0.0, 0.0)
    rolls = [s for s in case.load_path if s.kind == "roll"]
    if not rolls:
        return origin, (1.0, 0.0)
    d = np.asarray(rolls[0].direction, dtype=float)
    d = d / np.linalg.norm(d)
    return origin, (float(d[0]), float(d[1]))


def _load(case: Case) -> float:
    return max(float(getattr(s, "to", 0.0)) for s in case.load_path)


def _reference_key(case: Case) -> str:
    """Return what a dented case and its smooth reference share: all but surface and name."""
    ident = case.identity()
    ident.pop("surface", None)
    return json.dumps(ident, sort_keys=True)


def dent_summary(
    dented: str | Path, smooth: str | Path, fatigue_dir: str | Path
) -> xr.Dataset:
    """Summary Dataset of a dent study along ``case`` (see the module docstring).

    Parameters
    ----------
    dented, smooth : path
        Manifests of the dented campaign and of the smooth-reference campaign.
    fatigue_dir : path
        Folder of the fatigue results (:func:`fatigue_results` of both campaigns).

    Raises
    ------
    DentStudyError
        A dented case has no smooth case with the same bodies, grid, load path and solver.
    """
    fatigue_dir = Path(fatigue_dir)
    smooth_cases = {_reference_key(c.case): c for c in _done_cases(smooth)}
    rows, coords = [], []
    for item in _done_cases(dented):
        reference = smooth_cases.get(_reference_key(item.case))
        if reference is None:
            raise DentStudyError(
                f"{item.name}: no smooth case with the same bodies, grid, load path and solver "
                f"in {smooth}; the smooth campaign must mirror the dented one"
            )
        rows.append(_compare(item, reference, fatigue_dir))
        dent = item.case.surface.dents[0]  # type: ignore[union-attr]
        coords.append((item.name, dent.depth, dent.width, dent.depth / dent.width,
                       _load(item.case)))
    if not rows:
        raise DentStudyError(f"{dented}: no finished dented case to summarise")
    names, depth, width, slope, load = (list(c) for c in zip(*coords, strict=True))
    data = {k: ("case", np.array([r[k] for r in rows])) for k in rows[0]}
    ds = xr.Dataset(data, coords={"case": names, "dent_depth": ("case", depth),
                                  "dent_width": ("case", width), "dent_slope": ("case", slope),
                                  "load": ("case", load)})
    for name in ds.variables:
        if name in STUDY_RESULTS:
            units, long_name = STUDY_RESULTS[str(name)]
            ds[name].attrs.update(units=units, long_name=long_name)
    ds["case"].attrs.update(units="1", long_name="case name")
    ds.attrs.update(Conventions="CF-1.10", title="dent study summary",
                    dented_manifest=str(dented), smooth_manifest=str(smooth))
    return ds


def _compare(item: StudyCase, reference: StudyCase, fatigue_dir: Path) -> dict[str, float]:
    mine = case_metrics(item.path, _fatigue_file(fatigue_dir, item.name))
    ref = case_metrics(reference.path, _fatigue_file(fatigue_dir, reference.name))
    return mine | {
        "dang_van_max_smooth": ref["dang_van_max"],
        "dang_van_ratio": mine["dang_van_max"] / ref["dang_van_max"],
        "crossland_ratio": mine["crossland_max"] / ref["crossland_max"],
        "residual_stress_11_min_smooth": ref["residual_stress_11_min"],
        "max_plastic_strain_smooth": ref["max_plastic_strain"],
        "pressure_peak_ratio": mine["peak_pressure"] / ref["peak_pressure"],
    }


def _fatigue_file(folder: Path, name: str) -> Path:
    path = folder / f"{name}-fatigue.nc"
    if not path.exists():
        raise DentStudyError(f"{path}: no fatigue result for {name}; run fatigue_results first")
    return path


def plot_index_vs_slope(summary: xr.Dataset) -> Figure:
    """Dang Van ratio and pressure-peak ratio against the dent slope A/w, one line per load."""
    fig = Figure(figsize=(11.0, 4.2), layout="constrained")
    left, right = fig.subplots(1, 2)
    for load in np.unique(summary["load"].values):
        sel = summary.where(summary["load"] == load, drop=True).sortby("dent_slope")
        for ax, name in ((left, "dang_van_ratio"), (right, "pressure_peak_ratio")):
            for width in np.unique(sel["dent_width"].values):
                part = sel.where(sel["dent_width"] == width, drop=True)
                ax.plot(part["dent_slope"], part[name], "o-",
                        label=f"W = {load:.4g} N, w = {width * UM:.0f} µm")
    left.set(xlabel="dent slope A/w", ylabel="max Dang Van index / smooth",
             title="fatigue index raised by the dent")
    right.set(xlabel="dent slope A/w", ylabel="peak pressure / smooth",
              title="pressure peak raised by the dent")
    for ax in (left, right):
        ax.axhline(1.0, color="k", lw=0.8)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle("dent study: dented over smooth, same grid and load")
    return fig


def plot_worst_case(summary: xr.Dataset, fatigue_dir: str | Path) -> Figure:
    """Dang Van maps of the case with the highest Dang Van ratio."""
    worst = str(summary["case"].values[int(np.argmax(summary["dang_van_ratio"].values))])
    with xr.open_dataset(_fatigue_file(Path(fatigue_dir), worst)) as result:
        return plot_fatigue(result.load())


def write_summary(summary: xr.Dataset, path: str | Path) -> Path:
    """Write the summary netCDF atomically (temporary file, then rename)."""
    return write_atomically(path, summary.to_netcdf)

