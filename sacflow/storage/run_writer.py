"""Writing a run: one step at a time into part files, consolidated at the end.

One netCDF4 file per case, ``<out>/<case name>.nc``, laid out by
:mod:`sacflow.storage.run_layout` from the variable table
(:data:`~sacflow.storage.run_variables.RUN_VARIABLES`); numerical code hands over bare arrays in a
:class:`~sacflow.solver.state.State` and this module checks them against the table and the grid.

Crash safety. :class:`RunWriter` writes each step as its own complete part file, with the
solver state after it (:mod:`sacflow.storage.run_parts`, :mod:`sacflow.storage.run_restart`).
A normal end consolidates the parts into ``<path>`` atomically (global attribute
``complete = 1``) and removes the parts folder. After a crash,
:func:`~sacflow.storage.run_reader.open_run` reads the completed parts (``complete = 0``) and
``RunWriter(..., keep_steps=n)`` carries on after the first ``n``.

Run identity: a stored run, complete or not, is only replaced when the writer is told to
(``overwrite=True``; ``sacflow run --overwrite``); otherwise :class:`RunExistsError` names the
file, both case ids and the fields that differ (:func:`replace_message`). Damaged parts, and
those after them, are always dropped.

One process per run file: a writer holds the run's lock (:mod:`sacflow.storage.run_lock`) from
its creation to :meth:`RunWriter.close` or :meth:`RunWriter.abort`; a second writer of the same
file raises :class:`~sacflow.storage.run_lock.RunBusyError` naming the process, host and start
time of the first, and so does a writer whose ``info`` is out of date (another process wrote
the file since it was taken).
"""

from __future__ import annotations

import json
import shutil
import weakref
from collections.abc import Iterable
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np

from sacflow.config.schema import Case, identity_differences
from sacflow.errors import SacflowError
from sacflow.solver.state import INCLUSION_SCALARS, GridCoords, State
from sacflow.storage.run_layout import create_run_dataset, write_step, write_through
from sacflow.storage.run_lock import RunBusyError, RunLock
from sacflow.storage.run_parts import (
    UNIFORM_ATTR,
    AtomicFile,
    parts_dir,
    publish_part,
    run_attributes,
    temporary_part,
    uniform_value,
    write_consolidated,
)
from sacflow.storage.run_reader import RunInfo, run_info
from sacflow.storage.run_restart import write_restart
from sacflow.storage.run_variables import (
    RUN_VARIABLES,
    SURFACE,
    SURFACE_VECTOR,
    TENSOR,
    VOLUME,
    dimension_sizes,
    selected_fields,
)
from sacflow.storage.write_failure import reporting

__all__ = ["RunBusyError", "RunExistsError", "RunWriter", "replace_message"]

#: At most this many differing fields are listed in :func:`replace_message`.
_MAX_DIFFERENCES = 12


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
        Variables to store (default: those of every run,
        :data:`~sacflow.storage.run_variables.VARIABLES`).
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
        as the ``requested_case_id`` attribute;
        :func:`~sacflow.storage.run_reader.is_complete` accepts either id.
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
        self.names = selected_fields(fields)
        self.compression = compression
        # Volume fields of the consolidated file in float32 when the case asks (parts, the
        # restart state, stay float64: an interrupted run resumes exactly).
        self.volume_dtype = "f4" if case.output.volume_precision == "float32" else "f8"
        self._closed = False
        self.lock = RunLock(self.path)  # one process per run file, or RunBusyError
        self.lock.acquire()
        weakref.finalize(self, self.lock.release)  # a writer dropped unclosed lets it go too
        try:
            if info is not None and not _unchanged(info):
                raise RunBusyError(
                    f"{self.path} was written by another process since this run looked at it; "
                    "nothing was changed: run again to go on from what it stored"
                )
            info = info if info is not None else run_info(self.path)
            kept = _prepare(info, case, keep_steps, overwrite)
        except BaseException:
            self.lock.release()
            raise
        self.attrs = run_attributes(kept[0]) if kept else _global_attrs(case)
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
            if np.ndim(array) and (value := uniform_value(array)) is not None
        }
        values = {name: v for name, v in values.items() if name not in uniform}
        attrs = {**self.attrs, UNIFORM_ATTR: json.dumps(uniform)}
        tmp = temporary_part(self.parts, self.next_step)
        # Parts are temporary, read once at consolidation: uncompressed (compressing each step
        # twice, in its part and in the consolidated file, would be wasted work).
        try:
            with reporting(f"step {self.next_step}", self.path, self.next_step):
                with write_through(), create_run_dataset(tmp, self.coords, self.names, attrs,
                                                         0) as nc:
                    write_step(nc, 0, state.step, values)
                    if state.restart:
                        write_restart(nc, state, {**values, **uniform})
                part = publish_part(tmp, self.next_step)
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise
        self._stored.append(part)
        self.next_step += 1

    def close(self) -> None:
        """End normally: consolidate the parts into :attr:`path` and remove the parts folder."""
        if self._closed:
            return
        self._closed = True
        attrs = {**self.attrs, "complete": 1}
        try:
            with reporting("the consolidated file", self.path, self.next_step), \
                    AtomicFile(self.path) as tmp:
                write_consolidated(tmp, self._stored, self.coords, self.names, attrs,
                                   self.compression, self.volume_dtype)
            shutil.rmtree(self.parts, ignore_errors=True)
        finally:
            self.lock.release()

    def abort(self) -> None:
        """Stop without consolidating: the stored steps stay as parts (resume later)."""
        self._closed = True
        self.lock.release()

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


def _unchanged(info: RunInfo) -> bool:
    """Nothing was written at ``info.path`` since ``info`` was taken (the file, the part names)."""
    file_there = info.path.exists() or info.path.is_symlink()
    if info.complete or info.unreadable or file_there:
        return file_there == (info.complete or info.unreadable)
    folder = parts_dir(info.path)
    names = {p.name for p in folder.glob("step-*.nc")} if folder.is_dir() else set()
    return names == {p.name for p in (*info.parts, *info.damaged)}


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
        "Nothing was changed. To replace it, run again with --overwrite (overwrite=True from "
        "Python); to keep it, use another --out folder (out_dir) or another case name."
    )
    return "\n".join(lines)


def _global_attrs(case: Case) -> dict[str, Any]:
    """Global attributes of a new run of ``case`` (CF conventions, the case, its id, version)."""
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
    sizes = dimension_sizes(coords)
    values: dict[str, Any] = {k: v for k, v in state.scalars().items() if k in names}
    values.update({k: getattr(state, k) for k in INCLUSION_SCALARS if k in names})
    for group, arrays, dims in (
        ("surface", state.surface, (SURFACE, SURFACE_VECTOR)),
        ("volume", state.volume, (VOLUME, TENSOR)),
    ):
        for name, array in arrays.items():
            if name not in RUN_VARIABLES or RUN_VARIABLES[name].dims not in dims:
                raise ValueError(f"State.{group}[{name!r}] is not a {group} field")
            shape = tuple(sizes[d] for d in RUN_VARIABLES[name].dims[1:])
            if np.shape(array) != shape:
                raise ValueError(
                    f"State.{group}[{name!r}] has shape {np.shape(array)}, not {shape}"
                )
            if name in names:
                values[name] = array
    return values
