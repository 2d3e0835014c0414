"""netCDF layout of a run file: an empty file laid out as the variable table says, one step.

:func:`create_run_dataset` turns the variable table
(:data:`~sacflow.storage.run_variables.RUN_VARIABLES`) into a netCDF4 file (dimensions,
coordinate variables, types, fill values, zlib level, one chunk per step of a field, CF
attributes); :func:`write_step` fills one step. The per-step parts, the
consolidated file and the temporary file an interrupted run is read through are all made here,
so they have one layout. Files are written inside :func:`write_through` (no HDF5 chunk cache).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Literal, cast

import netCDF4
import numpy as np

from sacflow.solver.state import COMPONENTS, TRACTION_COMPONENTS, GridCoords
from sacflow.storage.run_variables import (
    COORDINATES,
    PHASE_FILL,
    RUN_VARIABLES,
    TENSOR,
    VOLUME,
    dimension_sizes,
)

__all__ = ["WRITE_CHUNK_CACHE", "ZlibLevel", "create_run_dataset", "write_step", "write_through"]

#: CF flag attributes of a boolean variable (stored as i1); ``dtype`` makes xarray decode it
#: as bool.
_BOOL_ATTRS = {
    "dtype": "bool",
    "flag_values": np.array([0, 1], "i1"),
    "flag_meanings": "false true",
}
#: HDF5 chunk cache [bytes] of the variables sacflow writes. Every write is one whole chunk (a
#: step of one field), which HDF5 then filters and writes at once instead of keeping up to
#: netCDF's default 64 MB per variable until the file closes (which raised a run's memory peak
#: by more than half, ``docs/performance.md``).
WRITE_CHUNK_CACHE = 0


@contextmanager
def write_through() -> Iterator[None]:
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


#: A zlib level as netCDF4 takes it.
ZlibLevel = Literal[1, 2, 3, 4, 5, 6, 7, 8, 9]


def _zlib_level(compression: int) -> ZlibLevel:
    """Return the zlib level of ``compression`` (0 writes uncompressed: zlib is then off)."""
    # The schema bounds output.compression to 0..9 (Output.compression), so this is 1..9.
    return cast(ZlibLevel, max(compression, 1))


def create_run_dataset(
    path: Path,
    coords: GridCoords,
    names: list[str],
    attrs: Mapping[str, Any],
    compression: int,
    volume_dtype: str = "f8",
) -> netCDF4.Dataset:
    """Create an empty run file laid out as in :data:`RUN_VARIABLES` (NaN where never written).

    Parameters
    ----------
    path : Path
        The file to create (replaced if it exists).
    coords : GridCoords
        Body-fixed grid of the run.
    names : list of str
        The variables to create, in table order.
    attrs : mapping
        Global attributes.
    compression : int
        zlib level 0..9 (0: none).
    volume_dtype : str
        "f8" or "f4": the type of the floating-point volume fields
        (``output.volume_precision``); the integer ``phase`` keeps its type, filled with
        :data:`~sacflow.storage.run_variables.PHASE_FILL` where not written.

    Returns
    -------
    netCDF4.Dataset
        Open for writing, auto-masking off; the caller closes it.
    """
    nc = netCDF4.Dataset(path, "w", format="NETCDF4")
    nc.set_auto_mask(False)
    nc.setncatts(dict(attrs))
    sizes = dimension_sizes(coords)
    used = {dim for name in names for dim in RUN_VARIABLES[name].dims} | {"x1", "x2", "x3",
                                                                      "component"}
    nc.createDimension("step", None)
    for dim, size in sizes.items():
        if dim in used:
            nc.createDimension(dim, size)
    _add_coordinates(nc, coords, used)
    for name in names:
        spec = RUN_VARIABLES[name]
        dtype = "i1" if spec.dtype == "bool" else spec.dtype
        volume = spec.dims in (VOLUME, TENSOR)
        if volume and spec.dtype == "f8":
            dtype = volume_dtype
        fill = None
        if dtype in ("f8", "f4"):
            fill = np.array(np.nan, dtype)
        elif volume:  # an integer volume field (phase): a fill read back as missing
            fill = np.array(PHASE_FILL, dtype)
        var = nc.createVariable(
            name,
            dtype,
            spec.dims,
            zlib=compression > 0,
            complevel=_zlib_level(compression),
            fill_value=fill,
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


def write_step(nc: netCDF4.Dataset, index: int, step: int, values: Mapping[str, Any]) -> None:
    """Write step number ``step`` at position ``index`` of ``nc``: the given variables' values."""
    nc["step"][index] = step
    for name, value in values.items():
        nc[name][index] = value
