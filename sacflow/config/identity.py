"""Case identity: what of a case changes its numbers, and the ``case_id`` hash of it.

A stored run is named by the ``case_id`` of its case: the first 12 hex digits of the SHA-256 of
the canonical JSON of the case's identity, its JSON form without what does not change the
stored numbers (:data:`NOT_IN_IDENTITY`, options added later at their default) and with the
files it names replaced by their contents' fingerprints (:class:`FileFingerprints`): a measured
surface and the cells file of an inhomogeneity by the SHA-256 of the file, the source run of a
chained case by that run's ``case_id``.

This layer reads no file. The fingerprints are read by the storage layer
(:func:`sacflow.storage.fingerprints.file_fingerprints`) once per case: where a case enters
(:func:`sacflow.storage.case_file.load_case` and ``case_from_dict``, campaign expansion), and
for a case built any other way (``Case(**data)`` in a notebook, a case read back from a run
file) at the first use of its id, through the reader storage installs on import
(:func:`install_file_fingerprint_reader`). A case that names no file needs no reader.

This module imports only the standard library, so that installing the reader costs nothing.
"""

from __future__ import annotations

import hashlib
import json
import operator
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import TYPE_CHECKING, Any

from sacflow.config.dotted import flatten

if TYPE_CHECKING:
    from sacflow.config.case import Case

__all__ = [
    "DEFAULTS_LEFT_OUT",
    "NOT_IN_IDENTITY",
    "OPTIONAL_INHOMOGENEITY_KEYS",
    "OPTIONAL_SEGMENT_KEYS",
    "OPTIONAL_TABLES",
    "PLASTIC_ONLY",
    "FileFingerprintReader",
    "FileFingerprints",
    "case_id_of",
    "identity_differences",
    "identity_of",
    "install_file_fingerprint_reader",
    "names_files",
    "read_file_fingerprints",
]

#: Fields that do not change the stored numbers, left out of :attr:`Case.case_id`: the name
#: (the file name), free text, the FFT thread count and the lossless compression level.
NOT_IN_IDENTITY: tuple[str, ...] = (
    "name", "description", "solver.fft_threads", "output.compression",
)
#: Optional tables (dotted paths) added after runs were stored: left out of the identity when
#: absent, so the case_id of a case without them is the one it had before they existed.
OPTIONAL_TABLES: tuple[str, ...] = ("friction", "body.hardening.kinematic")
#: Options added after runs were stored, left out of the identity at their default value (the
#: case_id of a case that does not set them is the one it had before they existed).
DEFAULTS_LEFT_OUT: dict[str, Any] = {"output.volume_precision": "float64",
                                     "output.every_step": [],
                                     "solver.residual_displacement_in_gap": True,
                                     "solver.return_integration": "backward_euler",
                                     "body.inhomogeneity": [],
                                     "solver.inclusion_tolerance": 1e-8,
                                     "solver.inclusion_max_iterations": 1000,
                                     "solver.stress_sampling": 1,
                                     "solver.surface_correction": "centre",
                                     "solver.traction_beyond_box": False,
                                     "solver.contact_subcells": 1}
#: Keys of an inhomogeneity added after runs were stored, left out of the identity when absent
#: (its own hardening: without it, or ``law = "elastic"``, the inhomogeneity stays elastic).
OPTIONAL_INHOMOGENEITY_KEYS: tuple[str, ...] = ("hardening",)
#: Options that change no number of an elastic body, left out of its identity.
PLASTIC_ONLY: tuple[str, ...] = ("solver.return_integration",)
#: Load-path segment options added after runs were stored, left out of the identity when unset.
OPTIONAL_SEGMENT_KEYS: tuple[str, ...] = ("passes", "between", "lift_increments")
#: Hex digits of a case id.
CASE_ID_DIGITS = 12


@dataclass(frozen=True)
class FileFingerprints:
    """What of the files a case names enters its identity (None: no such file, or unreadable).

    Attributes
    ----------
    surface_digest : str or None
        First 16 hex digits of the SHA-256 of a measured surface's file: the heights count,
        not where the file lies (a moved file keeps the id, an edited one not).
    source_case_id : str or None
        ``case_id`` of the run a chained case starts from (``initial_state.run``).
    cells_digests : tuple of (str or None)
        One per inhomogeneity of the body, in order: the first 16 hex digits of the SHA-256 of
        its cells file (``shape = "cells"``), None for the other shapes (empty: none).
    """

    surface_digest: str | None = None
    source_case_id: str | None = None
    cells_digests: tuple[str | None, ...] = ()


#: Reads the fingerprints of the files a case names (installed by the storage layer).
FileFingerprintReader = Callable[["Case"], FileFingerprints]

#: The installed reader, at most one (see :func:`install_file_fingerprint_reader`).
_readers: list[FileFingerprintReader] = []


def install_file_fingerprint_reader(reader: FileFingerprintReader) -> None:
    """Install the function that reads a case's file fingerprints (replacing any other).

    :mod:`sacflow.storage.fingerprints` installs
    :func:`~sacflow.storage.fingerprints.file_fingerprints` when it is imported (every
    :mod:`sacflow.storage` import does); a test may install another one.
    """
    _readers[:] = [reader]


