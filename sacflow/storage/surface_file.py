"""Measured surfaces: read a height file (netCDF or text columns) into arrays.

The only module that reads surface files; the solver receives the heights as a
:class:`~sacflow.solver.state.MeasuredSurface` (:func:`load_surface`), and
:mod:`sacflow.storage.case_file` checks
the file when a case is loaded (:func:`read_measured_surface`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sacflow.config.schema import Case, Measured
from sacflow.errors import SacflowError
from sacflow.solver.state import MeasuredSurface

__all__ = ["TEXT_SURFACE_FORMAT", "load_surface", "read_measured_surface"]

#: File suffixes read as netCDF when the format is "auto".
_NETCDF_SUFFIXES = {".nc", ".nc4", ".cdf", ".netcdf", ".h5", ".hdf5"}


def load_surface(case: Case) -> MeasuredSurface | None:
    """Return the measured surface a case names (read from its file), or None for other kinds.

    Raises
    ------
    SacflowError
        Naming ``surface.path`` and the reason when the file cannot be read as a surface.
    """
    surf = case.surface
    if not isinstance(surf, Measured):
        return None
    try:
        return read_measured_surface(surf.path, surf.format, surf.variable)
    except ValueError as exc:
        raise SacflowError(f"surface.path {surf.path}: {exc}") from None


def read_measured_surface(
    path: str | Path, fmt: str = "auto", variable: str = "height"
) -> MeasuredSurface:
    """Read a measured surface file.

    Formats: ``netcdf`` (a 2-D variable ``variable`` with coordinates in m) or ``text`` (three
    columns x1 x2 height [m], whitespace- or comma-separated, ``#`` comments, every grid point
    once, any order). ``auto`` picks netCDF for .nc/.nc4/.cdf/.h5 files.

    Raises
    ------
    ValueError
        With a one-line reason when the file is missing, unreadable or not a surface.
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError("file not found")
    if fmt == "auto":
        fmt = "netcdf" if path.suffix.lower() in _NETCDF_SUFFIXES else "text"
    try:
        surface = (
            _read_netcdf_surface(path, variable) if fmt == "netcdf" else _read_text_surface(path)
        )
    except (OSError, KeyError, IndexError, RuntimeError, TypeError) as exc:
        raise ValueError(f"not a readable {fmt} surface ({exc})") from None
    if surface.x1.size < 2 or surface.x2.size < 2 or not np.isfinite(surface.height).all():
        raise ValueError("needs at least 2 x 2 points and finite heights")
    return surface


#: The text surface format, stated in every message about a text surface file.
TEXT_SURFACE_FORMAT = (
    "expected three numeric columns x1 x2 height [m] per line, whitespace- or comma-separated, "
    "comment lines starting with #"
)


def _read_text_surface(path: Path) -> MeasuredSurface:
    """Read the three-column text format; a bad line is named with its number and the format.

    ``np.loadtxt`` reads well-formed files fast; when it fails, the lines are scanned once to
    name the first one that is not three numbers (a header ``x1 x2 height``, a missing column),
    with :data:`TEXT_SURFACE_FORMAT`.
    """
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise ValueError(f"not a text file (not UTF-8); {TEXT_SURFACE_FORMAT}") from None
    lines = [line.split("#")[0].strip() for line in text.splitlines()]
    first = next((line for line in lines if line), None)
    if first is None:
        raise ValueError(f"no data lines; {TEXT_SURFACE_FORMAT}")
    delimiter = "," if "," in first else None
    try:
        data = np.loadtxt(path, delimiter=delimiter, comments="#", ndmin=2, encoding="utf-8")
    except ValueError:
        raise ValueError(_first_bad_line(lines, delimiter)) from None
    if data.shape[1] != 3:
        raise ValueError(f"found {data.shape[1]} columns; {TEXT_SURFACE_FORMAT}")
    if not np.isfinite(data).all():
        row = int(np.flatnonzero(~np.isfinite(data).all(axis=1))[0])
        number = [i for i, line in enumerate(lines, start=1) if line][row]
        raise ValueError(f"line {number}: values must be finite numbers; {TEXT_SURFACE_FORMAT}")
    x1, i1 = np.unique(data[:, 0], return_inverse=True)
    x2, i2 = np.unique(data[:, 1], return_inverse=True)
    if np.unique(i1 * x2.size + i2).size != len(data) or x1.size * x2.size != len(data):
        raise ValueError("the points do not fill a rectangular x1-x2 grid, each point once")
    height = np.empty((x1.size, x2.size))
    height[i1, i2] = data[:, 2]
    return MeasuredSurface(x1, x2, height)


def _first_bad_line(lines: list[str], delimiter: str | None) -> str:
    """Message naming the first data line that is not three numbers (comments stripped)."""
    for number, line in enumerate(lines, start=1):
        if not line:
            continue
        fields = [f.strip() for f in line.split(delimiter)]
        try:
            values = [float(f) for f in fields]
        except ValueError:
            values = []
        if len(values) != 3:
            return f"line {number}: {line[:60]!r} is not three numbers; {TEXT_SURFACE_FORMAT}"
    return f"cannot read the numbers; {TEXT_SURFACE_FORMAT}"  # a form float() takes, loadtxt not


def _read_netcdf_surface(path: Path, variable: str) -> MeasuredSurface:
    import xarray as xr

    with xr.open_dataset(path) as ds:
        if variable not in ds:
            raise ValueError(f"no variable {variable!r} (found {list(ds.data_vars)})")
        da = ds[variable].load()
    if da.ndim != 2 or not all(d in da.coords for d in da.dims):
        raise ValueError(f"{variable!r} must be 2-D with coordinates on both dimensions")
    for name in (variable, *da.dims):
        units = (da if name == variable else da[name]).attrs.get("units", "m")
        if units not in ("m", "metre", "meter", "metres", "meters"):
            raise ValueError(f"{name!r} has units {units!r}; heights and coordinates must be in m")
    x1, x2 = (np.asarray(da[d].values, dtype=float) for d in da.dims)
    return MeasuredSurface(x1, x2, np.asarray(da.values, dtype=float))
