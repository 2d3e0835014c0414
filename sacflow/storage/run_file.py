"""Run files: with :mod:`sacflow.storage.surface_file`, the only modules that read or write netCDF.

Computation and metadata are separate layers: the numerical core hands bare arrays over, and
this module attaches dims, units and long names.

One netCDF4 file per case, ``<out>/<case name>.nc``, dimensions ``step`` (unlimited), ``x1``,
``x2``, ``x3`` and ``component`` (``11 22 33 12 13 23``). :data:`VARIABLES` is the one table
of dims, units and long names; numerical code hands over bare arrays in a
:class:`~sacflow.solver.state.State`.

Crash safety. :class:`RunWriter` writes each step as its own small file
``<path>.parts/step-000123-<sha256>.nc`` (temporary name, then ``os.replace``: a part is either
complete or absent; the name carries the first 16 hex digits of the SHA-256 of its bytes, so a
part damaged later is recognised). A normal end consolidates the parts into ``<path>`` the same
way and removes the parts folder, so ``<path>`` only ever exists complete (global attribute
``complete = 1``). After a crash, :func:`open_run` reads the completed parts (``complete = 0``)
and ``RunWriter(..., keep_steps=n)`` carries on after the first ``n``. :func:`run_info` says
what is stored at a path (one look at the file or the parts) and which parts are damaged.

Run identity: a stored run, complete or not, is only replaced when the writer is told to
(``overwrite=True``; ``sacflow run --overwrite``); otherwise :class:`RunExistsError` names the
file, both case ids and the fields that differ. Damaged parts, and those after them, are
always dropped.

True resume: each part also holds, in its group ``restart``, what the solver needs to go on after
that step (:data:`~sacflow.solver.state.RESTART_FIELDS`: plastic strain, equivalent plastic strain,
residual displacement, contact pressure; and the first-contact offset), except the arrays that
the part already stores as output fields with the same values. The consolidated file does not
keep them.

Parts are uncompressed (they are read once, at consolidation) and leave out the fields that hold
one value everywhere at their step, which they record by value in the attribute
:data:`UNIFORM_ATTR`: an elastic body's plastic strain, residual stress and yield stress are two
thirds of its volume bytes. The consolidated file and :func:`open_run` have them in full.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import re
import shutil
import tempfile
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any, Literal, NamedTuple, cast

import netCDF4
import numpy as np

from sacflow.config.schema import Case, identity_differences
from sacflow.errors import SacflowError
from sacflow.solver.state import (
    COMPONENTS,
    OPTIONAL_RESTART_FIELDS,
    RESTART_FIELDS,
    TRACTION_COMPONENTS,
    VOLUME_FIELDS,
    GridCoords,
    MeasuredSurface,
    State,
)
from sacflow.storage.surface_file import load_surface, read_measured_surface

if TYPE_CHECKING:  # xarray is imported where runs are read: writers (campaign workers) skip it
    import xarray as xr

__all__ = [
    "VARIABLES",
    "MeasuredSurface",
    "RunExistsError",
    "RunInfo",
    "RunWriter",
    "completed_steps",
    "is_complete",
    "open_run",
    "parts_dir",
    "read_measured_surface",
    "read_scalars",
    "load_surface",
    "run_info",
]

SCALAR = ("step",)
SURFACE = ("step", "x1", "x2")
SURFACE_VECTOR = ("step", "x1", "x2", "direction")
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
    "approach": Variable(
        SCALAR, "m",
        "rigid-body approach of the counter-body since first contact (at zero load: where it "
        "touches the deformed surface, the residual print depth after unloading)"),
    "load_x1": Variable(SCALAR, "m", "load position along x1 (body frame)"),
    "load_x2": Variable(SCALAR, "m", "load position along x2 (body frame)"),
    "contact_area": Variable(SCALAR, "m2", "contact area"),
    "max_pressure": Variable(SCALAR, "Pa", "maximum contact pressure"),
    "contact_iterations": Variable(SCALAR, "1", "elastic contact iterations", "i4"),
    "plasticity_iterations": Variable(SCALAR, "1", "plasticity iterations", "i4"),
    "converged": Variable(SCALAR, "1", "every loop of the increment met its tolerance", "bool"),
    "contact_converged": Variable(SCALAR, "1", "the contact solve met its tolerance", "bool"),
    "plasticity_converged": Variable(
        SCALAR, "1", "the plastic strain fixed point met its tolerance", "bool"),
    "coupling_converged": Variable(
        SCALAR, "1", "the contact-plasticity coupling met its tolerance", "bool"),
    "contact_residual": Variable(
        SCALAR, "1", "final relative gap error of the contact solve"),
    "plasticity_residual": Variable(
        SCALAR, "1", "final relative residual of the plastic strain increment"),
    "coupling_residual": Variable(
        SCALAR, "1", "final relative change of the residual surface displacement"),
    "segment": Variable(SCALAR, "1", "index of the load path segment", "i4"),
    "pass": Variable(SCALAR, "1", "rolling pass of the step, from 0", "i4"),
    "substeps": Variable(
        SCALAR, "1", "sub-increments the step was solved in (1: the step itself; more: it was "
        "cut back after not converging)", "i4"),
    # surface fields
    "pressure": Variable(SURFACE, "Pa", "contact pressure"),
    "shear_traction": Variable(
        SURFACE_VECTOR, "Pa", "shear traction on the surface of body 1 (components along x1, x2)"
    ),
    "gap": Variable(SURFACE, "m", "gap between the surfaces"),
    "geometry": Variable(SURFACE, "m", "initial gap including surface features"),
    "residual_displacement": Variable(
        SURFACE, "m", "normal surface displacement due to plastic strain, positive into the body"
    ),
    "surface_displacement": Variable(SURFACE, "m", "normal surface displacement"),
    # volume fields
    "plastic_strain": Variable(TENSOR, "1", "plastic strain tensor"),
    "equivalent_plastic_strain": Variable(VOLUME, "1", "equivalent plastic strain"),
    "backstress": Variable(TENSOR, "Pa", "backstress tensor of kinematic hardening"),
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
    "direction": Variable(("direction",), "1", "surface direction of a traction component",
                          "str"),
}
_BOOL_ATTRS = {
    "dtype": "bool",
    "flag_values": np.array([0, 1], "i1"),
    "flag_meanings": "false true",
}
#: Part file names: the step index and the first 16 hex digits of the SHA-256 of the file (parts
#: written before checksums have none and are checked by reading them).
_PART = re.compile(r"^step-(\d+)(?:-([0-9a-f]{16}))?\.nc$")
#: Hex digits of the SHA-256 kept in a part's name.
_CHECKSUM_DIGITS = 16
#: netCDF group of a part holding the solver state after its step (see the module docstring).
RESTART_GROUP = "restart"
#: Global attribute of a part: JSON ``{field: value}`` of the fields that hold one value
#: everywhere at that step and are not written out (the consolidated file has them in full).
UNIFORM_ATTR = "uniform_fields"
#: HDF5 chunk cache [bytes] of the variables sacflow writes. Every write is one whole chunk (a
#: step of one field), which HDF5 then filters and writes at once instead of keeping up to
#: netCDF's default 64 MB per variable until the file closes (which raised a run's memory peak
#: by more than half, ``docs/performance.md``).
WRITE_CHUNK_CACHE = 0


# --------------------------------------------------------------------------- writing
class RunExistsError(SacflowError):
    """A stored run would be replaced or deleted without being asked (``overwrite``)."""


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
    keep_steps : int
        Number of stored steps of an interrupted run of this case to keep and append after (its
        first ``keep_steps`` sound parts); 0 starts afresh.
    overwrite : bool
        Allow removing what is stored at ``path`` beyond the kept steps: a consolidated run
        file, or parts. Without it, :class:`RunExistsError` is raised when anything but damaged
        parts would be removed.
    requested_case_id : str, optional
        When the case run is an automatic adaptation of the one asked for (a deeper cuboid box,
        see :class:`~sacflow.errors.BoxTooShallowError`): the id of the case asked for, stored
        as the ``requested_case_id`` attribute; :func:`is_complete` accepts either id.
    info : RunInfo, optional
        What :func:`run_info` found at ``path``, when the caller has it already.

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
        keep_steps: int = 0,
        overwrite: bool = False,
        requested_case_id: str | None = None,
        info: RunInfo | None = None,
    ) -> None:
        self.path = Path(path)
        self.parts = parts_dir(self.path)
        self.coords = coords
        self.names = _selected(fields)
        self.compression = compression
        # Volume fields of the consolidated file in float32 when the case asks (parts, the
        # restart state, stay float64: an interrupted run resumes exactly).
        self.volume_dtype = "f4" if case.output.volume_precision == "float32" else "f8"
        self._closed = False
        info = info if info is not None else run_info(self.path)
        kept = _prepare(info, case, keep_steps, overwrite)
        self.attrs = _run_attrs(kept[0]) if kept else _global_attrs(case)
        if requested_case_id is not None and requested_case_id != case.case_id:
            self.attrs["requested_case_id"] = requested_case_id
        self._stored = list(kept)  # the parts of this run, in step order
        self.next_step = len(kept)  # number of steps stored so far
        self.parts.mkdir(parents=True, exist_ok=True)

    def append(self, state: State) -> None:
        """Store one step as a complete part file (with the solver state of ``state.restart``)."""
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
        name = f"step-{self.next_step:06d}"
        tmp = self.parts / f".{name}.nc.{os.getpid()}.tmp"
        # Parts are temporary: uncompressed (zlib took a third of a small elastic case's time
        # when each step was compressed twice, in its part and in the consolidated file).
        try:
            with _write_through(), self._create(tmp, attrs, 0) as nc:
                _write_step(nc, 0, state.step, values)
                if state.restart:
                    _write_restart(nc, state, {**values, **uniform})
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise
        target = self.parts / f"{name}-{_checksum(tmp)}.nc"
        _atomic_rename(tmp, target)
        self._stored.append(target)
        self.next_step += 1

    def close(self) -> None:
        """End normally: consolidate the parts into :attr:`path` and remove the parts folder."""
        if self._closed:
            return
        self._closed = True
        attrs = {**self.attrs, "complete": 1}
        with (_atomic(self.path) as tmp, _write_through(),
              self._create(tmp, attrs, volume_dtype=self.volume_dtype) as nc):
            _copy_parts(self._stored, nc, self.names)
        shutil.rmtree(self.parts, ignore_errors=True)

    def abort(self) -> None:
        """Stop without consolidating: the stored steps stay as parts (resume later)."""
        self._closed = True

    def __enter__(self) -> RunWriter:
        """Return the writer itself."""
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        """Consolidate on a normal exit, keep the parts (resumable) after an exception."""
        if exc_type is None:
            self.close()
        else:
            self.abort()

    def _create(self, path: Path, attrs: Mapping[str, Any], compression: int | None = None,
                volume_dtype: str = "f8") -> netCDF4.Dataset:
        level = self.compression if compression is None else compression
        return _create(path, self.coords, self.names, attrs, level, volume_dtype)


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


def _prepare(info: RunInfo, case: Case, keep_steps: int, overwrite: bool) -> list[Path]:
    """Remove what the new run replaces (see :class:`RunWriter`); return the parts kept."""
    if keep_steps:
        if info.complete or not info.matches(case.case_id) or keep_steps > len(info.parts):
            raise ValueError(f"{info.path}: cannot keep {keep_steps} steps of {info.describe()}")
    kept = list(info.parts[:keep_steps])
    replaced = info.complete or info.unreadable or len(info.parts) > keep_steps
    if replaced and not overwrite:
        raise RunExistsError(replace_message(info, case))
    for stale in [info.path, *info.path.parent.glob(f".{info.path.name}.*.tmp")]:
        if stale != info.path or replaced:
            stale.unlink(missing_ok=True)
    folder = parts_dir(info.path)
    if folder.is_dir():
        keep = set(kept)
        for item in folder.iterdir():
            if item not in keep and item.is_file():
                item.unlink()
    return kept


def replace_message(info: RunInfo, case: Case) -> str:
    """One-screen message: what is stored at ``info.path``, how it differs, how to replace it."""
    lines = [f"{info.path} holds {info.describe()}; this case is {case.case_id}."]
    stored = info.case
    if stored is not None and info.case_id != case.case_id:
        differences = identity_differences(stored.identity(), case.identity())
        if differences:
            shown = differences[:_MAX_DIFFERENCES]
            more = len(differences) - len(shown)
            lines.append("Fields that differ (stored -> this case):")
            lines += [f"  {line}" for line in shown]
            if more:
                lines.append(f"  ... and {more} more")
    lines.append(
        "Nothing was changed. To replace it, run again with --overwrite; to keep it, use "
        "another --out folder or another case name."
    )
    return "\n".join(lines)


#: At most this many differing fields are listed in :func:`replace_message`.
_MAX_DIFFERENCES = 12


def _checksum(path: Path) -> str:
    """First :data:`_CHECKSUM_DIGITS` hex digits of the SHA-256 of the file's bytes."""
    with open(path, "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()[:_CHECKSUM_DIGITS]


def _atomic_rename(tmp: Path, target: Path) -> None:
    """Give the finished temporary file ``tmp`` its checksummed name, on disk first."""
    with open(tmp, "rb+") as f:
        os.fsync(f.fileno())
    os.replace(tmp, target)


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
        **_source_attrs(case),
    }