def names_files(case: Case) -> bool:
    """Tell whether ``case`` names files whose contents enter its id.

    Its measured surface, its source run, the cells file of an inhomogeneity.
    """
    return (case.surface.kind == "measured" or case.initial_state is not None
            or any(item.cells is not None for item in case.body.inhomogeneity))


def read_file_fingerprints(case: Case) -> FileFingerprints:
    """Return the fingerprints of the files ``case`` names, read by the installed reader.

    Raises
    ------
    RuntimeError
        When the case names a file and no reader is installed (nothing imported
        :mod:`sacflow.storage`).
    """
    if not names_files(case):
        return FileFingerprints()
    if not _readers:
        raise RuntimeError(
            f"case {case.name!r} names files (surface.path, initial_state.run or "
            "body.inhomogeneity.<i>.cells) whose contents "
            "enter its case_id, and no reader of them is installed: import sacflow.storage "
            "(sacflow.load_case and sacflow.run do)"
        )
    return _readers[0](case)


def _drop(data: dict[str, Any], dotted: str, when: Callable[[Any], bool]) -> None:
    """Delete the entry at the dotted path of nested dicts ``data`` if present and ``when(it)``."""
    *parents, leaf = dotted.split(".")
    table: Any = data
    for key in parents:
        table = table.get(key) if isinstance(table, dict) else None
    if isinstance(table, dict) and leaf in table and when(table[leaf]):
        del table[leaf]


def identity_of(data: dict[str, Any], fingerprints: FileFingerprints) -> dict[str, Any]:
    """Return the identity of a case from its JSON form ``data`` (changed in place).

    Parameters
    ----------
    data : dict
        The case's JSON form, ``json.loads(case.model_dump_json())``.
    fingerprints : FileFingerprints
        Of the files the case names; where one is None the file's path stays.

    Returns
    -------
    dict
        ``data`` without :data:`NOT_IN_IDENTITY`, the optional segment keys when unset, the
        optional tables and an inhomogeneity's own ``hardening`` when absent,
        :data:`DEFAULTS_LEFT_OUT` at their default (the return integration at the value that
        reproduces the runs stored before the option: a plastic case at the new default gets a
        new id, its numbers changed) and, for an elastic body, :data:`PLASTIC_ONLY`; a measured
        surface's path and an inhomogeneity's cells file replaced by ``sha256:<digest>``, a
        source run by ``case_id:<id>``.
    """
    _drop_what_changes_no_number(data)
    if data["surface"]["kind"] == "measured" and fingerprints.surface_digest:
        # the heights are what count: the same file moved keeps the id, an edited one not
        data["surface"]["path"] = f"sha256:{fingerprints.surface_digest}"
    if data.get("initial_state") is not None and fingerprints.source_case_id:
        # the source's identity counts, not where its file lies
        data["initial_state"]["run"] = f"case_id:{fingerprints.source_case_id}"
    items = data.get("body", {}).get("inhomogeneity", ())
    for item, digest in zip(items, fingerprints.cells_digests, strict=False):
        if digest:  # the points count, not where the file lies
            item["cells"] = f"sha256:{digest}"
    return data


def _drop_what_changes_no_number(data: dict[str, Any]) -> None:
    """Remove from ``data`` the fields :func:`identity_of` leaves out (in place)."""
    for dotted in NOT_IN_IDENTITY:
        _drop(data, dotted, lambda value: True)
    for segment in data.get("load_path", ()):  # options added later, absent when unset
        for key in OPTIONAL_SEGMENT_KEYS:
            if segment.get(key, ...) is None:
                del segment[key]
    for dotted in OPTIONAL_TABLES:  # absent: the id of a case written before they existed
        _drop(data, dotted, lambda value: value is None)
    for dotted, default in DEFAULTS_LEFT_OUT.items():  # the same, for options at default
        _drop(data, dotted, partial(operator.eq, default))
    for item in data.get("body", {}).get("inhomogeneity", ()):  # the same, per inhomogeneity
        for key in OPTIONAL_INHOMOGENEITY_KEYS:
            _drop(item, key, lambda value: value is None)
    if data["body"]["hardening"]["law"] == "elastic":
        for dotted in PLASTIC_ONLY:
            _drop(data, dotted, lambda value: True)


def case_id_of(identity: dict[str, Any]) -> str:
    """First 12 hex digits of the SHA-256 of the canonical JSON of ``identity``."""
    text = json.dumps(identity, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:CASE_ID_DIGITS]


def identity_differences(stored: dict[str, Any], current: dict[str, Any]) -> list[str]:
    """Dotted paths where two case identities (:meth:`Case.identity`) differ, with both values.

    Returns lines such as ``"grid.nx: 128 -> 32"``, in path order.
    """
    a, b = flatten(stored), flatten(current)
    missing = "(absent)"
    return [
        f"{key}: {json.dumps(a.get(key, missing))} -> {json.dumps(b.get(key, missing))}"
        for key in sorted(a.keys() | b.keys())
        if a.get(key, missing) != b.get(key, missing)
    ]
