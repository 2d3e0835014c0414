"""Read case files, apply command-line overrides, and turn every mistake into a clear message.

Bad input is rejected where it enters (STYLE 12): every failure here is a
:class:`~sacflow.errors.ConfigError` whose text fits on one screen: the file name, then one line
per problem with the dotted field path (as written in the file, list indices as numbers, e.g.
``load_path.0.to``), what is wrong, what the field means, and the value found.
"""

from __future__ import annotations

import copy
import difflib
import json
import re
import tomllib
import types
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, Literal, Union, get_args, get_origin

import annotated_types
from pydantic import BaseModel, ValidationError
from pydantic.fields import FieldInfo

from sacflow.errors import ConfigError
from sacflow.schema import FIELD_ERROR, Case, Measured

__all__ = ["apply_overrides", "case_from_dict", "format_validation_error", "load_case", "read_file"]

#: At most this many problems are listed; the rest are counted.
MAX_PROBLEMS = 15
#: A list index in a dotted path: ASCII digits only (no sign).
_INDEX = re.compile(r"[0-9]+")
_EXPECTED = {
    "float": "a number",
    "int": "an integer",
    "bool": "true or false",
    "string": "a string",
    "list": "a list",
    "tuple": "a list",
    "dict": "a table",
    "model": "a table",
    "model_attributes": "a table",
    "path": "a file path",
}


