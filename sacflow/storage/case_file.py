"""Read case files and the files a case names; turn every mistake into a clear message.

Bad input is rejected where it enters: every failure here is a
:class:`~sacflow.errors.ConfigError` whose text fits on one screen: the file name, then one line
per problem with the dotted field path (as written in the file, list indices as numbers, e.g.
``load_path.0.to``), what is wrong, what the field means, and the value found. This module reads
(the case file, its measured surface, the run a chained case starts from, relative paths
resolved against the case file's folder); overrides, validation and the messages are the
configuration layer's (:mod:`sacflow.config.parsing`). A case leaves here with the fingerprints
of the files it names, from which its ``case_id`` follows (:mod:`sacflow.storage.fingerprints`).
"""

from __future__ import annotations

import json
import re
import tomllib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from sacflow.config.parsing import apply_overrides, validate_case
from sacflow.config.problems import report
from sacflow.config.schema import Case, Measured
from sacflow.errors import ConfigError
from sacflow.storage.fingerprints import identified

__all__ = [
    "case_from_dict",
    "check_case_files",
    "check_initial_state_file",
    "check_surface_file",
    "load_case",
    "read_file",
    "resolve_surface_path",
]


# --------------------------------------------------------------------------- public API
def load_case(path: str | Path, overrides: Sequence[str] = (), check_files: bool = True) -> Case:
    """Read a case file (TOML, or JSON as stored in a run file), apply overrides, validate.

    Parameters
    ----------
    path : str or Path
        Case file. A relative ``surface.path`` or ``initial_state.run`` is resolved against
        its folder.
    overrides : sequence of str
        ``dotted.key=value`` items applied in order
        (:func:`sacflow.config.parsing.apply_overrides`).
    check_files : bool
        Check that the files the case names can be read (default). False validates the case
        alone, before those files exist (a pipeline checking a chained case before the run it
        starts from): the case then has no file fingerprints, and no id until they can be read.

    Raises
    ------
    ConfigError
        On any problem: unreadable file, syntax error, bad override, invalid case.
    """
    path = Path(path)
    data = read_file(path)
    if "sweep" in data and "base" in data:
        raise ConfigError(
            f"{path}: a campaign file ([base] and [[sweep]]), not a case file: run it with "
            f"`sacflow campaign {path} --out DIR` (sacflow.campaign.run_campaign in Python)"
        )
    try:
        data = apply_overrides(data, overrides)
    except ConfigError as exc:
        raise ConfigError(f"{path}: {exc}") from None
    resolve_surface_path(data, path.parent)
    if not check_files:
        return validate_case(data, str(path))
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


def case_from_dict(data: Mapping[str, Any], source: str = "<dict>") -> Case:
    """Validate ``data`` into a :class:`Case` whose files (surface, source run) can be read.

    Returns the case with the fingerprints of those files (its ``case_id`` follows from them).

    Raises
    ------
    ConfigError
        With one line per problem (:func:`sacflow.config.parsing.validate_case`), or naming
        the file that cannot be read.
    """
    case = validate_case(data, source)
    check_case_files(case, source)
    return identified(case)


def check_case_files(case: Case, source: str) -> None:
    """Check that the files ``case`` names can be read (surface, source run, cells files).

    The measured surface, the run a chained case starts from, the cells files of its
    inhomogeneities (their points in the cuboid box).

    Raises
    ------
    ConfigError
        ``source: invalid case (1 problem)`` naming the file and the reason.
    """
    check_surface_file(case, source)
    check_initial_state_file(case, source)
    if any(item.cells is not None for item in case.body.inhomogeneity):
        from sacflow.storage.inclusion_cells_file import check_inclusion_cells

        check_inclusion_cells(case, source)


# --------------------------------------------------------------------------- file helpers
def _syntax_message(path: Path, text: str, kind: str, reason: str, line: int | None) -> str:
    message = f"{path}: {kind} syntax error: {reason}"
    lines = text.splitlines()
    if line is not None and 1 <= line <= len(lines):
        message += f"\n  {line} | {lines[line - 1][:100]}"
    return message


def resolve_surface_path(data: dict[str, Any], folder: Path) -> None:
    """Make the relative file paths of a case absolute against ``folder``, in place.

    ``surface.path``, ``initial_state.run`` and each ``body.inhomogeneity.<i>.cells``.

    A path that cannot be resolved is left as written: :func:`check_surface_file` reports it.
    """
    body = data.get("body")
    items = body.get("inhomogeneity") if isinstance(body, dict) else None
    entries = [(data.get("surface"), "path"), (data.get("initial_state"), "run")]
    entries += [(item, "cells") for item in (items if isinstance(items, list) else ())]
    for entry, key in entries:
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
