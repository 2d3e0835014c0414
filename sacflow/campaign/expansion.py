"""Campaign file -> cases: reading, sweep expansion, case names, and the campaign's messages.

A campaign file (TOML) names a base case (inline ``[base]`` table or ``base = "case.toml"``,
relative to the campaign file) and ``[[sweep]]`` blocks of dotted case paths (the ``--set``
syntax) with lists of values. A ``product`` block takes every combination of its lists, a
``zip`` block takes them side by side; several blocks combine as a product of blocks. Each case
is named ``<campaign>-<tags>`` from its parameters (``smoke-to0.19-radius0.0001``) and
identified by its :attr:`~sacflow.config.schema.Case.case_id`.
"""

from __future__ import annotations

import copy
import hashlib
import json
import re
from collections import Counter
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, get_origin

from pydantic import ValidationError

from sacflow.config.dotted import list_index, set_dotted, valid_indices
from sacflow.config.parsing import apply_overrides
from sacflow.config.problems import (
    drop_consequential,
    is_model,
    is_union,
    item_type,
    problem_line,
    report,
    strip_annotated,
    suggest,
    union_members,
)
from sacflow.config.schema import FIELD_ERROR, Campaign, Case, Sweep
from sacflow.errors import ConfigError
from sacflow.storage.case_file import check_case_files, read_file, resolve_surface_path
from sacflow.storage.fingerprints import identified

__all__ = [
    "MAX_NAME",
    "CampaignCase",
    "campaign_rows",
    "case_names",
    "expand_campaign",
    "label",
    "load_campaign",
]

#: Case names longer than this end in a digest of the parameters instead of all the tags.
MAX_NAME = 120


# --------------------------------------------------------------------------- loading
def load_campaign(path: str | Path, overrides: Sequence[str] = ()) -> Campaign:
    """Read and check a campaign file; ``overrides`` (``dotted.key=value``) apply to the base.

    The returned campaign holds the base case as a table (a base file is read, relative paths
    are made absolute), and every expanded case has been validated.

    Raises
    ------
    ConfigError
        One screen naming each problem: campaign fields, the base file, sweep paths, or the
        expanded cases (``case 3 (load_path.0.to=-1): load_path.0.to: must be > 0 ...``).
    """
    path = Path(path)
    source = str(path)
    data = read_file(path)
    if "base" not in data and "sweep" not in data and {"body", "grid", "load_path"} & set(data):
        raise ConfigError(
            f"{path}: a case file ([body], [grid], [[load_path]]), not a campaign file: run it "
            f"with `sacflow run {path} --out DIR`, or make it the base of a campaign "
            f"(base = \"{path.name}\" and [[sweep]] blocks: docs/campaigns.md)"
        )
    try:
        campaign = Campaign.model_validate(data)
    except ValidationError as exc:
        errors = drop_consequential(exc.errors(include_url=False))
        raise ConfigError(_report(source, [_campaign_problem(e) for e in errors])) from None
    base = _read_base(campaign.base, path.parent, source)
    try:
        base = apply_overrides(base, overrides)
    except ConfigError as exc:
        raise ConfigError(f"{path}: {exc}") from None
    sweep = tuple(_absolute_surface_paths(block, path.parent) for block in campaign.sweep)
    campaign = campaign.model_copy(update={"base": base, "sweep": sweep})
    expand_campaign(campaign, source)
    return campaign


def _read_base(base: str | dict[str, Any], folder: Path, source: str) -> dict[str, Any]:
    """Return the base case as a table, a measured surface path made absolute."""
    if isinstance(base, dict):
        data = copy.deepcopy(base)
        resolve_surface_path(data, folder)
        return data
    file = (folder / Path(base).expanduser()).resolve()
    if not file.is_file():
        problem = (
            f"base: case file {base!r} not found (looked for {file}); "
            "give a path relative to the campaign file"
        )
        raise ConfigError(_report(source, [problem]))
    try:
        data = read_file(file)
    except ConfigError as exc:
        raise ConfigError(_report(source, [f"base: {exc}"])) from None
    resolve_surface_path(data, file.parent)
    return data


