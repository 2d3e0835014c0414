"""Whole or absent: write a file under a temporary name, then move it onto its own.

A reader, or a run killed mid-write, never leaves a half-written netCDF file, picture or
table under the final name: the file is written next to its target (same folder, so the
rename cannot cross file systems), flushed to disk, and moved with :func:`os.replace`, which
is atomic on POSIX and Windows. The temporary name keeps the target's suffix, so writers that
choose the format from it (matplotlib's ``savefig``, xarray's ``to_netcdf``) still do.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

__all__ = ["replace_durably", "temporary_name", "write_atomically"]


def temporary_name(path: Path) -> Path:
    """Return the hidden sibling ``path`` is written under: ``.stem.<pid>.tmp.suffix``."""
    return path.with_name(f".{path.stem}.{os.getpid()}.tmp{path.suffix}")


def replace_durably(tmp: Path, target: Path) -> None:
    """Flush the whole file ``tmp`` to disk, then move it onto ``target`` (:func:`os.replace`)."""
    with open(tmp, "rb+") as f:  # on disk before it becomes visible
        os.fsync(f.fileno())
    os.replace(tmp, target)


def write_atomically(path: str | Path, write: Callable[[Path], object]) -> Path:
    """Call ``write(tmp)`` and move ``tmp`` onto ``path``; on failure ``path`` is untouched.

    Parameters
    ----------
    path : str or Path
        The file to write; its folder is created if needed.
    write : callable
        Writes the whole file to the path it is given (e.g.
        ``lambda tmp: dataset.to_netcdf(tmp)`` or ``figure.savefig``).

    Returns
    -------
    Path
        ``path``.
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = temporary_name(target)
    try:
        write(tmp)
        replace_durably(tmp, target)
    finally:
        tmp.unlink(missing_ok=True)
    return target
