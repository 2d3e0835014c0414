"""Reading the stored state a case starts from (``initial_state = { run, step, offset }``).

The module that reads a chained case's source run: its arrays, which the solver receives as a
:class:`~sacflow.mechanics.initial_state.StoredState` (:func:`read_initial_state`) as it receives
a measured surface, and the number of the chosen step (:func:`stored_step_number`, for the new
run's attributes). Only the source's ``case_id`` attribute is read elsewhere, by
:mod:`sacflow.config.schema` for the case identity. Errors name ``initial_state`` and the fix.
"""

from __future__ import annotations

import json
from pathlib import Path

import netCDF4
import numpy as np

from sacflow.config.schema import Case
from sacflow.mechanics.initial_state import InitialStateError, StoredState

__all__ = [
    "InitialStateError",
    "check_initial_state",
    "read_initial_state",
    "stored_step_number",
]

#: Variables the source run must store at the chosen step.
NEEDED = ("plastic_strain", "equivalent_plastic_strain")


def check_initial_state(case: Case) -> None:
    """Check, without reading its arrays, that the run and step ``initial_state`` names exist.

    Raises
    ------
    InitialStateError
        As :func:`read_initial_state`, except for values not stored at the step (found when the
        arrays are read).
    """
    _open(case, arrays=False)


def read_initial_state(case: Case) -> StoredState | None:
    """Return the stored state ``case.initial_state`` names, or None when it names none.

    Raises
    ------
    InitialStateError
        The file is missing, not a finished run, has no such step, or does not store the plastic
        strain and the equivalent plastic strain at that step.
    """
    return _open(case, arrays=True)


def _open(case: Case, arrays: bool) -> StoredState | None:
    spec = case.initial_state
    if spec is None:
        return None
    path = Path(spec.run)
    where = f"initial_state.run {path}"
    if not path.exists():
        raise InitialStateError(f"{where}: no such run file (a finished run is needed; an "
                                "interrupted one must be finished first)")
    try:
        with netCDF4.Dataset(path) as nc:
            nc.set_auto_mask(False)
            if arrays:
                return _read(nc, spec.step, where, _kinematic(case))
            _check(nc, spec.step, where, _kinematic(case))
            return None
    except OSError as exc:
        raise InitialStateError(f"{where}: not a readable run file ({exc})") from None


def _kinematic(case: Case) -> bool:
    return getattr(case.body.hardening, "kinematic", None) is not None


def _source_kinematic(nc: netCDF4.Dataset) -> dict | None:
    """Return the source case's ``[body.hardening.kinematic]`` table (None: isotropic only)."""
    try:
        stored = json.loads(str(nc.getncattr("case")))
    except (AttributeError, ValueError):
        return None
    return (stored.get("body", {}).get("hardening", {}) or {}).get("kinematic")


def _check(nc: netCDF4.Dataset, step: int, where: str, kinematic: bool) -> None:
    """Check that the file is a run with that step and the variables a start needs.

    A source with kinematic hardening carries its backstress over: it must be stored, and the
    case must have kinematic hardening too (dropping the backstress would move every yield
    surface back to the origin without saying so). A source without kinematic hardening has a
    zero backstress, so a kinematic case may start from it.
    """
    if "case_id" not in nc.ncattrs() or "step" not in nc.variables:
        raise InitialStateError(f"{where}: not a sacflow run file")
    steps = np.asarray(nc["step"][:])
    if not -steps.size <= step < steps.size:
        raise InitialStateError(f"initial_state.step {step}: the run stores {steps.size} steps "
                                f"(0 to {steps.size - 1}, or -1 to -{steps.size})")
    missing = [name for name in NEEDED if name not in nc.variables]
    if missing:
        raise InitialStateError(
            f"{where}: the run does not store {', '.join(missing)}; run the source with them in "
            "[output] fields"
        )
    source = _source_kinematic(nc)
    if source is not None and not kinematic:
        constants = ", ".join(f"{k} = {v:g}" for k, v in source.items())
        raise InitialStateError(
            f"{where}: the source has kinematic hardening ({constants}) and its backstress "
            "would be lost; add [body.hardening.kinematic] to this case"
        )
    if source is not None and "backstress" not in nc.variables:
        raise InitialStateError(
            f"{where}: the source has kinematic hardening but does not store its backstress; "
            "run the source with backstress in [output] fields"
        )


def _read(nc: netCDF4.Dataset, step: int, where: str, kinematic: bool) -> StoredState:
    _check(nc, step, where, kinematic)
    steps = np.asarray(nc["step"][:])
    index = step % steps.size
    names = (*NEEDED, "backstress") if _source_kinematic(nc) is not None else NEEDED
    arrays = {name: np.asarray(nc[name][index], dtype=float) for name in names}
    if any(not np.isfinite(a).all() for a in arrays.values()):
        raise InitialStateError(
            f"{where}: step {int(steps[index])} has no stored {' and '.join(arrays)}; run the "
            "source with them in [output] fields, stored at that step "
            "(output.volume_every = 1, or pick a stored step)"
        )
    x1, x2, x3 = (np.asarray(nc[x][:], dtype=float) for x in ("x1", "x2", "x3"))
    return StoredState(x1, x2, x3, arrays["plastic_strain"], arrays["equivalent_plastic_strain"],
                       case_id=str(nc.getncattr("case_id")), step=int(steps[index]),
                       backstress=arrays.get("backstress"))


def stored_step_number(path: Path, step: int) -> int | None:
    """Return the step number that index ``step`` of a run's stored steps names (None if none)."""
    try:
        with netCDF4.Dataset(path) as nc:
            steps = np.asarray(nc["step"][:])
    except (OSError, IndexError, KeyError):
        return None
    return int(steps[step % steps.size]) if -steps.size <= step < steps.size else None