#: Swept keys naming files, resolved against the campaign file: (table, key in the table).
_FILE_KEYS = (("surface", "path"), ("initial_state", "run"))
#: A swept cells file of an inhomogeneity, also resolved against the campaign file.
_CELLS_KEY = re.compile(r"^body\.inhomogeneity\.\d+\.cells$")


def _absolute_surface_paths(block: Sweep, folder: Path) -> Sweep:
    """Make swept measured-surface, source-run and cells files relative to the campaign file."""
    parameters = dict(block.parameters)
    for table, key in _FILE_KEYS:
        for swept in (f"{table}.{key}", table):
            if swept not in parameters:
                continue
            values = []
            for value in parameters[swept]:
                whole = swept == table
                data = {table: value if whole else {key: value}}
                resolve_surface_path(data, folder)
                values.append(data[table] if whole else data[table][key])
            parameters[swept] = tuple(values)
    for swept in [key for key in parameters if _CELLS_KEY.match(key)]:
        values = []
        for value in parameters[swept]:
            data = {"body": {"inhomogeneity": [{"cells": value}]}}
            resolve_surface_path(data, folder)
            values.append(data["body"]["inhomogeneity"][0]["cells"])
        parameters[swept] = tuple(values)
    return block.model_copy(update={"parameters": parameters})


# --------------------------------------------------------------------------- expansion
@dataclass(frozen=True)
class CampaignCase:
    """One expanded case: its 1-based position, the swept values and the validated case."""

    index: int
    parameters: dict[str, Any]
    case: Case

    @property
    def name(self) -> str:
        """Case name (also the run file name without ``.nc``)."""
        return self.case.name

    @property
    def case_id(self) -> str:
        """Hash of the case (see :attr:`sacflow.config.schema.Case.case_id`)."""
        return self.case.case_id

    def label(self) -> str:
        """Return ``path=value, ...`` of the swept parameters."""
        return label(self.parameters)


def expand_campaign(campaign: Campaign, source: str = "<campaign>") -> list[CampaignCase]:
    """Expand the sweep blocks over the base case and validate every case.

    A base given as a path is read relative to the working directory (:func:`load_campaign`
    reads it relative to the campaign file).

    Raises
    ------
    ConfigError
        Unknown sweep paths, duplicate parameter sets, or invalid cases; problems shared by
        every case are reported once, as ``base (all cases)``.
    """
    base = _read_base(campaign.base, Path.cwd(), source)
    problems = [
        f'sweep.{i}.parameters."{key}": {problem}'
        for i, block in enumerate(campaign.sweep)
        for key in block.parameters
        if (problem := _path_problem(key)) is not None
    ]
    if problems:
        raise ConfigError(_report(source, problems))
    rows = campaign_rows(campaign)
    problems = _duplicates(rows)
    names = case_names(campaign.name, rows)
    cases, failures = [], []
    for index, (row, name) in enumerate(zip(rows, names, strict=True), start=1):
        case_or_problems = _build_case(base, row, name, source)
        if isinstance(case_or_problems, Case):
            cases.append(CampaignCase(index, row, case_or_problems))
        else:
            failures.append((index, row, case_or_problems))
    problems += _case_problems(failures, len(rows))
    if problems:
        raise ConfigError(_report(source, problems))
    return cases


def campaign_rows(campaign: Campaign) -> list[dict[str, Any]]:
    """Return the parameter sets of every case: the product of the blocks' rows, in order."""
    rows: list[dict[str, Any]] = [{}]
    for block in campaign.sweep:
        keys, lists = list(block.parameters), list(block.parameters.values())
        if block.mode == "zip":
            combos = [dict(zip(keys, values, strict=True)) for values in zip(*lists, strict=True)]
        else:
            combos = [{}]
            for key, values in zip(keys, lists, strict=True):
                combos = [{**c, key: v} for c in combos for v in values]
        rows = [{**row, **combo} for row in rows for combo in combos]
    return rows


