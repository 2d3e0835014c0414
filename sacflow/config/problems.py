"""Validation problems as one-line messages: the field path, what is wrong, the fix.

Shared by case files (:mod:`sacflow.storage.case_file`) and campaign files
(:mod:`sacflow.campaign`): a
pydantic error becomes ``path: what is wrong[: field meaning][; got value]`` (:func:`problem_line`),
and a list of problems becomes one screen, ``source: invalid case (n problems)`` then one indented
line each (:func:`report`). The type helpers (:func:`strip_annotated`, :func:`is_union`, ...)
follow field annotations through the :class:`~sacflow.config.schema.Case` schema.
"""

from __future__ import annotations

import difflib
import types
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Annotated, Any, Literal, Union, get_args, get_origin

import annotated_types
from pydantic import BaseModel
from pydantic.fields import FieldInfo

from sacflow.config.base import FIELD_ERROR
from sacflow.config.case import Case

__all__ = [
    "MAX_PROBLEMS",
    "drop_consequential",
    "is_model",
    "is_union",
    "item_type",
    "problem_line",
    "report",
    "strip_annotated",
    "suggest",
    "union_members",
]

#: At most this many problems are listed; the rest are counted.
MAX_PROBLEMS = 15
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
_BOUNDS = ("greater_than", "greater_than_equal", "less_than", "less_than_equal")


def report(source: str, problems: Sequence[str], what: str = "case") -> str:
    """Return ``source: invalid <what> (n problems)`` then one indented line per problem.

    At most :data:`MAX_PROBLEMS` lines are listed; the rest are counted.
    """
    lines = [f"  {problem}" for problem in problems[:MAX_PROBLEMS]]
    if len(problems) > MAX_PROBLEMS:
        lines.append(f"  ... and {len(problems) - MAX_PROBLEMS} more")
    count = f"{len(problems)} problem" + ("s" if len(problems) != 1 else "")
    return "\n".join([f"{source}: invalid {what} ({count})", *lines])


# --------------------------------------------------------------------------- schema types
def strip_annotated(tp: Any) -> tuple[Any, list[Any]]:
    """Remove ``Annotated`` and ``| None`` wrappers; return the type and the constraints."""
    constraints: list[Any] = []
    while True:
        if get_origin(tp) is Annotated:
            tp, *meta = get_args(tp)
            for m in meta:
                constraints.extend(m.metadata if isinstance(m, FieldInfo) else [m])
        elif is_union(tp) and len(members := union_members(tp)) == 1:
            tp = members[0]
        else:
            return tp, constraints


def is_union(tp: Any) -> bool:
    """Tell whether ``tp`` is a union (``A | B`` or ``Union[A, B]``)."""
    return get_origin(tp) in (Union, types.UnionType)


def union_members(tp: Any) -> list[Any]:
    """Return the members of a union, ``None`` left out."""
    return [a for a in get_args(tp) if a is not type(None)]


def is_model(tp: Any) -> bool:
    """Tell whether ``tp`` is a pydantic model class."""
    return isinstance(tp, type) and issubclass(tp, BaseModel)


def item_type(tp: Any, index: int) -> Any:
    """Return the type of item ``index`` of a list or tuple type (None when out of range)."""
    args = get_args(tp)
    if get_origin(tp) is list or (len(args) == 2 and args[1] is Ellipsis):
        return args[0] if args else None
    return args[index] if 0 <= index < len(args) else None


def _tags(tp: Any) -> tuple[str, dict[str, type[BaseModel]]] | None:
    """Discriminator name and tag -> model map of a tagged union, else None."""
    members = union_members(tp) if is_union(tp) else []
    if not members or not all(is_model(m) for m in members):
        return None
    common = set.intersection(*(set(m.model_fields) for m in members))
    for name in sorted(common):
        annotations = [m.model_fields[name].annotation for m in members]
        if all(get_origin(a) is Literal and len(get_args(a)) == 1 for a in annotations):
            return name, {get_args(a)[0]: m for a, m in zip(annotations, members, strict=True)}
    return None


# --------------------------------------------------------------------------- error locations
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


def _walk(loc: Sequence[str | int]) -> _Site:
    """Follow a pydantic error location through the :class:`Case` schema."""
    site = _Site(tp=Case)
    for key in loc:
        site.tp, _ = strip_annotated(site.tp)
        tags = _tags(site.tp)
        if tags and key in tags[1]:  # the tag pydantic inserts for a tagged union
            site.tp = tags[1][key]
            continue
        site.path.append(str(key))
        if is_model(site.tp):
            site.owner = site.tp
            site.info = site.tp.model_fields.get(str(key))
            site.tp = site.info.annotation if site.info else None
            site.constraints = list(site.info.metadata) if site.info else []
        elif get_origin(site.tp) in (list, tuple) and isinstance(key, int):
            site.tp, site.constraints = item_type(site.tp, key), []
        else:
            site.tp, site.constraints = None, []
    site.tp, extra = strip_annotated(site.tp)
    site.constraints += extra
    return site


# --------------------------------------------------------------------------- messages
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


def suggest(word: Any, choices: Sequence[str]) -> str:
    """Return ``', did you mean X?'`` for a close match, else the list of allowed choices."""
    match = _close_match(word, choices)
    if match is not None:
        return f", did you mean {match!r}?"
    return "; allowed: " + ", ".join(repr(c) for c in choices)


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def drop_consequential(errors: list[Any]) -> list[Any]:
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


def problem_line(err: Mapping[str, Any]) -> str:
    """Return one line for a :class:`Case` error: ``path: what is wrong[: meaning][; got x]``."""
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
        return f"{site.dotted}.{name}: unknown {name} {tag!r}" + suggest(tag, allowed)
    if kind == "extra_forbidden":
        owner_fields = list(site.owner.model_fields) if site.owner else []
        return f"{site.dotted}: unknown key" + suggest(site.path[-1], owner_fields)
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
    """Say what is wrong, and whether showing the input helps."""
    if kind == "missing":
        if site.path and site.path[-1].isdigit():
            return "missing (too few values)", False
        return "required field missing", False
    if kind in _BOUNDS:
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
