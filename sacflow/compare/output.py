"""Writing and summarising stage results: ``stem.nc`` + ``stem.png``, one text block."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import xarray as xr

from sacflow.compare.plots import display_scale, plot
from sacflow.storage.atomic_file import replace_durably

__all__ = ["summary", "summary_numbers", "write"]


def write(result: xr.Dataset, out_dir: str | Path, stem: str, **plot_options) -> tuple[Path, Path]:
    """Write ``out_dir/stem.nc`` (the result) and ``out_dir/stem.png`` (its plot), atomically.

    Each file is written under a temporary name in ``out_dir`` and moved onto its final name
    with :func:`os.replace`: a reader never sees a half-written file.

    Parameters
    ----------
    result : xarray.Dataset
        The result of a stage (its ``stage`` attribute chooses the plot).
    out_dir : str or Path
        Output folder (created if needed).
    stem : str
        File name without suffix.
    **plot_options
        Passed to the stage's plot function (e.g. ``result_name`` for campaign-summary).

    Returns
    -------
    (Path, Path)
        The netCDF and PNG paths.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    targets = (out / f"{stem}.nc", out / f"{stem}.png")
    tmps = [t.with_name(f".{t.name}.{os.getpid()}.tmp") for t in targets]
    fig = plot(result, **plot_options)
    try:
        result.to_netcdf(tmps[0], format="NETCDF4")
        fig.savefig(tmps[1], format="png", dpi=120)
        for tmp, target in zip(tmps, targets, strict=True):
            replace_durably(tmp, target)
    finally:
        for tmp in tmps:
            tmp.unlink(missing_ok=True)
    return targets


def _value(value: float, units: str) -> str:
    if not np.isfinite(value):
        return "n/a"
    factor, shown = display_scale(units, [value])
    if units == "1" and value != 0 and (abs(value) < 1e-2 or abs(value) >= 1e4):
        return f"{value:.4g}"
    return f"{value * factor:.4g} {shown if shown != '1' else ''}".rstrip()


def summary_numbers(result: xr.Dataset) -> dict[str, tuple[float, str]]:
    """Return a result's summary numbers: ``{name: (value, units)}`` of its 0-d variables (SI)."""
    return {
        str(name): (float(var), var.attrs.get("units", "1"))
        for name, var in result.data_vars.items()
        if var.ndim == 0
    }


def summary(result: xr.Dataset) -> str:
    """Return the summary numbers of a result (its 0-d variables) as a short text block.

    A stage that concludes (attribute ``verdict``: the ``passes`` stage's shakedown or
    ratcheting) says so on the line after the title.
    """
    lines = [f"{result.attrs.get('stage', 'compare')}: {result.attrs.get('case', '')}"]
    if "verdict" in result.attrs:  # the stage's conclusion first (passes: shakedown or not)
        lines.append(f"  verdict: {result.attrs['verdict']}")
    numbers = summary_numbers(result)
    width = max((len(n) for n in numbers), default=0)
    for name, (value, units) in numbers.items():
        text = _value(value, units)
        lines.append(f"  {name:<{width}}  {text:>14}  {result[name].attrs.get('long_name', '')}")
    if "case" in result.dims:  # campaign: one line per case
        params = result.attrs.get("parameters", "").split()
        shown = ("max_plastic_strain", "dent_depth", "peak_pressure", "iterations_total")
        for i, case in enumerate(result["case"].values):
            parts = [f"{p}={result[p].values[i]}" for p in params]
            parts += [
                f"{k}={_value(float(result[k].values[i]), result[k].attrs['units'])}" for k in shown
            ]
            lines.append(f"  {case}: " + ", ".join(parts))
    return "\n".join(lines)
