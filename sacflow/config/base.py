"""Base of the case models: the frozen model, the field-named error, the unit and count types.

Every model of a case (:mod:`sacflow.config.case` and the tables it holds) derives from
:class:`Model`: immutable, hashable, unknown keys rejected. Units are SI everywhere (m, Pa, N);
sequences are tuples so that a case cannot be changed in place. Cross-field checks raise
:func:`field_error`, which names the offending field so that the one-screen messages of
:mod:`sacflow.config.problems` can point at it.
"""

from __future__ import annotations

import math
import types
import typing
from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, model_validator
from pydantic_core import PydanticCustomError

__all__ = [
    "FIELD_ERROR",
    "MAX_CELLS",
    "MAX_PASSES",
    "MAX_STEPS",
    "MAX_THREADS",
    "NAME_PATTERN",
    "NON_FINITE_TEXT",
    "CellCount",
    "FiniteFloat",
    "Model",
    "NonNegativeFloat",
    "PoissonRatio",
    "PositiveFloat",
    "PositiveInt",
    "Radius",
    "StepCount",
    "field_error",
    "finite_json",
    "not_a_number",
    "number_kind",
    "strictly_increasing",
    "unit_vector",
]

#: Error type of the case-level checks; its context names the offending field.
FIELD_ERROR = "sacflow_field"
#: Pattern shared by case and campaign names (they become file names).
NAME_PATTERN = r"^[A-Za-z0-9][A-Za-z0-9_.-]*$"

PositiveFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]
NonNegativeFloat = Annotated[float, Field(ge=0, allow_inf_nan=False)]
FiniteFloat = Annotated[float, Field(allow_inf_nan=False)]
PositiveInt = Annotated[int, Field(ge=1)]
#: Most cells along one grid axis (nx, ny, nz): far above any grid a machine can hold (the
#: memory check refuses those with a size estimate), low enough that every index stays a
#: machine integer.
MAX_CELLS = 1 << 16
#: Most increments (or rolling steps) of one load-path segment: a run of that many steps takes
#: days; the bound keeps the expanded step plan small.
MAX_STEPS = 100_000
CellCount = Annotated[int, Field(ge=1, le=MAX_CELLS)]
#: Most FFT threads (``solver.fft_threads``): FFTW takes a C integer; no machine has more cores.
MAX_THREADS = 4096
StepCount = Annotated[int, Field(ge=1, le=MAX_STEPS)]
#: Most passes of one roll segment (a campaign of millions of cycles is not run pass by pass).
MAX_PASSES = 10000
#: Radius of curvature [m]; ``inf`` stands for a flat surface.
Radius = Annotated[float, Field(gt=0)]
PoissonRatio = Annotated[float, Field(gt=-1, lt=0.5)]

#: Passes of a direction's normalisation towards its fixed point (two suffice: no direction of
#: 200 000 random ones needed more).
NORMALISE_PASSES = 4


#: The strings a float field accepts: how the case JSON writes non-finite values, and TOML's.
NON_FINITE_TEXT = frozenset({"Infinity", "-Infinity", "+Infinity", "NaN", "inf", "-inf", "nan"})


class Model(BaseModel):
    """Base of every sacflow model: immutable, hashable, unknown keys rejected.

    Numbers are numbers: a ``true``/``false`` or a quoted ``"16"`` given for a number is an
    error naming the field (pydantic would read ``true`` as 1.0 and ``"16"`` as 16, and a later
    check would blame another field).
    """

    model_config = ConfigDict(frozen=True, extra="forbid", ser_json_inf_nan="strings")

    @model_validator(mode="before")
    @classmethod
    def _numbers_are_numbers(cls, data: Any) -> Any:
        if not isinstance(data, dict):
            return data
        for name, value in data.items():
            field = cls.model_fields.get(name)
            kind = None if field is None else number_kind(field.annotation)
            if kind is None:
                continue
            values = value if isinstance(value, list | tuple) and kind[1] else (value,)
            for item in values:
                if not_a_number(item, kind[0]):
                    raise field_error(name, _number_message(item, kind[0]))
        return data


def number_kind(annotation: Any) -> tuple[type, bool] | None:
    """``(int or float, is a tuple of them)`` for a numeric field annotation, else None.

    ``float``, ``int``, ``X | None`` of them and homogeneous tuples of them count.
    """
    origin = typing.get_origin(annotation)
    if origin in (typing.Union, types.UnionType):
        kinds = [number_kind(a) for a in typing.get_args(annotation) if a is not type(None)]
        return kinds[0] if len(kinds) == 1 else None
    if origin is tuple:
        inner = {number_kind(a) for a in typing.get_args(annotation) if a is not Ellipsis}
        only = next(iter(inner)) if len(inner) == 1 else None
        return None if only is None else (only[0], True)
    if annotation is float or annotation is int:
        return annotation, False
    return None


def _number_message(value: Any, kind: type) -> str:
    """Say that ``value`` is not a number of type ``kind``, and how to write one."""
    what = "an integer" if kind is int else "a number"
    if isinstance(value, bool):
        return f"expected {what}, got {str(value).lower()}"
    return f"expected {what}, got the text {value!r} (write numbers without quotes)"


def not_a_number(value: Any, kind: type) -> bool:
    """Tell whether ``value`` must be refused for a field of type ``kind`` (int or float)."""
    if isinstance(value, bool):
        return True
    if isinstance(value, str):
        return kind is int or value.strip() not in NON_FINITE_TEXT
    return False


def field_error(field: str, message: str) -> PydanticCustomError:
    """Return a validation error for a cross-field check that names ``field`` (dotted path).

    ``field`` is relative to the model that raises it; :mod:`sacflow.config.problems` appends it
    to the error location. ``message`` must not contain braces.
    """
    return PydanticCustomError(FIELD_ERROR, message, {"field": field})


def strictly_increasing(values: tuple[float, ...]) -> bool:
    """Tell whether every value is larger than the one before (profile depths, strains)."""
    return all(b > a for a, b in zip(values, values[1:], strict=False))


def unit_vector(value: tuple[float, float]) -> tuple[float, float]:
    """Return the unit vector of ``value``, a fixed point of the normalisation.

    Dividing by the norm once can change the last bit of a vector that is then divided again
    (about one direction in five): a case read back from its JSON would then have another
    ``case_id``. Normalising until nothing changes (one or two more passes) makes the stored
    direction read back as itself.

    Raises
    ------
    ValueError
        For a zero or non-finite vector.
    """
    norm = math.hypot(*value)
    if not (0.0 < norm < math.inf):
        raise ValueError("must be a non-zero vector (d1, d2)")
    unit = (value[0] / norm, value[1] / norm)
    for _ in range(NORMALISE_PASSES):
        norm = math.hypot(*unit)
        again = (unit[0] / norm, unit[1] / norm)
        if again == unit:
            break
        unit = again
    return unit


def finite_json(value: Any) -> Any:
    """Replace non-finite floats by the strings pydantic accepts back ("Infinity", ...).

    Makes a JSON schema strictly valid JSON (no bare ``Infinity``).
    """
    if isinstance(value, dict):
        return {k: finite_json(v) for k, v in value.items()}
    if isinstance(value, list):
        return [finite_json(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return "NaN" if math.isnan(value) else ("Infinity" if value > 0 else "-Infinity")
    return value
