"""The solver state stored with each part of a run (true resume).

Each part holds, in its group :data:`RESTART_GROUP`, what the solver needs to go on after that
step (:data:`~sacflow.solver.state.RESTART_FIELDS`: plastic strain, equivalent plastic strain,
residual displacement, contact pressure; any other array the solver keeps in
``State.restart`` under the name of a run variable (:func:`optional_restart_fields`: the
backstress of kinematic hardening, the equivalent eigenstrain of inhomogeneities as the warm
start of their solve); and the first-contact offset), except the arrays that the part already
stores as output fields with the same values (attribute ``in_output``) and those holding one
value everywhere (attribute ``uniform``). The consolidated file does not keep them: a finished
run does not resume. An interrupted run resumes from its last sound part
(:func:`read_restart`); one whose parts have no state (written by a simulation that cannot
resume, or by an older sacflow) is replayed instead.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import netCDF4
import numpy as np

from sacflow.solver.state import OPTIONAL_RESTART_FIELDS, RESTART_FIELDS, State
from sacflow.storage.run_parts import UNIFORM_ATTR, uniform_value
from sacflow.storage.run_variables import RUN_VARIABLES

__all__ = [
    "RESTART_GROUP",
    "has_restart",
    "optional_restart_fields",
    "read_restart",
    "write_restart",
]

#: netCDF group of a part holding the solver state after its step (see the module docstring).
RESTART_GROUP = "restart"


def optional_restart_fields(held: Iterable[str]) -> list[str]:
    """Return the arrays of ``held`` kept beyond :data:`RESTART_FIELDS`, in table order.

    :data:`~sacflow.solver.state.OPTIONAL_RESTART_FIELDS` (the backstress) and any other run
    variable the solver keeps in ``State.restart`` (the equivalent eigenstrain of
    inhomogeneities); names that are no run variable are not kept.
    """
    held = set(held)
    names = [*OPTIONAL_RESTART_FIELDS, *RUN_VARIABLES]
    return [name for name in dict.fromkeys(names)
            if name in held and name not in RESTART_FIELDS]


def write_restart(nc: netCDF4.Dataset, state: State, stored: Mapping[str, Any]) -> None:
    """Write group :data:`RESTART_GROUP` of a part: the solver state after the step.

    Arrays equal to the part's own output field of the same name (``stored``: an array, or the
    value of a field recorded by value) are not written twice (attribute ``in_output``); arrays
    holding one value are recorded by value (``uniform``).
    """
    group = nc.createGroup(RESTART_GROUP)
    offset = state.first_contact_offset
    group.first_contact_offset = math.nan if offset is None else float(offset)
    in_output, uniform = [], {}
    optional = optional_restart_fields(state.restart)
    for name in (*RESTART_FIELDS, *optional):
        array = np.asarray(state.restart[name], dtype=float)
        if name in stored and _same(stored[name], array):
            in_output.append(name)
        elif (value := uniform_value(array)) is not None:
            uniform[name] = value
        else:
            group.createVariable(name, "f8", RUN_VARIABLES[name].dims[1:])[:] = array
    group.in_output = json.dumps(in_output)
    group.uniform = json.dumps(uniform)


def _same(stored: Any, array: np.ndarray) -> bool:
    """Tell whether a stored output value (array, or one value of a uniform field) is ``array``."""
    if np.ndim(stored) == 0:
        return uniform_value(array) == stored
    return stored is array or np.array_equal(stored, array)


def has_restart(part: Path) -> bool:
    """Tell whether ``part`` holds the solver state after its step."""
    with netCDF4.Dataset(part) as nc:
        return RESTART_GROUP in nc.groups


def read_restart(part: Path) -> tuple[dict[str, np.ndarray], float | None] | None:
    """Read the solver state a part stores (:func:`write_restart`), or None when it has none.

    Returns
    -------
    (dict, float or None) or None
        The arrays by name, and the first-contact offset (None before the first contact).
    """
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
        optional = optional_restart_fields(held)
        for name in (*RESTART_FIELDS, *optional):
            shape = tuple(sizes[d] for d in RUN_VARIABLES[name].dims[1:])
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
