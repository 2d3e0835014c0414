"""Reading runs: what is stored at a run path, the run as an xarray Dataset, its scalars.

:func:`run_info` looks once at what is stored at ``<out>/<name>.nc``: a finished (consolidated)
run, the sound parts of an interrupted one, damaged parts, or a file that is not a run; its
:class:`RunInfo` names the stored case, tells whether it matches a case id (run identity), and
reads the solver state kept with the last part (:mod:`sacflow.storage.run_restart`).
:func:`open_run` (``sacflow.open_run``) opens a run as an :class:`xarray.Dataset`: the
consolidated file, or the completed steps of an interrupted run (``complete = 0``) gathered into
a temporary file. :func:`read_scalars` reads the per-step scalars with netCDF4 alone (a campaign
worker need not import xarray).
"""

from __future__ import annotations

import tempfile
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import netCDF4
import numpy as np

from sacflow.config.schema import Case
from sacflow.errors import InputError
from sacflow.storage.run_parts import (
    part_layout,
    parts_dir,
    run_attributes,
    sound_parts,
    write_consolidated,
)
from sacflow.storage.run_restart import has_restart, read_restart
from sacflow.storage.run_variables import RUN_VARIABLES, SCALAR

if TYPE_CHECKING:  # xarray is imported where runs are read: writers (campaign workers) skip it
    import xarray as xr

__all__ = [
    "RunFileError",
    "RunInfo",
    "RunNotFoundError",
    "completed_steps",
    "is_complete",
    "not_a_run",
    "open_run",
    "read_scalars",
    "run_info",
]


class RunFileError(InputError):
    """A file given as a run is damaged, truncated, or not a sacflow run (the message says)."""


class RunNotFoundError(RunFileError, FileNotFoundError):
    """No run at the path: no file and no completed steps."""


#: First bytes of an HDF5 file (netCDF-4), and of a classic netCDF file.
_HDF5_SIGNATURE, _CDF_SIGNATURE = b"\x89HDF\r\n\x1a\n", b"CDF"


def not_a_run(path: Path, problem: str) -> str:
    """Say what the file ``path`` is instead of a run, and what to do (for :class:`RunFileError`).

    ``problem`` is the reader's own complaint, kept at the end of the message.
    """
    try:
        with open(path, "rb") as f:
            head = f.read(64)
    except OSError as exc:  # a folder, no permission
        return f"{path}: cannot be read as a run file ({exc.strerror or exc})"
    text = head.lstrip()
    if not head:
        what = "an empty file, not a run file"
    elif (head.startswith(_HDF5_SIGNATURE) or head.startswith(_CDF_SIGNATURE)) and _opens(path):
        what = (f"a netCDF file, but not a sacflow run ({problem or 'no step dimension'}): a "
                "comparison's output, or another program's? Give a <name>.nc written by "
                "`sacflow run`")
        problem = ""
    elif head.startswith(_HDF5_SIGNATURE) or head.startswith(_CDF_SIGNATURE):
        what = ("a damaged or truncated netCDF file (written while the disk filled up, or "
                "copied in part?): run its case again to rewrite it")
    elif path.name.endswith(".manifest.json") or text.startswith(b"{"):
        what = ("a JSON file (a campaign manifest?), not a run file: open a campaign with "
                "sacflow.open_campaign, or give one of its <case>.nc files")
    elif path.suffix == ".toml" or b"=" in head:
        what = ("a text file (a case or campaign file?), not a run file: run it with "
                "`sacflow run` (`sacflow campaign`) and give the <name>.nc it writes")
    else:
        what = "not a netCDF file, so not a sacflow run file"
    return f"{path}: {what} ({problem})" if problem else f"{path}: {what}"


def _opens(path: Path) -> bool:
    """Tell whether netCDF opens ``path`` (its header is sound)."""
    try:
        with netCDF4.Dataset(path):
            return True
    except (OSError, RuntimeError):
        return False


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
            return not_a_run(self.path, self.problem).removeprefix(f"{self.path}: ")
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
        if self.attrs and not self.unreadable:
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
        return has_restart(self.parts[-1])

    def restart(self) -> tuple[dict[str, np.ndarray], float | None] | None:
        """Solver state stored with the last sound part: ``(arrays, first-contact offset)``.

        None when there is no part or the part has no state (written by a simulation that
        cannot resume, or by an older sacflow); the runner then replays the stored steps.
        """
        return read_restart(self.parts[-1]) if self.parts else None


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
                variables = tuple(name for name in RUN_VARIABLES if name in nc.variables)
        except KeyError as exc:  # a netCDF file without a step dimension
            return RunInfo(path, problem=f"no {exc} dimension", unreadable=True)
        except (OSError, RuntimeError) as exc:
            return RunInfo(path, problem=str(exc) or type(exc).__name__, unreadable=True)
        if "case_id" not in attrs:  # a netCDF file of steps, but not a run (a compare output)
            return RunInfo(path, attrs=attrs, problem="no case_id attribute", unreadable=True)
        return RunInfo(path, complete=bool(attrs.get("complete")), attrs=attrs, steps=steps,
                       variables=variables)
    parts, damaged, problem = sound_parts(parts_dir(path))
    attrs, variables = {}, ()
    if parts:
        attrs = run_attributes(parts[0])
        variables = tuple(part_layout(parts[0])[1])
    return RunInfo(path, attrs=attrs, steps=len(parts), parts=tuple(parts),
                   damaged=tuple(damaged), problem=problem, variables=variables)


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

    Raises
    ------
    RunNotFoundError
        No file and no completed steps at ``path`` (also a ``FileNotFoundError``).
    RunFileError
        The file is damaged or truncated, or not a sacflow run (a manifest, a case file, any
        other file): the message names the file, what it is, and what to do.
    """
    import xarray as xr

    path = Path(path)
    if path.exists():
        info = run_info(path)
        if info.unreadable:
            raise RunFileError(not_a_run(path, info.problem))
        try:
            return xr.open_dataset(path) if lazy else _load(path)
        except (OSError, ValueError, RuntimeError) as exc:
            raise RunFileError(f"{path}: a damaged run file: its arrays cannot be read "
                               f"({exc}); run its case again to rewrite it") from None
    parts = list(run_info(path).parts)
    if not parts:
        raise RunNotFoundError(f"no run at {path} (no file and no completed steps)")
    coords, names = part_layout(parts[0])
    with tempfile.TemporaryDirectory() as folder:
        target = Path(folder) / path.name
        write_consolidated(target, parts, coords, names, run_attributes(parts[0]), compression=0)
        return _load(target)


def _load(path: Path) -> xr.Dataset:
    """Read the whole run file ``path`` into memory and close it."""
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
            for name, var in RUN_VARIABLES.items():
                if var.dims == SCALAR and name in nc.variables:
                    values = np.asarray(nc[name][:])
                    columns.setdefault(name, []).append(
                        values.astype(bool) if var.dtype == "bool" else values)
    return {name: np.concatenate(chunks) for name, chunks in columns.items()}
