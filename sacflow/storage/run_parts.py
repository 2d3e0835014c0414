"""Per-step part files of a run: names and checksums, the sound parts, their consolidation.

:class:`~sacflow.storage.run_writer.RunWriter` writes each step as its own small file
``<path>.parts/step-000123-<sha256>.nc``: first under a temporary name
(:func:`temporary_part`), then :func:`publish_part` gives it its final name with
``os.replace``, so a part is either complete or absent. The name carries the first 16 hex
digits of the SHA-256 of the part's bytes, so a part damaged later is recognised
(:func:`sound_parts`). A normal end consolidates the parts into ``<path>``
(:func:`write_consolidated` inside :class:`AtomicFile`: a temporary file moved onto the target,
so ``<path>`` only ever exists complete) and removes the parts folder.

Parts are uncompressed (they are read once, at consolidation) and leave out the fields that hold
one value everywhere at their step (:func:`uniform_value`), which they record by value in the
global attribute :data:`UNIFORM_ATTR`: an elastic body's plastic strain, residual stress and
yield stress are two thirds of its volume bytes. The consolidated file has them in full.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import netCDF4
import numpy as np

from sacflow.solver.state import GridCoords
from sacflow.storage.run_layout import create_run_dataset, write_step, write_through
from sacflow.storage.run_variables import RUN_VARIABLES

__all__ = [
    "UNIFORM_ATTR",
    "AtomicFile",
    "part_layout",
    "parts_dir",
    "publish_part",
    "run_attributes",
    "sound_parts",
    "temporary_part",
    "uniform_value",
    "write_consolidated",
]

#: Part file names: the step index and the first 16 hex digits of the SHA-256 of the file (parts
#: written before checksums have none and are checked by reading them).
_PART = re.compile(r"^step-(\d+)(?:-([0-9a-f]{16}))?\.nc$")
#: Hex digits of the SHA-256 kept in a part's name.
_CHECKSUM_DIGITS = 16
#: Global attribute of a part: JSON ``{field: value}`` of the fields that hold one value
#: everywhere at that step and are not written out (the consolidated file has them in full).
UNIFORM_ATTR = "uniform_fields"


def parts_dir(path: str | Path) -> Path:
    """Folder holding the per-step parts of the run file ``path``."""
    path = Path(path)
    return path.with_name(path.name + ".parts")


def temporary_part(folder: Path, index: int) -> Path:
    """Temporary name, in the parts folder ``folder``, of the part of step ``index`` in writing."""
    return folder / f".step-{index:06d}.nc.{os.getpid()}.tmp"


def publish_part(tmp: Path, index: int) -> Path:
    """Give the finished temporary part ``tmp`` of step ``index`` its checksummed name.

    The file is on disk (``fsync``) before it is renamed, so a part under its final name is
    complete. Returns the final path.
    """
    target = tmp.parent / f"step-{index:06d}-{_checksum(tmp)}.nc"
    with open(tmp, "rb+") as f:
        os.fsync(f.fileno())
    os.replace(tmp, target)
    return target


def _checksum(path: Path) -> str:
    """First :data:`_CHECKSUM_DIGITS` hex digits of the SHA-256 of the file's bytes."""
    with open(path, "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()[:_CHECKSUM_DIGITS]


class AtomicFile:
    """Context manager giving a temporary path next to ``target``, moved onto it on success.

    On an exception the temporary file is removed and ``target`` is left as it was.
    """

    def __init__(self, target: Path) -> None:
        self.target = target
        self.tmp = target.with_name(f".{target.name}.{os.getpid()}.tmp")

    def __enter__(self) -> Path:
        """Return the temporary path to write."""
        return self.tmp

    def __exit__(self, exc_type: type[BaseException] | None, *_: object) -> None:
        """Move the written file onto the target, on disk first (remove it after an error)."""
        if exc_type is not None:
            self.tmp.unlink(missing_ok=True)
            return
        with open(self.tmp, "rb+") as f:  # on disk before it becomes visible
            os.fsync(f.fileno())
        os.replace(self.tmp, self.target)


def uniform_value(array: np.ndarray) -> float | None:
    """Return the value of every element of ``array`` when all are equal (not NaN), else None."""
    flat = array.reshape(-1)
    first = flat[0]
    if flat[-1] != first or not (flat == first).all():  # the ends first: most fields differ
        return None
    return float(first)


def write_consolidated(
    path: Path,
    parts: list[Path],
    coords: GridCoords,
    names: list[str],
    attrs: Mapping[str, Any],
    compression: int,
    volume_dtype: str = "f8",
) -> None:
    """Write the steps of ``parts`` into one run file ``path`` (layout as ``create_run_dataset``).

    ``compression`` and ``volume_dtype`` are those of
    :func:`~sacflow.storage.run_layout.create_run_dataset`.
    """
    with write_through(), create_run_dataset(path, coords, names, attrs, compression,
                                             volume_dtype) as nc:
        _copy_parts(parts, nc, names)


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
            write_step(nc, index, int(src["step"][0]), values)


def sound_parts(folder: Path) -> tuple[list[Path], list[Path], str]:
    """Sound parts step-0..., the damaged ones after them, and why the first one is damaged.

    A part is damaged when its SHA-256 does not match the checksum in its name (parts without
    one are read through); the first damaged part, every part after it, and the parts after a
    missing step are all listed as damaged.
    """
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


def run_attributes(part: Path) -> dict[str, Any]:
    """Global attributes of the run a part belongs to (without the part's own)."""
    with netCDF4.Dataset(part) as nc:
        attrs = {k: nc.getncattr(k) for k in nc.ncattrs()}
    attrs.pop(UNIFORM_ATTR, None)
    return attrs


def part_layout(part: Path) -> tuple[GridCoords, list[str]]:
    """Grid and stored variables (in table order) of a part."""
    with netCDF4.Dataset(part) as nc:
        coords = GridCoords(*(np.array(nc[x][:], dtype=float) for x in ("x1", "x2", "x3")))
        return coords, [name for name in RUN_VARIABLES if name in nc.variables]