def _build_case(
    base: Mapping[str, Any], row: Mapping[str, Any], name: str, source: str
) -> Case | list[str]:
    """Return the validated case of one row, its files read (its id fixed), or its problems."""
    data = copy.deepcopy(dict(base))
    for key, value in row.items():
        try:
            set_dotted(data, key.split("."), copy.deepcopy(value), key)
        except ConfigError as exc:
            return [f"{key}: {str(exc).split(': ', 1)[-1]}"]
    data["name"] = name
    try:
        case = Case.model_validate(data)
    except ValidationError as exc:
        return [problem_line(e) for e in drop_consequential(exc.errors(include_url=False))]
    try:
        check_case_files(case, source)
    except ConfigError as exc:
        return [line.strip() for line in str(exc).splitlines()[1:]]
    return identified(case)


def _case_problems(failures: list[tuple[int, dict[str, Any], list[str]]], total: int) -> list[str]:
    """Return one line per problem; those of every case once, as ``base (all cases)``."""
    if not failures:
        return []
    common = set(failures[0][2]) if len(failures) == total and total > 1 else set()
    for _, _, problems in failures[1:]:
        common &= set(problems)
    lines = [f"base (all cases): {p}" for p in failures[0][2] if p in common]
    for index, row, problems in failures:
        lines += [f"case {index} ({label(row)}): {p}" for p in problems if p not in common]
    return lines


def _duplicates(rows: list[dict[str, Any]]) -> list[str]:
    first: dict[str, int] = {}
    problems = []
    for index, row in enumerate(rows, start=1):
        key = json.dumps(row, sort_keys=True, default=str)
        if key in first:
            problems.append(
                f"sweep: cases {first[key]} and {index} have the same parameters "
                f"({label(row)}); remove the repeated value"
            )
        first.setdefault(key, index)
    return problems


# --------------------------------------------------------------------------- sweep paths
def _path_problem(key: str) -> str | None:
    """Say why the dotted ``key`` is not a field path of a :class:`Case` (None when it is)."""
    keys = key.split(".")
    options: list[Any] = [Case]
    for depth, part in enumerate(keys):
        where = ".".join(keys[:depth]) or "the case"
        found: list[Any] = []
        fields: list[str] = []
        sizes: list[int | None] = []
        for tp in _concrete(options):
            if is_model(tp):
                fields += [f for f in tp.model_fields if f not in fields]
                if part in tp.model_fields:
                    found.append(tp.model_fields[part].annotation)
            elif get_origin(tp) is dict:
                return None  # free-form table: anything goes below
            elif get_origin(tp) in (list, tuple):
                variable = get_origin(tp) is list or tp.__args__[-1] is Ellipsis
                sizes.append(None if variable else len(tp.__args__))
                index = list_index(part)
                if index is not None and (item := item_type(tp, index)) is not None:
                    found.append(item)
        if found:
            options = found
        elif fields:
            return f"{where} has no field {part!r}" + suggest(part, fields)
        elif sizes:
            fixed = [n for n in sizes if n is not None]
            if list_index(part) is not None and fixed:
                return f"index {part} is out of range for {where}; {valid_indices(max(fixed))}"
            return (
                f"{part!r} is not a list index ({where} is a list, indexed by whole numbers "
                f"from 0; negative indices are not supported); use e.g. {where}.0"
            )
        else:
            return f"{where} is a value, not a table; remove .{'.'.join(keys[depth:])}"
    return None


def _concrete(options: list[Any]) -> Iterator[Any]:
    """Yield the concrete types behind annotations, optionals and unions."""
    for tp in options:
        tp, _ = strip_annotated(tp)
        if is_union(tp):
            yield from _concrete(union_members(tp))
        else:
            yield tp


