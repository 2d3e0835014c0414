"""Read case files, apply command-line overrides, and turn every mistake into a clear message.

Bad input is rejected where it enters (STYLE 12): every failure here is a
:class:`~sacflow.errors.ConfigError` whose text fits on one screen: the file name, then one line
per problem with the dotted field path (as written in the file, list indices as numbers, e.g.
``load_path.0.to``), what is wrong, what the field means, and the value found. The lines are
built by :mod:`sacflow.config.problems`; dotted ``--set`` paths are followed by
:mod:`sacflow.config.dotted`.
"""

from __future__ import annotations

import copy
import json
import re
import tomllib
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from sacflow.config.dotted import set_dotted
from sacflow.config.problems import drop_consequential, problem_line, report
from sacflow.config.schema import Case, Measured
from sacflow.errors import ConfigError

__all__ = [
    "apply_overrides",
    "case_from_dict",
    "check_surface_file",
    "format_validation_error",
    "load_case",
    "read_file",
    "resolve_surface_path",
]

# --------------------------------------------------------------------------- public API
def load_case(path: str | Path, overrides: Sequence[str] = ()) -> Case:
    """Read a case file (TOML, or JSON as stored in a run file), apply overrides, validate.

    Parameters
    ----------
    path : str or Path
        Case file. A relative ``surface.path`` or ``initial_state.run`` is resolved against
        its folder.
    overrides : sequence of str
        ``dotted.key=value`` items applied in order (see :func:`apply_overrides`).

    Raises
    ------
    ConfigError
        On any problem: unreadable file, syntax error, bad override, invalid case.
    """
    path = Path(path)
    data = read_file(path)
    try:
        data = apply_overrides(data, overrides)
    except ConfigError as exc:
        raise ConfigError(f"{path}: {exc}") from None
    resolve_surface_path(data, path.parent)
    return case_from_dict(data, source=str(path))


def read_file(path: Path) -> dict[str, Any]:
    """Parse a TOML (or ``.json``) file into a dict; errors name the line and column."""
    try:
        text = path.read_bytes().decode("utf-8")
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read the file ({exc.strerror or exc})") from None
    except UnicodeDecodeError:
        raise ConfigError(f"{path}: not a UTF-8 text file") from None
    try:
        if path.suffix.lower() == ".json":
            data = json.loads(text)
        else:
            data = tomllib.loads(text)
    except json.JSONDecodeError as exc:
        raise ConfigError(_syntax_message(path, text, "JSON", exc.msg, exc.lineno)) from None
    except tomllib.TOMLDecodeError as exc:
        match = re.search(r"line (\d+)", str(exc))
        line = int(match.group(1)) if match else None
        raise ConfigError(_syntax_message(path, text, "TOML", str(exc), line)) from None
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: the file must hold a table of case fields")
    return data


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


def case_from_dict(data: Mapping[str, Any], source: str = "<dict>") -> Case:
    """Validate ``data`` into a :class:`Case`; a measured surface file must be readable.

    Raises
    ------
    ConfigError
        With one line per problem (see :func:`format_validation_error`).
    """
    try:
        case = Case.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(format_validation_error(exc, source)) from None
    check_surface_file(case, source)
    check_initial_state_file(case, source)
    return case


def format_validation_error(error: ValidationError, source: str) -> str:
    """Return a short message: ``source``, then one line per problem naming the field."""
    errors = drop_consequential(error.errors(include_url=False))
    return report(source, [problem_line(err) for err in errors])


# --------------------------------------------------------------------------- file helpers
def _syntax_message(path: Path, text: str, kind: str, reason: str, line: int | None) -> str:
    message = f"{path}: {kind} syntax error: {reason}"
    lines = text.splitlines()
    if line is not None and 1 <= line <= len(lines):
        message += f"\n  {line} | {lines[line - 1][:100]}"
    return message


def resolve_surface_path(data: dict[str, Any], folder: Path) -> None:
    """Make a relative ``surface.path`` or ``initial_state.run`` absolute against ``folder``.

    In place.

    A path that cannot be resolved is left as written: :func:`check_surface_file` reports it.
    """
    for table, key in (("surface", "path"), ("initial_state", "run")):
        entry = data.get(table)
        if isinstance(entry, dict) and isinstance(entry.get(key), str):
            try:
                candidate = Path(entry[key]).expanduser()
                if not candidate.is_absolute():
                    entry[key] = str((folder / candidate).resolve())
            except (OSError, ValueError, RuntimeError):
                pass  # left as written: the file check reports it


def check_surface_file(case: Case, source: str) -> None:
    """Check that a measured surface of ``case`` can be read.

    Raises
    ------
    ConfigError
        ``source: invalid case (1 problem)`` naming ``surface.path`` and the reason.
    """
    surface = case.surface
    if not isinstance(surface, Measured):
        return
    from sacflow.storage.surface_file import read_measured_surface  # xarray only when needed

    try:
        read_measured_surface(surface.path, surface.format, surface.variable)
    except (OSError, ValueError) as exc:
        problem = f"surface.path: cannot read the measured surface {str(surface.path)!r}: {exc}"
        raise ConfigError(report(source, [problem])) from None


def check_initial_state_file(case: Case, source: str) -> None:
    """Check that the stored run a chained case starts from can be read at its step.

    Raises
    ------
    ConfigError
        ``source: invalid case (1 problem)`` naming ``initial_state`` and the reason.
    """
    if case.initial_state is None:
        return
    from sacflow.mechanics.initial_state import InitialStateError
    from sacflow.storage.initial_state_file import check_initial_state  # netCDF only when needed

    try:
        check_initial_state(case)
    except InitialStateError as exc:
        raise ConfigError(report(source, [str(exc)])) from None


# --------------------------------------------------------------------------- overrides
def _parse_literal(raw: str) -> Any:
    try:
        return tomllib.loads(f"value = {raw}")["value"]
    except tomllib.TOMLDecodeError:
        return raw