def _source_attrs(case: Case) -> dict[str, Any]:
    """Attributes naming the stored state a chained case starts from (none otherwise)."""
    spec = case.initial_state
    if spec is None:
        return {}
    from sacflow.storage.initial_state_file import stored_step_number

    source = case.identity()["initial_state"]["run"]
    number = stored_step_number(Path(spec.run), spec.step)
    return {"initial_state_run": str(spec.run),
            "initial_state_case_id": str(source).removeprefix("case_id:"),
            "initial_state_step": spec.step if number is None else number}


def _state_values(state: State, names: list[str], coords: GridCoords) -> dict[str, Any]:
    """Values of ``state`` to store, checked against the table and the grid."""
    sizes = _sizes(coords)
    values: dict[str, Any] = {k: v for k, v in state.scalars().items() if k in names}
    for group, arrays, dims in (
        ("surface", state.surface, (SURFACE, SURFACE_VECTOR)),
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
    return dict(zip(("x1", "x2", "x3"), coords.shape, strict=True), component=len(COMPONENTS),
                direction=len(TRACTION_COMPONENTS))


#: A zlib level as netCDF4 takes it.
ZlibLevel = Literal[1, 2, 3, 4, 5, 6, 7, 8, 9]


def _zlib_level(compression: int) -> ZlibLevel:
    """Return the zlib level of ``compression`` (0 writes uncompressed: zlib is then off)."""
    # The schema bounds output.compression to 0..9 (Output.compression), so this is 1..9.
    return cast(ZlibLevel, max(compression, 1))


def _create(
    path: Path,
    coords: GridCoords,
    names: list[str],
    attrs: Mapping[str, Any],
    compression: int,
    volume_dtype: str = "f8",
) -> netCDF4.Dataset:
    """Create an empty run file laid out as in :data:`VARIABLES` (NaN where never written).

    ``volume_dtype`` ("f8" or "f4") is the type of the volume fields (``output.volume_precision``).
    """
    nc = netCDF4.Dataset(path, "w", format="NETCDF4")
    nc.set_auto_mask(False)
    nc.setncatts(dict(attrs))
    sizes = _sizes(coords)
    used = {dim for name in names for dim in VARIABLES[name].dims} | {"x1", "x2", "x3",
                                                                      "component"}
    nc.createDimension("step", None)
    for dim, size in sizes.items():
        if dim in used:
            nc.createDimension(dim, size)
    _add_coordinates(nc, coords, used)
    for name in names:
        spec = VARIABLES[name]
        dtype = "i1" if spec.dtype == "bool" else spec.dtype
        if name in VOLUME_FIELDS:
            dtype = volume_dtype
        var = nc.createVariable(
            name,
            dtype,
            spec.dims,
            zlib=compression > 0,
            complevel=_zlib_level(compression),
            fill_value=np.array(np.nan, dtype) if dtype in ("f8", "f4") else None,
            chunksizes=(1, *(sizes[d] for d in spec.dims[1:])) if len(spec.dims) > 1 else None,
        )
        var.setncatts({"units": spec.units, "long_name": spec.long_name})
        if spec.dtype == "bool":  # CF flags; "dtype" makes xarray decode it as bool
            var.setncatts(_BOOL_ATTRS)
    return nc


def _add_coordinates(nc: netCDF4.Dataset, coords: GridCoords, used: set[str]) -> None:
    """Write the coordinate variables of the dimensions in ``used`` (always x1, x2, x3, component).

    The traction ``direction`` appears only in files that store ``shear_traction``.
    """
    values = {"x1": coords.x1, "x2": coords.x2, "x3": coords.x3}
    for name, spec in COORDINATES.items():
        if name != "step" and name not in used:
            continue
        var = nc.createVariable(name, str if spec.dtype == "str" else spec.dtype, spec.dims)
        var.setncatts({"units": spec.units, "long_name": spec.long_name})
        if name in values:
            var[:] = np.asarray(values[name], dtype=float)
    nc["component"][:] = np.array(COMPONENTS, dtype=object)
    if "direction" in used:
        nc["direction"][:] = np.array(TRACTION_COMPONENTS, dtype=object)
    nc["x3"].positive = "down"


def _write_step(nc: netCDF4.Dataset, index: int, step: int, values: Mapping[str, Any]) -> None:
    nc["step"][index] = step
    for name, value in values.items():
        nc[name][index] = value


def _uniform(array: np.ndarray) -> float | None:
    """Return the value of every element of ``array`` when all are equal (not NaN), else None."""
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
@dataclass(frozen=True)
class RunInfo:
    """What is stored at a run path (:func:`run_info`): one look at the file or its parts.

    Attributes
    ----------
    path : Path
        The run file ``<out>/<name>.nc``.
    complete : bool
        A consolidated (finished) run file is there.
    attrs : dict
        Global attributes of the run (of the file, or of its first part).
    steps : int
        Stored steps: of the file, or the sound parts of an interrupted run.
    parts : tuple of Path
        The sound parts, step 0 onwards, of an interrupted run.
    damaged : tuple of Path
        Parts that cannot be used: the first one whose checksum or contents are wrong, every
        part after it, and parts after a missing step.
    problem : str
        Why the file is unreadable, or the first damaged part is damaged ("" when all is well).
    unreadable : bool
        A file is at ``path`` but netCDF cannot read it as a run.
    variables : tuple of str
        The stored variables (of the file, or of the first part).
    """

    path: Path
    complete: bool = False
    attrs: Mapping[str, Any] = field(default_factory=dict)
    steps: int = 0
    parts: tuple[Path, ...] = ()
    damaged: tuple[Path, ...] = ()
    problem: str = ""
    unreadable: bool = False
    variables: tuple[str, ...] = ()

    @property
    def exists(self) -> bool:
        """Anything is stored at the path (a file, or parts sound or damaged)."""
        return self.complete or self.unreadable or bool(self.parts or self.damaged)

    @property
    def damaged_only(self) -> bool:
        """Nothing usable is stored: only damaged parts (always dropped)."""
        return not (self.complete or self.unreadable or self.parts) and bool(self.damaged)

    @property
    def case_id(self) -> str | None:
        """Case id of the stored run (its ``case_id`` attribute)."""
        value = self.attrs.get("case_id")
        return None if value is None else str(value)

    @property
    def case(self) -> Case | None:
        """The stored case, or None when absent or no longer valid under this schema."""
        text = self.attrs.get("case")
        if not text:
            return None
        try:
            return Case.model_validate_json(str(text))
        except ValueError:
            return None

    def matches(self, case_id: str) -> bool:
        """Tell whether the stored run is a run of the case ``case_id``.

        It is when ``case_id`` is the stored ``case_id`` or ``requested_case_id`` (a run whose
        box was deepened automatically), or the id of the stored case under this version's
        rules (runs written before the id left out names and thread counts).
        """
        ids = {self.case_id, self.attrs.get("requested_case_id")}
        if case_id in ids:
            return True
        stored = self.case
        return stored is not None and stored.case_id == case_id

    def describe(self) -> str:
        """Say in a few words what is stored, for messages."""
        if self.unreadable:
            return f"a file that is not a readable run ({self.problem})"
        if self.complete:
            return f"a finished run of case {self.case_id} ({self.steps} steps)"
        if self.parts:
            return f"an interrupted run of case {self.case_id} ({self.steps} steps stored)"
        if self.damaged:
            return f"{len(self.damaged)} damaged step parts"
        return "no run"

    def report(self) -> str:
        """Write a few lines for ``sacflow info``: what is stored, of which case, and its state."""
        lines = [f"{self.path}: {self.describe()}"]
        if self.attrs:
            stored = self.case
            lines.append(f"  case: {stored.name if stored else '?'} (id {self.case_id}"
                         + (f", asked as {self.attrs['requested_case_id']}"
                            if "requested_case_id" in self.attrs else "") + ")")
            lines.append(f"  written by sacflow {self.attrs.get('sacflow_version', '?')}, "
                         f"created {self.attrs.get('created', '?')}")
            lines.append(f"  variables: {', '.join(self.variables)}")
        if self.parts:
            resumable = "yes" if self.restart_stored() else "by replaying the stored steps"
            lines.append(f"  resumable: {resumable} (run the same case again)")
        if self.damaged:
            lines.append(f"  damaged, dropped at the next run: {len(self.damaged)} parts "
                         f"({self.problem})")
        return "\n".join(lines)

    def restart_stored(self) -> bool:
        """Tell whether the last sound part holds the solver state (true resume is possible)."""
        if not self.parts:
            return False
        with netCDF4.Dataset(self.parts[-1]) as nc:
            return RESTART_GROUP in nc.groups

    def restart(self) -> tuple[dict[str, np.ndarray], float | None] | None:
        """Solver state stored with the last sound part: ``(arrays, first-contact offset)``.

        None when there is no part or the part has no state (written by a simulation that
        cannot resume, or by an older sacflow); the runner then replays the stored steps.
        """
        return _read_restart(self.parts[-1]) if self.parts else None


def run_info(path: str | Path) -> RunInfo:
    """Find what is stored at the run path ``path``: a finished run, an interrupted one, or none.

    Opens a consolidated file once (attributes and step count). For an interrupted run, every
    part is checked: its SHA-256 against the checksum in its name (parts without one are read
    through); the first damaged part and those after it are listed in ``damaged``.
    """
    path = Path(path)
    if path.exists() or path.is_symlink():
        try:
            with netCDF4.Dataset(path) as nc:
                attrs = {k: nc.getncattr(k) for k in nc.ncattrs()}
                steps = len(nc.dimensions["step"])
                variables = tuple(name for name in VARIABLES if name in nc.variables)
        except (OSError, KeyError, RuntimeError) as exc:
            return RunInfo(path, problem=str(exc) or type(exc).__name__, unreadable=True)
        return RunInfo(path, complete=bool(attrs.get("complete")), attrs=attrs, steps=steps,
                       variables=variables)
    parts, damaged, problem = _sound_parts(parts_dir(path))
    attrs, variables = {}, ()
    if parts:
        attrs = _run_attrs(parts[0])
        variables = tuple(_layout(parts[0])[1])
    return RunInfo(path, attrs=attrs, steps=len(parts), parts=tuple(parts),
                   damaged=tuple(damaged), problem=problem, variables=variables)


def _sound_parts(folder: Path) -> tuple[list[Path], list[Path], str]:
    """Sound parts step-0..., the damaged ones after them, and why the first one is damaged."""
    if not folder.is_dir():
        return [], [], ""
    found: dict[int, Path] = {}
    for p in sorted(folder.iterdir()):
        if (m := _PART.match(p.name)) and p.is_file():
            found.setdefault(int(m.group(1)), p)
    sound: list[Path] = []
    problem = ""
    for index in sorted(found):
        part = found[index]
        if index != len(sound):
            problem = problem or f"step {len(sound)} is missing"
            break
        problem = _part_problem(part)
        if problem:
            break
        sound.append(part)
    damaged = [found[i] for i in sorted(found) if i >= len(sound)]
    return sound, damaged, problem


def _part_problem(part: Path) -> str:
    """Why ``part`` cannot be used ("" when it is sound)."""
    expected = _PART.match(part.name).group(2)  # type: ignore[union-attr]
    if expected is not None:
        actual = _checksum(part)
        return "" if actual == expected else (
            f"{part.name}: its SHA-256 {actual} does not match the checksum in its name")
    try:  # a part written before checksums: read it through
        with netCDF4.Dataset(part) as nc:
            for var in nc.variables.values():
                var[...]
    except (OSError, RuntimeError, KeyError, ValueError) as exc:
        return f"{part.name}: {exc}"
    return ""


def _write_restart(nc: netCDF4.Dataset, state: State, stored: Mapping[str, Any]) -> None:
    """Group :data:`RESTART_GROUP` of a part: the solver state after the step.

    Arrays equal to the part's own output field of the same name are not written twice
    (attribute ``in_output``); arrays holding one value are recorded by value (``uniform``).
    """
    group = nc.createGroup(RESTART_GROUP)
    offset = state.first_contact_offset
    group.first_contact_offset = math.nan if offset is None else float(offset)
    in_output, uniform = [], {}
    optional = [name for name in OPTIONAL_RESTART_FIELDS if name in state.restart]
    for name in (*RESTART_FIELDS, *optional):
        array = np.asarray(state.restart[name], dtype=float)
        if name in stored and _same(stored[name], array):
            in_output.append(name)
        elif (value := _uniform(array)) is not None:
            uniform[name] = value
        else:
            group.createVariable(name, "f8", VARIABLES[name].dims[1:])[:] = array
    group.in_output = json.dumps(in_output)
    group.uniform = json.dumps(uniform)


def _same(stored: Any, array: np.ndarray) -> bool:
    """Tell whether a stored output value (array, or one value of a uniform field) is ``array``."""
    if np.ndim(stored) == 0:
        return _uniform(array) == stored
    return stored is array or np.array_equal(stored, array)


def _read_restart(part: Path) -> tuple[dict[str, np.ndarray], float | None] | None:
    """Read the solver state a part stores (:func:`_write_restart`), or None when it has none."""
    with netCDF4.Dataset(part) as nc:
        nc.set_auto_mask(False)
        if RESTART_GROUP not in nc.groups:
            return None
        group = nc.groups[RESTART_GROUP]
        in_output = set(json.loads(group.in_output))
        uniform = json.loads(group.uniform)
        part_uniform = json.loads(getattr(nc, UNIFORM_ATTR, "{}"))
        sizes = {name: len(dim) for name, dim in nc.dimensions.items()}
        arrays = {}
        held = set(group.variables) | set(uniform) | in_output
        optional = [name for name in OPTIONAL_RESTART_FIELDS if name in held]
        for name in (*RESTART_FIELDS, *optional):
            shape = tuple(sizes[d] for d in VARIABLES[name].dims[1:])
            if name in group.variables:
                arrays[name] = np.array(group[name][...], dtype=float)
            elif name in uniform:
                arrays[name] = np.full(shape, float(uniform[name]))
            elif name in in_output and name in part_uniform:
                arrays[name] = np.full(shape, float(part_uniform[name]))
            else:
                arrays[name] = np.array(nc[name][0], dtype=float)
        offset = float(group.first_contact_offset)
    return arrays, (None if math.isnan(offset) else offset)


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
        interrupted one (its sound parts). Volume fields are NaN on steps where they were not
        stored.
    """
    import xarray as xr

    path = Path(path)
    if path.exists():
        return xr.open_dataset(path) if lazy else _load(path)
    parts = list(run_info(path).parts)
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
    """Tell whether ``path`` is a finished (consolidated) run of the case ``case_id``.

    A run whose box was grown automatically (``requested_case_id`` attribute) also counts as a
    finished run of the case asked for.
    """
    path = Path(path)
    if not path.exists():
        return False
    info = run_info(path)
    return info.complete and info.matches(case_id)


def completed_steps(path: str | Path, case_id: str | None = None) -> int:
    """Count the steps stored for the run file ``path`` (0 if they belong to another case)."""
    info = run_info(path)
    if case_id is not None and not info.matches(case_id):
        return 0
    return info.steps


def read_scalars(path: str | Path) -> dict[str, np.ndarray]:
    """Per-step scalars of a run (consolidated or interrupted), without its fields."""
    path = Path(path)
    files = [path] if path.exists() else list(run_info(path).parts)
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