# --------------------------------------------------------------------------- names
def case_names(campaign: str, rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """Name each row ``<campaign>-<tag>-<tag>...``: deterministic, file-name safe and unique."""
    keys = _short_keys(list(rows[0]) if rows else [])
    names = []
    for row in rows:
        name = "-".join([campaign, *(keys[k] + _tag_value(v) for k, v in row.items())])
        if len(name) > MAX_NAME:
            name = f"{name[: MAX_NAME - 13]}-{_digest(row)[:12]}"
        names.append(name)
    counts = Counter(names)  # values that differ but read the same once made file-name safe
    return [
        name if counts[name] == 1 else f"{name}-{_digest(row)[:8]}"
        for name, row in zip(names, rows, strict=True)
    ]


def _short_keys(keys: list[str]) -> dict[str, str]:
    """Return the shortest distinct dotted suffix of each key, never starting with an index."""
    split = {key: key.split(".") for key in keys}
    short = {}
    for key, parts in split.items():
        for n in range(1, len(parts) + 1):
            suffix = parts[-n:]
            clash = any(o != key and op[-n:] == suffix for o, op in split.items())
            if not clash and not suffix[0].isdigit():
                break
        short[key] = ".".join(suffix)
    return short


def _tag_value(value: Any) -> str:
    """Write a value as a short, file-name safe tag (tables: a digest)."""
    if isinstance(value, bool):
        text = str(value).lower()
    elif isinstance(value, float):
        text = re.sub(r"e([+-]?)0*(\d)", lambda m: "e" + m[1].strip("+") + m[2], repr(value))
        text = text.removesuffix(".0")
    elif isinstance(value, int | str):
        text = str(value)
    elif isinstance(value, list | tuple) and all(isinstance(v, int | float | str) for v in value):
        text = "x".join(_tag_value(v) for v in value)
    else:
        text = "h" + _digest(value)[:8]
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text) or "_"


def _digest(value: Any) -> str:
    return hashlib.sha256(json.dumps(value, sort_keys=True, default=str).encode()).hexdigest()


def label(row: Mapping[str, Any]) -> str:
    """Return ``path=value, ...`` of a parameter set, long values cut."""
    return ", ".join(f"{k}={_show(v)}" for k, v in row.items())


def _show(value: Any) -> str:
    text = json.dumps(value, default=str) if isinstance(value, str | dict) else repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


# --------------------------------------------------------------------------- error messages
def _report(source: str, problems: list[str]) -> str:
    """Return ``source: invalid campaign (n problems)`` then one indented line per problem."""
    return report(source, list(dict.fromkeys(problems)), "campaign")  # a union error: per member


def _campaign_problem(err: Mapping[str, Any]) -> str:
    """Return one line for a :class:`Campaign` validation error: the field, the problem, the fix."""
    kind, ctx, loc = err["type"], err.get("ctx") or {}, list(err["loc"])
    if loc[:1] == ["base"]:
        loc = ["base"]  # drop the union member pydantic appends
    owner = Sweep if loc[:1] == ["sweep"] and len(loc) >= 3 else Campaign
    path = ".".join(f'"{k}"' if "." in str(k) else str(k) for k in loc)
    info = owner.model_fields.get(str(loc[-1])) if loc else None
    meaning = f": {info.description}" if info is not None and info.description else ""
    got = f"; got {_show(err.get('input'))}"
    if kind == FIELD_ERROR:
        return f"{'.'.join(p for p in (path, ctx['field']) if p)}: {err['msg']}"
    if kind == "extra_forbidden":
        return f"{path}: unknown key" + suggest(loc[-1], list(owner.model_fields))
    if kind == "missing":
        return f"{path}: required field missing{meaning}"
    if loc == ["base"]:
        return f"{path}: expected a case file path or an inline [base] table{got}"
    if kind == "too_short":
        what = {"sweep": "one [[sweep]] block", "parameters": "one parameter"}.get(
            str(loc[-1]), "one value"
        )
        return f"{path}: needs at least {what}{meaning}"
    fixed = {
        "literal_error": f"must be {ctx.get('expected')}",
        "string_pattern_mismatch": (
            "must start with a letter or digit, then letters, digits, -, _, ."
        ),
        "tuple_type": "expected a list of values, e.g. [32, 48]",
        "list_type": "expected a list of values, e.g. [32, 48]",
        "dict_type": f"expected a table{meaning}",
        "model_type": f"expected a table{meaning}",
    }
    return f"{path}: {fixed.get(kind, err['msg'])}{got}"
