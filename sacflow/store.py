"""Run files: the only module that knows xarray and netCDF (DESIGN §4, STYLE 8).

One netCDF4 file per case, ``<out>/<case name>.nc``, dimensions ``step`` (unlimited), ``x1``,
``x2``, ``x3`` and ``component`` (``11 22 33 12 13 23``). :data:`VARIABLES` is the one table
of dims, units and long names; numerical code hands over bare arrays in a
:class:`~sacflow.state.State`.

Crash safety. :class:`RunWriter` writes each step as its own small file
``<path>.parts/step-000123.nc`` (temporary name, then ``os.replace``: a part is either complete or
absent). A normal end consolidates the parts into ``<path>`` the same way and removes the parts
folder, so ``<path>`` only ever exists complete (global attribute ``complete = 1``). After a crash,
:func:`open_run` reads the completed parts (``complete = 0``) and ``RunWriter(..., resume=True)``
carries on after them.

Parts are uncompressed (they are read once, at consolidation) and leave out the fields that hold
one value everywhere at their step, which they record by value in the attribute
:data:`UNIFORM_ATTR`: an elastic body's plastic strain, residual stress and yield stress are two
thirds of its volume bytes. The consolidated file and :func:`open_run` have them in full.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import tempfile
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any, NamedTuple

import netCDF4
import numpy as np

from sacflow.schema import Case
from sacflow.state import COMPONENTS, GridCoords, State

if TYPE_CHECKING:  # xarray is imported where runs are read: writers (campaign workers) skip it
    import xarray as xr

__all__ = [
    "VARIABLES",
    "MeasuredSurface",
    "RunWriter",
    "completed_steps",
    "is_complete",
    "open_run",
    "parts_dir",
    "read_measured_surface",
    "read_scalars",
]

SCALAR = ("step",)
SURFACE = ("step", "x1", "x2")
VOLUME = ("step", "x1", "x2", "x3")
TENSOR = ("step", "x1", "x2", "x3", "component")


class Variable(NamedTuple):
    """Layout and CF metadata of one stored variable."""

    dims: tuple[str, ...]
    units: str
    long_name: str
    dtype: str = "f8"  # netCDF type; "bool" is stored as i1 flags


#: Every stored variable: dims, units, long name, netCDF type. The only place metadata lives.
VARIABLES: dict[str, Variable] = {
    # per-step scalars
    "load": Variable(SCALAR, "N", "applied normal load"),
    "approach": Variable(SCALAR, "m", "rigid-body approach of the counter-body since contact"),
    "load_x1": Variable(SCALAR, "m", "load position along x1 (body frame)"),
    "load_x2": Variable(SCALAR, "m", "load position along x2 (body frame)"),
    "contact_area": Variable(SCALAR, "m2", "contact area"),
    "max_pressure": Variable(SCALAR, "Pa", "maximum contact pressure"),
    "contact_iterations": Variable(SCALAR, "1", "elastic contact iterations", "i4"),
    "plasticity_iterations": Variable(SCALAR, "1", "plasticity iterations", "i4"),
    "converged": Variable(SCALAR, "1", "the increment converged", "bool"),
    "segment": Variable(SCALAR, "1", "index of the load path segment", "i4"),
    # surface fields
    "pressure": Variable(SURFACE, "Pa", "contact pressure"),
    "gap": Variable(SURFACE, "m", "gap between the surfaces"),
    "geometry": Variable(SURFACE, "m", "initial gap including surface features"),
    "residual_displacement": Variable(
        SURFACE, "m", "normal surface displacement due to plastic strain, positive into the body"
    ),
    "surface_displacement": Variable(SURFACE, "m", "normal surface displacement"),
    # volume fields
    "plastic_strain": Variable(TENSOR, "1", "plastic strain tensor"),
    "equivalent_plastic_strain": Variable(VOLUME, "1", "equivalent plastic strain"),
    "residual_stress": Variable(TENSOR, "Pa", "residual stress tensor"),
    "stress": Variable(TENSOR, "Pa", "stress tensor (contact pressure and residual)"),
    "von_mises": Variable(VOLUME, "Pa", "von Mises equivalent stress"),
    "yield_stress": Variable(VOLUME, "Pa", "current yield stress"),
}
#: Coordinate variables: dims, units, long name, type.
COORDINATES: dict[str, Variable] = {
    "step": Variable(("step",), "1", "load increment index", "i4"),
    "x1": Variable(("x1",), "m", "surface cell centre along x1 (body frame)"),
    "x2": Variable(("x2",), "m", "surface cell centre along x2 (body frame)"),
    "x3": Variable(("x3",), "m", "depth of the cuboid centre, positive into the body"),
    "component": Variable(("component",), "1", "tensor component", "str"),
}
_BOOL_ATTRS = {
    "dtype": "bool",
    "flag_values": np.array([0, 1], "i1"),
    "flag_meanings": "false true",
}
_PART = re.compile(r"^step-(\d+)\.nc$")
#: Global attribute of a part: JSON ``{field: value}`` of the fields that hold one value
#: everywhere at that step and are not written out (the consolidated file has them in full).
UNIFORM_ATTR = "uniform_fields"
#: HDF5 chunk cache [bytes] of the variables sacflow writes. Every write is one whole chunk (a
#: step of one field), which HDF5 then filters and writes at once instead of keeping up to
#: netCDF's default 64 MB per variable until the file closes (measured: a 128 x 128 x 16 case
#: peaked at 660 MB instead of 400 MB).
WRITE_CHUNK_CACHE = 0
_NETCDF_SUFFIXES = {".nc", ".nc4", ".cdf", ".netcdf", ".h5", ".hdf5"}


# --------------------------------------------------------------------------- writing
class RunWriter:
    """Write one run step by step, atomically (see the module docstring).

    Parameters
    ----------
    path : str or Path
        Final run file ``<out>/<name>.nc``.
    case : Case
        The case; stored as canonical JSON in the global attributes.
    coords : GridCoords
        Body-fixed grid of the run.
    fields : iterable of str, optional
        Variables to store (default: all of :data:`VARIABLES`).
    compression : int
        zlib level 0..9 (0: none) of the consolidated file; the per-step parts, temporary, are
        not compressed.
    resume : bool
        Keep the completed steps of an interrupted run of the same case and append after them.
        Otherwise (and for parts of another case) any previous output is removed.
    requested_case_id : str, optional
        When the case run is an automatic adaptation of the one asked for (a deeper cuboid box,
        see :class:`~sacflow.errors.BoxTooShallowError`): the id of the case asked for, stored
        as the ``requested_case_id`` attribute; :func:`is_complete` accepts either id.

    Examples
    --------
    >>> with RunWriter(path, case, sim.coords) as writer:  # doctest: +SKIP
    ...     for state in sim.run():
    ...         writer.append(state)
    """

    def __init__(
        self,
        path: str | Path,
        case: Case,
        coords: GridCoords,
        fields: Iterable[str] | None = None,
        compression: int = 1,
        resume: bool = False,
        requested_case_id: str | None = None,
    ) -> None:
        self.path = Path(path)
        self.parts = parts_dir(self.path)
        self.coords = coords
        self.names = _selected(fields)
        self.compression = compression
        self._closed = False
        kept = _prepare(self.path, case.case_id, resume)
        self.attrs = _run_attrs(kept[0]) if kept else _global_attrs(case)
        if requested_case_id is not None and requested_case_id != case.case_id:
            self.attrs["requested_case_id"] = requested_case_id
        self.next_step = len(kept)  # number of steps stored so far
        self.parts.mkdir(parents=True, exist_ok=True)

    def append(self, state: State) -> None:
        """Store one step as a complete part file."""
        if self._closed:
            raise RuntimeError(f"{self.path}: writer is closed")
        values = _state_values(state, self.names, self.coords)
        # Fields holding one value everywhere (an elastic body's plastic strain, residual stress
        # and infinite yield stress: two thirds of its bytes) are recorded by value in the part.
        uniform = {
            name: value
            for name, array in values.items()
            if np.ndim(array) and (value := _uniform(array)) is not None
        }
        values = {name: v for name, v in values.items() if name not in uniform}
        attrs = {**self.attrs, UNIFORM_ATTR: json.dumps(uniform)}
        target = self.parts / f"step-{self.next_step:06d}.nc"
        # Parts are temporary: uncompressed (zlib took a third of a small elastic case's time
        # when each step was compressed twice, in its part and in the consolidated file).
        with _atomic(target) as tmp, _write_through(), self._create(tmp, attrs, 0) as nc:
            _write_step(nc, 0, state.step, values)
        self.next_step += 1

    def close(self) -> None:
        """Normal end: consolidate the parts into :attr:`path` and remove the parts folder."""
        if self._closed:
            return
        self._closed = True
        attrs = {**self.attrs, "complete": 1}
        with _atomic(self.path) as tmp, _write_through(), self._create(tmp, attrs) as nc:
            _copy_parts(_complete_parts(self.parts), nc, self.names)
        shutil.rmtree(self.parts, ignore_errors=True)

    def abort(self) -> None:
        """Stop without consolidating: the stored steps stay as parts (resume later)."""
        self._closed = True

    def __enter__(self) -> RunWriter:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()

    def _create(self, path: Path, attrs: Mapping[str, Any],
                compression: int | None = None) -> netCDF4.Dataset:
        level = self.compression if compression is None else compression
        return _create(path, self.coords, self.names, attrs, level)


def parts_dir(path: str | Path) -> Path:
    """Folder holding the per-step parts of the run file ``path``."""
    path = Path(path)
    return path.with_name(path.name + ".parts")


def _selected(fields: Iterable[str] | None) -> list[str]:
    if fields is None:
        return list(VARIABLES)
    fields = set(fields)
    unknown = fields - set(VARIABLES)
    if unknown:
        raise ValueError(f"unknown output fields {sorted(unknown)}; known: {list(VARIABLES)}")
    return [name for name in VARIABLES if name in fields]


def _prepare(path: Path, case_id: str, resume: bool) -> list[Path]:
    """Clear old output unless resuming the same case; return the parts kept."""
    parts = _complete_parts(parts_dir(path)) if resume else []
    if parts and _read_attrs(parts[0]).get("case_id") != case_id:
        parts = []
    if resume and is_complete(path, case_id):
        raise FileExistsError(f"{path} is a complete run of this case; nothing to resume")
    for stale in [path, *path.parent.glob(f".{path.name}.*.tmp")]:
        stale.unlink(missing_ok=True)
    folder = parts_dir(path)
    if folder.exists():
        keep = set(parts)
        for item in folder.iterdir():
            if item not in keep:
                item.unlink()
    return parts


def _global_attrs(case: Case) -> dict[str, Any]:
    try:
        version = metadata.version("sacflow")
    except metadata.PackageNotFoundError:
        version = "unknown"
    return {
        "title": f"sacflow run {case.name}",
        "Conventions": "CF-1.10",
        "case": case.canonical_json(),
        "case_id": case.case_id,
        "sacflow_version": version,
        "created": datetime.now(UTC).isoformat(timespec="seconds"),
        "complete": 0,
    }


def _state_values(state: State, names: list[str], coords: GridCoords) -> dict[str, Any]:
    """Values of ``state`` to store, checked against the table and the grid."""
    sizes = _sizes(coords)
    values: dict[str, Any] = {k: v for k, v in state.scalars().items() if k in names}
    for group, arrays, dims in (
        ("surface", state.surface, (SURFACE,)),
        ("volume", state.volume, (VOLUME, TENSOR)),
    ):
        for name, array in arrays.items():
            if name not in VARIABLES or VARIABLES[name].dims not in dims:
                raise ValueError(f"State.{group}[{name!r}] is not a {group} field")
            shape = tuple(sizes[d] for d in VARIABLES[name].dims[1:])
            if np.shape(array) != shape:
                raise ValueError(
                    f"State.{group}[{name!r}] has shape {np.shape(array)}, not {shape}"
                )
            if name in names:
                values[name] = array
    return values


class _atomic:
    """Context manager giving a temporary path next to ``target``, moved onto it on success."""

    def __init__(self, target: Path) -> None:
        self.target = target
        self.tmp = target.with_name(f".{target.name}.{os.getpid()}.tmp")

    def __enter__(self) -> Path:
        return self.tmp

    def __exit__(self, exc_type: type[BaseException] | None, *_: object) -> None:
        if exc_type is not None:
            self.tmp.unlink(missing_ok=True)
            return
        with open(self.tmp, "rb+") as f:  # on disk before it becomes visible
            os.fsync(f.fileno())
        os.replace(self.tmp, self.target)


@contextmanager
def _write_through() -> Iterator[None]:
    """Files created inside write each chunk out at once (chunk cache :data:`WRITE_CHUNK_CACHE`).

    netCDF-C gives a variable the library-wide chunk cache setting when it creates the HDF5
    dataset, which is at the first write, not at ``createVariable``: the setting must hold for
    the whole block, and is restored after it.
    """
    previous = netCDF4.get_chunk_cache()
    netCDF4.set_chunk_cache(WRITE_CHUNK_CACHE, 1, previous[2])
    try:
        yield
    finally:
        netCDF4.set_chunk_cache(*previous)


def _sizes(coords: GridCoords) -> dict[str, int]:
    """Length of every fixed dimension."""
    return dict(zip(("x1", "x2", "x3"), coords.shape, strict=True), component=len(COMPONENTS))


def _create(
    path: Path,
    coords: GridCoords,
    names: list[str],
    attrs: Mapping[str, Any],
    compression: int,
) -> netCDF4.Dataset:
    """Create an empty run file laid out as in :data:`VARIABLES` (NaN where never written)."""
    nc = netCDF4.Dataset(path, "w", format="NETCDF4")
    nc.set_auto_mask(False)
    nc.setncatts(dict(attrs))
    sizes = _sizes(coords)
    nc.createDimension("step", None)
    for dim, size in sizes.items():
        nc.createDimension(dim, size)
    _add_coordinates(nc, coords)
    for name in names:
        spec = VARIABLES[name]
        var = nc.createVariable(
            name,
            "i1" if spec.dtype == "bool" else spec.dtype,
            spec.dims,
            zlib=compression > 0,
            complevel=max(compression, 1),
            fill_value=np.nan if spec.dtype == "f8" else None,
            chunksizes=(1, *(sizes[d] for d in spec.dims[1:])) if len(spec.dims) > 1 else None,
        )
        var.setncatts({"units": spec.units, "long_name": spec.long_name})
        if spec.dtype == "bool":  # CF flags; "dtype" makes xarray decode it as bool
            var.setncatts(_BOOL_ATTRS)
    return nc


def _add_coordinates(nc: netCDF4.Dataset, coords: GridCoords) -> None:
    values = {"x1": coords.x1, "x2": coords.x2, "x3": coords.x3}
    for name, spec in COORDINATES.items():
        var = nc.createVariable(name, str if spec.dtype == "str" else spec.dtype, spec.dims)
        var.setncatts({"units": spec.units, "long_name": spec.long_name})
        if name in values:
            var[:] = np.asarray(values[name], dtype=float)
    nc["component"][:] = np.array(COMPONENTS, dtype=object)
    nc["x3"].positive = "down"


def _write_step(nc: netCDF4.Dataset, index: int, step: int, values: Mapping[str, Any]) -> None:
    nc["step"][index] = step
    for name, value in values.items():
        nc[name][index] = value


def _uniform(array: np.ndarray) -> float | None:
    """The value of every element of ``array`` when they are all equal (not NaN), else None."""
    flat = array.reshape(-1)
    first = flat[0]
    if flat[-1] != first or not (flat == first).all():  # the ends first: most fields differ
        return None
    return float(first)


def _copy_parts(parts: list[Path], nc: netCDF4.Dataset, names: list[str]) -> None:
    """Copy each part, one step at a time; arrays never written (all NaN) stay unwritten.

    A field a part records by value (attribute :data:`UNIFORM_ATTR`) is written in full.
    """
    for index, part in enumerate(parts):
        with netCDF4.Dataset(part) as src:
            src.set_auto_mask(False)
            uniform = json.loads(getattr(src, UNIFORM_ATTR, "{}"))
            values = {}
            for name in names:
                if name in uniform:
                    values[name] = np.full(src[name].shape[1:], uniform[name])
                    continue
                value = src[name][0]
                if np.ndim(value) == 0 or not np.isnan(value).all():
                    values[name] = value
            _write_step(nc, index, int(src["step"][0]), values)


# --------------------------------------------------------------------------- reading
def _complete_parts(folder: Path) -> list[Path]:
    """Parts step-000000.nc, step-000001.nc, ... up to the first missing one."""
    if not folder.is_dir():
        return []
    found = {
        int(m.group(1)): folder / m.group(0) for p in folder.iterdir() if (m := _PART.match(p.name))
    }
    parts = []
    while len(parts) in found:
        parts.append(found[len(parts)])
    return parts


def _read_attrs(path: Path) -> dict[str, Any]:
    with netCDF4.Dataset(path) as nc:
        return {k: nc.getncattr(k) for k in nc.ncattrs()}


def _run_attrs(part: Path) -> dict[str, Any]:
    """Global attributes of the run a part belongs to (without the part's own)."""
    attrs = _read_attrs(part)
    attrs.pop(UNIFORM_ATTR, None)
    return attrs


def _layout(part: Path) -> tuple[GridCoords, list[str]]:
    with netCDF4.Dataset(part) as nc:
        coords = GridCoords(*(np.array(nc[x][:], dtype=float) for x in ("x1", "x2", "x3")))
        return coords, [name for name in VARIABLES if name in nc.variables]


def open_run(path: str | Path, lazy: bool = False) -> xr.Dataset:
    """Open a run: the consolidated file, else the completed steps of an interrupted run.

    Parameters
    ----------
    path : str or Path
        Run file ``<out>/<name>.nc``.
    lazy : bool
        Keep a consolidated file open and read arrays on demand (large runs; close the dataset
        when done). By default everything is loaded and the file closed at once.

    Returns
    -------
    xarray.Dataset
        Global attribute ``complete`` is 1 for a finished run, 0 for the steps of an
        interrupted one. Volume fields are NaN on steps where they were not stored.
    """
    import xarray as xr

    path = Path(path)
    if path.exists():
        return xr.open_dataset(path) if lazy else _load(path)
    parts = _complete_parts(parts_dir(path))
    if not parts:
        raise FileNotFoundError(f"no run at {path} (no file and no completed steps)")
    coords, names = _layout(parts[0])
    with tempfile.TemporaryDirectory() as folder:
        target = Path(folder) / path.name
        attrs = _run_attrs(parts[0])
        with _write_through(), _create(target, coords, names, attrs, compression=0) as nc:
            _copy_parts(parts, nc, names)
        return _load(target)


def _load(path: Path) -> xr.Dataset:
    import xarray as xr

    with xr.open_dataset(path) as ds:
        return ds.load()


def is_complete(path: str | Path, case_id: str) -> bool:
    """True when ``path`` is a finished (consolidated) run of the case ``case_id``.

    A run whose box was grown automatically (``requested_case_id`` attribute) also counts as a
    finished run of the case asked for.
    """
    path = Path(path)
    if not path.exists():
        return False
    attrs = _read_attrs(path)
    return bool(attrs.get("complete")) and case_id in (
        attrs.get("case_id"), attrs.get("requested_case_id"))


def completed_steps(path: str | Path, case_id: str | None = None) -> int:
    """Number of steps stored for the run file ``path`` (0 if they belong to another case)."""
    path = Path(path)
    if path.exists():
        files = [path]
    else:
        files = _complete_parts(parts_dir(path))
    if not files or (case_id is not None and _read_attrs(files[0]).get("case_id") != case_id):
        return 0
    if files[0] == path:
        with netCDF4.Dataset(path) as nc:
            return len(nc.dimensions["step"])
    return len(files)


def read_scalars(path: str | Path) -> dict[str, np.ndarray]:
    """Per-step scalars of a run (consolidated or interrupted), without its fields."""
    path = Path(path)
    files = [path] if path.exists() else _complete_parts(parts_dir(path))
    columns: dict[str, list[np.ndarray]] = {}
    for file in files:  # netCDF4 directly: a campaign worker need not import xarray for this
        with netCDF4.Dataset(file) as nc:
            nc.set_auto_mask(False)  # unwritten floats are NaN (their fill value) as they are
            for name, var in VARIABLES.items():
                if var.dims == SCALAR and name in nc.variables:
                    values = np.asarray(nc[name][:])
                    columns.setdefault(name, []).append(
                        values.astype(bool) if var.dtype == "bool" else values)
    return {name: np.concatenate(chunks) for name, chunks in columns.items()}


# --------------------------------------------------------------------------- measured surfaces
@dataclass(frozen=True)
class MeasuredSurface:
    """A measured surface: heights [m] on the grid ``x1`` × ``x2`` [m], shape (nx1, nx2)."""

    x1: np.ndarray
    x2: np.ndarray
    height: np.ndarray


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


def _read_text_surface(path: Path) -> MeasuredSurface:
    lines = (line.split("#")[0].strip() for line in path.read_text().splitlines())
    first = next((line for line in lines if line), "")
    data = np.loadtxt(path, delimiter="," if "," in first else None, comments="#", ndmin=2)
    if data.shape[1] != 3:
        raise ValueError(f"expected 3 columns x1 x2 height [m], found {data.shape[1]}")
    x1, i1 = np.unique(data[:, 0], return_inverse=True)
    x2, i2 = np.unique(data[:, 1], return_inverse=True)
    if np.unique(i1 * x2.size + i2).size != len(data) or x1.size * x2.size != len(data):
        raise ValueError("the points do not fill a rectangular x1-x2 grid, each point once")
    height = np.empty((x1.size, x2.size))
    height[i1, i2] = data[:, 2]
    return MeasuredSurface(x1, x2, height)


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
