"""A case's hardening law (schema model, or a dict / namespace of its fields) as a runtime law.

The schema's hardening models (:mod:`sacflow.config.schema`) are the one place of the laws'
rules for case files; this module validates anything that is not such a model yet through
them (one error per offending field) and builds the laws of
:mod:`sacflow.mechanics.hardening` the return mapping runs with.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from pydantic import BaseModel, ValidationError

from sacflow.config import schema
from sacflow.mechanics.hardening import (
    DepthScaledHardening,
    HardeningLaw,
    KinematicLaw,
    LinearHardening,
    NoPlasticity,
    PerfectPlasticity,
    SwiftHardening,
    TabularHardening,
)

__all__ = ["hardening_from_schema", "kinematic_from_schema"]

#: Schema model of each ``law``.
SCHEMA_LAWS: dict[str, type[BaseModel]] = {
    "elastic": schema.Elastic,
    "swift": schema.Swift,
    "linear": schema.Linear,
    "perfectly_plastic": schema.PerfectlyPlastic,
    "tabular": schema.Tabular,
}


def validated(model: type[BaseModel], fields: dict[str, Any]) -> Any:
    """``fields`` validated by the schema ``model``.

    Raises
    ------
    ValueError
        Naming the law, each offending field, what is wrong and the value found.
    """
    try:
        return model.model_validate(fields)
    except ValidationError as exc:
        what = f"hardening law {fields['law']!r}" if "law" in fields else model.__name__
        problems = []
        for err in exc.errors(include_url=False):
            loc = [str(k) for k in err["loc"]]
            value = err.get("input")
            if err["type"] == schema.FIELD_ERROR:
                loc.append(err["ctx"]["field"])
                value = fields.get(loc[-1])
            got = "" if err["type"] == "missing" else f"; got {value!r:.60}"
            problems.append(f"field {'.'.join(loc)!r}: {err['msg']}{got}")
        raise ValueError(f"{what}: " + "; ".join(problems)) from None


def as_floats(values: Any) -> Any:
    """Array-likes as (nested) lists for validation; anything else as it is."""
    try:
        return np.asarray(values, dtype=float).tolist()
    except (TypeError, ValueError):
        return values


def field_of(obj: Any, name: str, default: Any = None) -> Any:
    """Field ``name`` of a dict or an object with attributes."""
    return obj.get(name, default) if isinstance(obj, dict) else getattr(obj, name, default)


def schema_law(obj: Any) -> Any:
    """``obj`` as a validated schema hardening model (it may be one already)."""
    if isinstance(obj, tuple(SCHEMA_LAWS.values())):
        return obj
    kind = field_of(obj, "law")
    if kind not in SCHEMA_LAWS:
        raise ValueError(f"hardening law must be one of {list(SCHEMA_LAWS)}, got {kind!r}")
    model = SCHEMA_LAWS[kind]
    data = {name: field_of(obj, name) for name in model.model_fields}
    data = {name: value for name, value in data.items() if value is not None}
    if "depth_profile" in data and not isinstance(data["depth_profile"], BaseModel):
        profile = data["depth_profile"]
        data["depth_profile"] = {k: as_floats(field_of(profile, k)) for k in ("depth", "factor")}
    for name in ("plastic_strain", "stress"):
        if name in data:
            data[name] = as_floats(data[name])
    return validated(model, data)


def hardening_from_schema(obj: Any) -> HardeningLaw:
    """Build a law from a schema model or any object (SimpleNamespace, dict) with a ``law`` field.

    ``law`` in {"elastic", "swift", "linear", "perfectly_plastic", "tabular"} with the fields
    of :mod:`sacflow.config.schema`'s model of that law (B, C, n, strain_unit / yield_stress,
    modulus / yield_stress / plastic_strain, stress, beyond_last); an optional ``depth_profile``
    (``depth``, ``factor``) wraps the law in
    :class:`~sacflow.mechanics.hardening.DepthScaledHardening`. Anything but a schema model is
    validated by that model first: what the schema accepts builds here and runs in the return
    mapping.

    Raises
    ------
    ValueError
        Naming the law and the offending field.
    """
    law = schema_law(obj)
    builders: dict[str, Callable[[], HardeningLaw]] = {
        "elastic": NoPlasticity,
        "swift": lambda: SwiftHardening(law.B, law.C, law.n, law.strain_unit),
        "linear": lambda: LinearHardening(law.yield_stress, law.modulus),
        "perfectly_plastic": lambda: PerfectPlasticity(law.yield_stress),
        "tabular": lambda: TabularHardening(law.plastic_strain, law.stress, law.beyond_last),
    }
    built = builders[law.law]()
    profile = getattr(law, "depth_profile", None)
    if profile is not None:
        built = DepthScaledHardening(built, profile.depth, profile.factor)
    return built


def kinematic_from_schema(hardening: Any) -> KinematicLaw | None:
    """Return the backstress law of a schema hardening law (or dict); None when it has none.

    ``kinematic = {modulus, recall}`` as a :class:`~sacflow.mechanics.hardening.KinematicLaw`.
    """
    spec = field_of(hardening, "kinematic")
    if spec is None:
        return None
    return KinematicLaw(float(field_of(spec, "modulus")), float(field_of(spec, "recall", 0.0)))
