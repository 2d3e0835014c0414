"""Fingerprints of the files a case names, the part of its ``case_id`` that storage reads.

A case's id covers the contents of the files it names, not their paths
(:mod:`sacflow.config.identity`): a measured surface and the cells file of an inhomogeneity by
the SHA-256 of the file, the source run
of a chained case by the ``case_id`` that run stores. The configuration layer reads no file;
this module reads them, once per case: :func:`identified` where a case enters (the case file
readers and campaign expansion), and :func:`file_fingerprints`, installed as the configuration
layer's reader when this module is imported, for a case built any other way. It imports no
model (nor pydantic), so that importing it costs nothing. A file that cannot be read leaves its
path in the identity.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import TYPE_CHECKING

from sacflow.config.identity import (
    FileFingerprints,
    install_file_fingerprint_reader,
    names_files,
)

if TYPE_CHECKING:
    from sacflow.config.case import Case

__all__ = ["file_digest", "file_fingerprints", "identified", "stored_case_id"]

#: Hex digits of a file's SHA-256 kept in a case identity.
DIGEST_DIGITS = 16


def file_digest(path: Path) -> str | None:
    """SHA-256 of a file's contents (first 16 hex digits), or None when it cannot be read."""
    try:
        with open(path, "rb") as f:
            return hashlib.file_digest(f, "sha256").hexdigest()[:DIGEST_DIGITS]
    except OSError:
        return None


def stored_case_id(path: Path) -> str | None:
    """Return the ``case_id`` attribute of a run file, or None when it cannot be read."""
    try:
        import netCDF4  # only for cases that start from a stored run

        with netCDF4.Dataset(path) as nc:
            return str(nc.getncattr("case_id"))
    except (OSError, AttributeError, RuntimeError):
        return None


def file_fingerprints(case: Case) -> FileFingerprints:
    """Read the fingerprints of the files ``case`` names.

    Its measured surface, its source run, the cells files of its inhomogeneities.
    """
    surface = case.surface
    items = case.body.inhomogeneity
    return FileFingerprints(
        surface_digest=file_digest(surface.path) if surface.kind == "measured" else None,
        source_case_id=None if case.initial_state is None else stored_case_id(
            case.initial_state.run),
        cells_digests=tuple(None if item.cells is None else file_digest(item.cells)
                            for item in items) if any(i.cells for i in items) else (),
    )


def identified(case: Case) -> Case:
    """Return ``case`` with the fingerprints of the files it names read now, its id fixed.

    Where a case enters (a case file, a campaign's expansion), after its files were checked.
    """
    if not names_files(case):
        return case
    return case.with_file_fingerprints(file_fingerprints(case))


install_file_fingerprint_reader(file_fingerprints)
