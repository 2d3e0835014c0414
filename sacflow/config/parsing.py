"""Case data -> :class:`~sacflow.config.case.Case`: overrides, validation, one-screen messages.

The pure half of reading a case (reads no file): ``--set dotted.key=value`` overrides on the
case's table (paths followed by :mod:`sacflow.config.dotted`), validation into a case, and the
message of a failed validation: the source, then one line per problem with the dotted field
path (list indices as numbers, e.g. ``load_path.0.to``), what is wrong, what the field means
and the value found (:mod:`sacflow.config.problems`). :mod:`sacflow.storage.case_file` reads the
files and calls these.
"""

from __future__ import annotations

import copy
import tomllib
from collections.abc import Iterable, Mapping
from typing import Any

from pydantic import ValidationError

from sacflow.config.case import Case
from sacflow.config.dotted import set_dotted
from sacflow.config.problems import drop_consequential, problem_line, report
from sacflow.errors import ConfigError

__all__ = ["apply_overrides", "format_validation_error", "validate_case"]


def apply_overrides(data: Mapping[str, Any], overrides: Iterable[str]) -> dict[str, Any]:
    """Return a copy of ``data`` with ``dotted.key=value`` overrides applied.

    The value is parsed as a TOML literal (``64``, ``0.19``, ``"linear"``, ``[1e-5, 1e-5]``,
    ``inf``); anything else is kept as a bare string. Whole-number keys index lists from 0
    (``load_path.0.to=0.19``; the index just past the end appends); negative or non-integer
    indices are rejected. Missing intermediate tables are created.
    """
    result = copy.deepcopy(dict(data))
    for item in overrides:
        key, sep, raw = item.partition("=")
        keys = key.strip().split(".")
        if not sep or not all(k.strip() for k in keys):
            raise ConfigError(f"--set {item!r}: expected dotted.key=value, e.g. grid.nx=64")
        set_dotted(result, [k.strip() for k in keys], _parse_literal(raw.strip()), item)
    return result


def validate_case(data: Mapping[str, Any], source: str = "<dict>") -> Case:
    """Validate ``data`` into a :class:`Case` (the files it names are not read).

    :func:`sacflow.storage.case_file.case_from_dict` also checks those files.

    Raises
    ------
    ConfigError
        With one line per problem (see :func:`format_validation_error`).
    """
    try:
        return Case.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(format_validation_error(exc, source)) from None


def format_validation_error(error: ValidationError, source: str) -> str:
    """Return a short message: ``source``, then one line per problem naming the field."""
    errors = drop_consequential(error.errors(include_url=False))
    return report(source, [problem_line(err) for err in errors])


def _parse_literal(raw: str) -> Any:
    """Return ``raw`` read as a TOML value (``64``, ``"a"``, ``[1, 2]``), else ``raw`` itself."""
    try:
        return tomllib.loads(f"value = {raw}")["value"]
    except tomllib.TOMLDecodeError:
        return raw