# --------------------------------------------------------------------------- public API
def load_case(path: str | Path, overrides: Sequence[str] = ()) -> Case:
    """Read a case file (TOML, or JSON as stored in a run file), apply overrides, validate.

    Parameters
    ----------
    path : str or Path
        Case file. A relative ``surface.path`` is resolved against its folder.
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
    _resolve_surface_path(data, path.parent)
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
        _set_dotted(result, [k.strip() for k in keys], _parse_literal(raw.strip()), item)
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
    _check_surface_file(case, source)
    return case


def format_validation_error(error: ValidationError, source: str) -> str:
    """Return a short message: ``source``, then one line per problem naming the field."""
    errors = _drop_consequential(error.errors(include_url=False))
    return _report(source, [_problem(err) for err in errors])


def _report(source: str, problems: list[str]) -> str:
    """``source: invalid case (n problems)`` then one indented line per problem."""
    lines = [f"  {problem}" for problem in problems[:MAX_PROBLEMS]]
    if len(problems) > MAX_PROBLEMS:
        lines.append(f"  ... and {len(problems) - MAX_PROBLEMS} more")
    count = f"{len(problems)} problem" + ("s" if len(problems) != 1 else "")
    return "\n".join([f"{source}: invalid case ({count})", *lines])


# --------------------------------------------------------------------------- file helpers
def _syntax_message(path: Path, text: str, kind: str, reason: str, line: int | None) -> str:
    message = f"{path}: {kind} syntax error: {reason}"
    lines = text.splitlines()
    if line is not None and 1 <= line <= len(lines):
        message += f"\n  {line} | {lines[line - 1][:100]}"
    return message


def _resolve_surface_path(data: dict[str, Any], folder: Path) -> None:
    surface = data.get("surface")
    if isinstance(surface, dict) and isinstance(surface.get("path"), str):
        try:
            candidate = Path(surface["path"]).expanduser()
            if not candidate.is_absolute():
                surface["path"] = str((folder / candidate).resolve())
        except (OSError, ValueError, RuntimeError):
            pass  # left as written: the file check reports it


def _check_surface_file(case: Case, source: str) -> None:
    surface = case.surface
    if not isinstance(surface, Measured):
        return
    from sacflow.store import read_measured_surface  # xarray only when needed

    try:
        read_measured_surface(surface.path, surface.format, surface.variable)
    except (OSError, ValueError) as exc:
        problem = f"surface.path: cannot read the measured surface {str(surface.path)!r}: {exc}"
        raise ConfigError(_report(source, [problem])) from None


# --------------------------------------------------------------------------- overrides
def _parse_literal(raw: str) -> Any:
    try:
        return tomllib.loads(f"value = {raw}")["value"]
    except tomllib.TOMLDecodeError:
        return raw


def _set_dotted(data: dict[str, Any], keys: list[str], value: Any, item: str) -> None:
    node: Any = data
    for depth, key in enumerate(keys):
        where = ".".join(keys[:depth]) or "the case"
        last = depth == len(keys) - 1
        if isinstance(node, list):
            key_or_index: Any = _list_index(key, len(node), where, item)
            if key_or_index == len(node):
                node.append({})
        elif isinstance(node, dict):
            key_or_index = key
            if not last and key not in node:
                node[key] = {}
        else:
            raise ConfigError(f"--set {item!r}: {where} is a value, not a table or list")
        if last:
            node[key_or_index] = value
        else:
            node = node[key_or_index]


def list_index(key: str) -> int | None:
    """The list index a dotted-path part stands for: ASCII digits only (``0``, ``12``), else None.

    Negative (``-1``), signed (``+1``), fractional (``1.5``) and non-ASCII digits (``²``) are
    not indices: a ``--set`` or sweep key counts items from the start, like the error messages.
    """
    return int(key) if _INDEX.fullmatch(key) else None


def valid_indices(size: int) -> str:
    """The valid indices of a list of ``size`` items, in words (for messages)."""
    if size == 0:
        return "it is empty: use index 0 to add a first item"
    last = "0" if size == 1 else f"0..{size - 1}"
    item = "item" if size == 1 else "items"
    return f"it has {size} {item}: use index {last}, or {size} to add an item at the end"


def _list_index(key: str, size: int, where: str, item: str) -> int:
    """The index ``key`` into the list ``where`` of ``size`` items (appending allowed)."""
    index = list_index(key)
    if index is None:
        raise ConfigError(
            f"--set {item!r}: {key!r} is not a list index ({where} is a list, indexed by whole "
            f"numbers from 0; negative indices are not supported); {valid_indices(size)}"
        )
    if index > size:
        raise ConfigError(
            f"--set {item!r}: index {index} is out of range for {where}; {valid_indices(size)}"
        )
    return index


# --------------------------------------------------------------------------- error messages
@dataclass
class _Site:
    """What the schema says about an error location."""

    path: list[str] = field(default_factory=list)
    owner: type[BaseModel] | None = None  # model holding the last key
    tp: Any = None  # type at the location
    info: FieldInfo | None = None  # last model field crossed
    constraints: list[Any] = field(default_factory=list)

    @property
    def dotted(self) -> str:
        return ".".join(self.path) or "(case)"


def _strip(tp: Any) -> tuple[Any, list[Any]]:
    """Remove ``Annotated`` and ``| None`` wrappers; return the type and the constraints."""
    constraints: list[Any] = []
    while True:
        if get_origin(tp) is Annotated:
            tp, *meta = get_args(tp)
            for m in meta:
                constraints.extend(m.metadata if isinstance(m, FieldInfo) else [m])
        elif _is_union(tp) and len(members := _members(tp)) == 1:
            tp = members[0]
        else:
            return tp, constraints


def _is_union(tp: Any) -> bool:
    return get_origin(tp) in (Union, types.UnionType)


def _members(tp: Any) -> list[Any]:
    return [a for a in get_args(tp) if a is not type(None)]


def _is_model(tp: Any) -> bool:
    return isinstance(tp, type) and issubclass(tp, BaseModel)


def _tags(tp: Any) -> tuple[str, dict[str, type[BaseModel]]] | None:
    """Discriminator name and tag -> model map of a tagged union, else None."""
    members = _members(tp) if _is_union(tp) else []
    if not members or not all(_is_model(m) for m in members):
        return None
    common = set.intersection(*(set(m.model_fields) for m in members))
    for name in sorted(common):
        annotations = [m.model_fields[name].annotation for m in members]
        if all(get_origin(a) is Literal and len(get_args(a)) == 1 for a in annotations):
            return name, {get_args(a)[0]: m for a, m in zip(annotations, members, strict=True)}
    return None


def _item_type(tp: Any, index: int) -> Any:
    args = get_args(tp)
    if get_origin(tp) is list or (len(args) == 2 and args[1] is Ellipsis):
        return args[0] if args else None
    return args[index] if 0 <= index < len(args) else None


def _walk(loc: Sequence[str | int]) -> _Site:
    """Follow a pydantic error location through the :class:`Case` schema."""
    site = _Site(tp=Case)
    for key in loc:
        site.tp, _ = _strip(site.tp)
        tags = _tags(site.tp)
        if tags and key in tags[1]:  # the tag pydantic inserts for a tagged union
            site.tp = tags[1][key]
            continue
        site.path.append(str(key))
        if _is_model(site.tp):
            site.owner = site.tp
            site.info = site.tp.model_fields.get(key)
            site.tp = site.info.annotation if site.info else None
            site.constraints = list(site.info.metadata) if site.info else []
        elif get_origin(site.tp) in (list, tuple) and isinstance(key, int):
            site.tp, site.constraints = _item_type(site.tp, key), []
        else:
            site.tp, site.constraints = None, []
    site.tp, extra = _strip(site.tp)
    site.constraints += extra
    return site


def _interval(constraints: list[Any], ctx: Mapping[str, Any]) -> str:
    """'in (-1, 0.5)', '> 0', '>= 8' ... from the field constraints (or the error context)."""
    bounds: dict[str, Any] = dict(ctx)
    for c in constraints:
        for name in ("gt", "ge", "lt", "le"):
            if isinstance(c, getattr(annotated_types, name.capitalize())):
                bounds[name] = getattr(c, name)
    low = next(((b, bounds[k]) for k, b in (("gt", "("), ("ge", "[")) if k in bounds), None)
    high = next(((b, bounds[k]) for k, b in (("lt", ")"), ("le", "]")) if k in bounds), None)
    if low and high:
        return f"in {low[0]}{low[1]:g}, {high[1]:g}{high[0]}"
    if low:
        return f"{'>' if low[0] == '(' else '>='} {low[1]:g}"
    if high:
        return f"{'<' if high[0] == ')' else '<='} {high[1]:g}"
    return "in range"


def _close_match(word: Any, choices: Sequence[str]) -> str | None:
    lowered = {c.lower(): c for c in choices}
    match = difflib.get_close_matches(str(word).lower(), list(lowered), n=1, cutoff=0.6)
    return lowered[match[0]] if match else None


def _suggest(word: Any, choices: Sequence[str]) -> str:
    """', did you mean X?' for a close match, else the list of allowed choices."""
    match = _close_match(word, choices)
    if match is not None:
        return f", did you mean {match!r}?"
    return "; allowed: " + ", ".join(repr(c) for c in choices)


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _drop_consequential(errors: list[Any]) -> list[Any]:
    """Drop pydantic's 'too short' on a sequence whose items already failed."""
    locs = [tuple(e["loc"]) for e in errors]
    return [
        e
        for e in errors
        if not (
            e["type"] == "too_short"
            and any(len(o) > len(e["loc"]) and o[: len(e["loc"])] == tuple(e["loc"]) for o in locs)
        )
    ]


def _problem(err: Mapping[str, Any]) -> str:
    """One line: ``path: what is wrong[: field meaning][; got value]``."""
    kind, ctx = err["type"], err.get("ctx") or {}
    site = _walk(err["loc"])
    if kind == FIELD_ERROR:
        return f"{'.'.join([*site.path, ctx['field']])}: {err['msg']}"
    if kind in ("union_tag_invalid", "union_tag_not_found"):
        tags = _tags(site.tp)
        name, allowed = (tags[0], list(tags[1])) if tags else ("kind", [])
        if kind == "union_tag_not_found":
            return f"{site.dotted}.{name}: required field missing; one of " + ", ".join(allowed)
        tag = ctx["tag"]
        return f"{site.dotted}.{name}: unknown {name} {tag!r}" + _suggest(tag, allowed)
    if kind == "extra_forbidden":
        owner_fields = list(site.owner.model_fields) if site.owner else []
        return f"{site.dotted}: unknown key" + _suggest(site.path[-1], owner_fields)
    what, show_input = _what(kind, ctx, err, site)
    line = f"{site.dotted}: {what}"
    if site.info is not None and site.info.description and not what.endswith("?"):
        line += f": {site.info.description}"
    if show_input:
        line += f"; got {_short(err['input'])}"
    return line


def _what(
    kind: str, ctx: Mapping[str, Any], err: Mapping[str, Any], site: _Site
) -> tuple[str, bool]:
    """What is wrong, and whether showing the input helps."""
    if kind == "missing":
        if site.path and site.path[-1].isdigit():
            return "missing (too few values)", False
        return "required field missing", False
    if kind in ("greater_than", "greater_than_equal", "less_than", "less_than_equal"):
        return f"must be {_interval(site.constraints, ctx)}", True
    if kind == "finite_number":
        return "must be a finite number", True
    if kind == "literal_error":
        allowed = [str(a) for a in get_args(site.tp)] if get_origin(site.tp) is Literal else []
        match = _close_match(err["input"], allowed)
        if match is not None:
            return f"not an allowed value, did you mean {match!r}?", True
        return "must be one of " + ", ".join(repr(a) for a in allowed), True
    if kind == "too_short":
        return f"needs at least {ctx.get('min_length')} item(s)", True
    if kind == "too_long":
        return f"takes at most {ctx.get('max_length')} item(s)", True
    if kind == "string_pattern_mismatch":
        return f"must match {ctx.get('pattern')}", True
    if kind in ("value_error", "assertion_error"):
        return str(ctx.get("error", err["msg"])), True
    prefix = kind.rsplit("_", 1)[0] if kind.endswith(("_type", "_parsing")) else kind
    if kind == "int_from_float" or prefix in _EXPECTED:
        return f"expected {_EXPECTED.get(prefix, 'an integer')}", True
    return str(err["msg"]), True
