"""Campaigns: a base case swept over parameters, one dask task and one run file per case.

A campaign file (TOML) names a base case (inline ``[base]`` table or ``base = "case.toml"``,
relative to the campaign file) and ``[[sweep]]`` blocks of dotted case paths (the ``--set``
syntax) with lists of values. A ``product`` block takes every combination of its lists, a
``zip`` block takes them side by side; several blocks combine as a product of blocks. Each case
is named ``<campaign>-<tags>`` from its parameters (``smoke-to0.19-radius0.0001``) and
identified by its :attr:`~sacflow.schema.Case.case_id`.

Running (DESIGN §1, STYLE 10): one dask task per case, each writing ``<out>/<case name>.nc``
through :func:`sacflow.runner.run_case` -- no shared file, no lock; the parent only gathers the
outcomes into ``<out>/<campaign>.manifest.json`` (rewritten atomically after every case).
Finished cases are skipped on a re-run, interrupted ones resume after their stored steps, and a
failing case is recorded while the others go on.
"""

from __future__ import annotations

import copy
import hashlib
import importlib.util
import json
import logging
import os
import re
import sys
import time
import traceback
from collections import Counter
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager, nullcontext
from dataclasses import asdict, dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, Literal, get_origin

from pydantic import ValidationError
from tqdm.auto import tqdm

from sacflow.config import (
    MAX_PROBLEMS,
    _check_surface_file,
    _drop_consequential,
    _is_model,
    _is_union,
    _item_type,
    _members,
    _problem,
    _resolve_surface_path,
    _set_dotted,
    _strip,
    _suggest,
    apply_overrides,
    list_index,
    read_file,
    valid_indices,
)
from sacflow.errors import ConfigError, SacflowError
from sacflow.malloc import MALLOC_ENV
from sacflow.outdir import prepare_output_dir
from sacflow.schema import FIELD_ERROR, Campaign, Case, Elastic, Sweep

__all__ = [
    "CampaignCase",
    "CampaignSummary",
    "CaseRecord",
    "expand_campaign",
    "load_campaign",
    "run_campaign",
    "run_one",
]

#: Environment variable read by the FFT operators; campaign workers default to 1 thread each.
FFT_THREADS_ENV = "SACFLOW_FFT_THREADS"
#: Environment of the local cluster's workers: n single-threaded cases on n cores, not n × cores
#: FFT or BLAS threads. OpenMP and BLAS read theirs when numpy loads, so the worker processes
#: (or the fork server they are forked from) start with them.
WORKER_ENV = {
    FFT_THREADS_ENV: "1",
    "OMP_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
}
#: Modules the fork server imports once, before forking the local cluster's workers.
WORKER_PRELOAD = ("distributed", "sacflow.campaign", "sacflow.runner", "sacflow.solver")
#: ... and, when a case has plasticity, what only elastic-plastic runs import (numba included).
PLASTIC_PRELOAD = ("scipy.sparse.linalg", "sacflow.kernels.eigenstrain",
                   "sacflow.kernels.pair_products")
#: ... and last, a module that freezes the garbage collector's view of all that (gc.freeze).
FORK_SERVER_LAST = "sacflow._freeze"
#: Case names longer than this end in a digest of the parameters instead of all the tags.
MAX_NAME = 120
WORKER_DIED = (
    "the worker process died running this case (out of memory, or a crash in compiled code); "
    "see the dask worker logs"
)
#: Transport schemes of a dask scheduler address (``--scheduler``); none means tcp.
SCHEDULER_SCHEMES = ("tcp", "tls", "ws", "wss", "ucx")
#: Largest TCP port number.
MAX_PORT = 65535
#: The expected form of ``--scheduler``, printed with every problem.
SCHEDULER_FORM = (
    "expected tcp://host:8786 (the address `dask scheduler` prints; scheme one of "
    + ", ".join(SCHEDULER_SCHEMES) + ", port 1..65535)"
)
_SCHEDULER_ADDRESS = re.compile(
    r"(?:(?:" + "|".join(SCHEDULER_SCHEMES) + r")://)?"
    r"(?:\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]+):(?P<port>[0-9]{1,5})"
)
Status = Literal["pending", "done", "failed", "skipped"]
SimulationFactory = Callable[[Case], Any]


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
    try:
        campaign = Campaign.model_validate(read_file(path))
    except ValidationError as exc:
        errors = _drop_consequential(exc.errors(include_url=False))
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
    """The base case as a table; a measured surface path made absolute."""
    if isinstance(base, dict):
        data = copy.deepcopy(base)
        _resolve_surface_path(data, folder)
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
    _resolve_surface_path(data, file.parent)
    return data


def _absolute_surface_paths(block: Sweep, folder: Path) -> Sweep:
    """Swept measured-surface files are relative to the campaign file, like the base's."""
    parameters = dict(block.parameters)
    for key in ("surface.path", "surface"):
        if key in parameters:
            values = []
            for value in parameters[key]:
                data = {"surface": {"path": value} if key == "surface.path" else value}
                _resolve_surface_path(data, folder)
                values.append(data["surface"]["path"] if key == "surface.path" else data["surface"])
            parameters[key] = tuple(values)
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
        """Hash of the case (see :attr:`sacflow.schema.Case.case_id`)."""
        return self.case.case_id

    def label(self) -> str:
        """``path=value, ...`` of the swept parameters."""
        return _label(self.parameters)


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
    """Parameter sets of every case: the product of the blocks' rows, in order."""
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


def case_names(campaign: str, rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """``<campaign>-<tag>-<tag>...`` per row: deterministic, file-name safe and unique."""
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


def _build_case(
    base: Mapping[str, Any], row: Mapping[str, Any], name: str, source: str
) -> Case | list[str]:
    """The validated case of one row, or its problems."""
    data = copy.deepcopy(dict(base))
    for key, value in row.items():
        try:
            _set_dotted(data, key.split("."), copy.deepcopy(value), key)
        except ConfigError as exc:
            return [f"{key}: {str(exc).split(': ', 1)[-1]}"]
    data["name"] = name
    try:
        case = Case.model_validate(data)
    except ValidationError as exc:
        return [_problem(e) for e in _drop_consequential(exc.errors(include_url=False))]
    try:
        _check_surface_file(case, source)
    except ConfigError as exc:
        return [line.strip() for line in str(exc).splitlines()[1:]]
    return case


def _case_problems(failures: list[tuple[int, dict[str, Any], list[str]]], total: int) -> list[str]:
    """One line per problem; those of every case once, as ``base (all cases)``."""
    if not failures:
        return []
    common = set(failures[0][2]) if len(failures) == total and total > 1 else set()
    for _, _, problems in failures[1:]:
        common &= set(problems)
    lines = [f"base (all cases): {p}" for p in failures[0][2] if p in common]
    for index, row, problems in failures:
        lines += [f"case {index} ({_label(row)}): {p}" for p in problems if p not in common]
    return lines


def _duplicates(rows: list[dict[str, Any]]) -> list[str]:
    first: dict[str, int] = {}
    problems = []
    for index, row in enumerate(rows, start=1):
        key = json.dumps(row, sort_keys=True, default=str)
        if key in first:
            problems.append(
                f"sweep: cases {first[key]} and {index} have the same parameters "
                f"({_label(row)}); remove the repeated value"
            )
        first.setdefault(key, index)
    return problems


def _path_problem(key: str) -> str | None:
    """Why the dotted ``key`` is not a field path of a :class:`Case` (None when it is)."""
    keys = key.split(".")
    options: list[Any] = [Case]
    for depth, part in enumerate(keys):
        where = ".".join(keys[:depth]) or "the case"
        found: list[Any] = []
        fields: list[str] = []
        sizes: list[int | None] = []
        for tp in _concrete(options):
            if _is_model(tp):
                fields += [f for f in tp.model_fields if f not in fields]
                if part in tp.model_fields:
                    found.append(tp.model_fields[part].annotation)
            elif get_origin(tp) is dict:
                return None  # free-form table: anything goes below
            elif get_origin(tp) in (list, tuple):
                variable = get_origin(tp) is list or tp.__args__[-1] is Ellipsis
                sizes.append(None if variable else len(tp.__args__))
                index = list_index(part)
                if index is not None and (item := _item_type(tp, index)) is not None:
                    found.append(item)
        if found:
            options = found
        elif fields:
            return f"{where} has no field {part!r}" + _suggest(part, fields)
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
    """The concrete types behind annotations, optionals and unions."""
    for tp in options:
        tp, _ = _strip(tp)
        if _is_union(tp):
            yield from _concrete(_members(tp))
        else:
            yield tp


def _short_keys(keys: list[str]) -> dict[str, str]:
    """Shortest distinct dotted suffix of each key, never starting with a list index."""
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
    """A value as a short, file-name safe tag (tables: a digest)."""
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


def _label(row: Mapping[str, Any]) -> str:
    return ", ".join(f"{k}={_show(v)}" for k, v in row.items())


def _show(value: Any) -> str:
    text = json.dumps(value, default=str) if isinstance(value, str | dict) else repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


# --------------------------------------------------------------------------- error messages
def _report(source: str, problems: list[str]) -> str:
    """``source: invalid campaign (n problems)`` then one indented line per problem."""
    problems = list(dict.fromkeys(problems))  # a union error comes once per member
    lines = [f"  {problem}" for problem in problems[:MAX_PROBLEMS]]
    if len(problems) > MAX_PROBLEMS:
        lines.append(f"  ... and {len(problems) - MAX_PROBLEMS} more")
    count = f"{len(problems)} problem" + ("s" if len(problems) != 1 else "")
    return "\n".join([f"{source}: invalid campaign ({count})", *lines])


def _campaign_problem(err: Mapping[str, Any]) -> str:
    """One line for a :class:`Campaign` validation error: the field, what is wrong, the fix."""
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
        return f"{path}: unknown key" + _suggest(loc[-1], list(owner.model_fields))
    if kind == "missing":
        return f"{path}: required field missing{meaning}"
    if loc == ["base"]:
        return f"{path}: expected a case file path or an inline [base] table{got}"
    if kind == "literal_error":
        return f"{path}: must be {ctx.get('expected')}{got}"
    if kind == "string_pattern_mismatch":
        return f"{path}: must start with a letter or digit, then letters, digits, -, _, .{got}"
    if kind == "too_short":
        what = {"sweep": "one [[sweep]] block", "parameters": "one parameter"}.get(
            str(loc[-1]), "one value"
        )
        return f"{path}: needs at least {what}{meaning}"
    if kind in ("tuple_type", "list_type"):
        return f"{path}: expected a list of values, e.g. [32, 48]{got}"
    if kind in ("dict_type", "model_type"):
        return f"{path}: expected a table{meaning}{got}"
    return f"{path}: {err['msg']}{got}"


# --------------------------------------------------------------------------- the dask task
def run_one(
    case_json: str,
    out_dir: str,
    simulation_factory: SimulationFactory | None = None,
    overwrite: bool = False,
) -> dict[str, Any]:
    """Dask task: rebuild the case from its JSON and run it into ``out_dir``.

    Never raises for a failing case: returns ``status`` (``done`` or ``failed``), ``error``,
    ``traceback`` (unexpected errors only), ``wall_time``, ``cpu_time`` (of the worker process:
    well below the wall time when the machine is oversubscribed), ``steps``, ``resumed_steps``.
    ``SACFLOW_FFT_THREADS`` defaults to 1 in the worker (one case per core). A run of another
    case stored under the case's name is replaced only with ``overwrite``.
    """
    os.environ.setdefault(FFT_THREADS_ENV, "1")
    start, cpu_start = time.perf_counter(), time.process_time()
    try:
        from sacflow.runner import run_case

        case = Case.model_validate_json(case_json)
        summary = run_case(
            case, out_dir, progress=False, simulation_factory=simulation_factory, resume=True,
            overwrite=overwrite,
        )
    except Exception as exc:  # the case failed; the campaign goes on
        return {
            "status": "failed",
            "error": _describe(exc),
            "traceback": None if isinstance(exc, SacflowError) else traceback.format_exc(),
            "wall_time": time.perf_counter() - start,
            "cpu_time": time.process_time() - cpu_start,
        }
    return {  # complete already: a retry after its worker died with the result (still "done")
        "status": "done",
        "wall_time": time.perf_counter() - start,
        "cpu_time": time.process_time() - cpu_start,
        "steps": summary.steps,
        "resumed_steps": summary.resumed_steps,
    }


def _describe(exc: BaseException) -> str:
    return str(exc) if isinstance(exc, SacflowError) else f"{type(exc).__name__}: {exc}"


# --------------------------------------------------------------------------- records
@dataclass(frozen=True)
class CaseRecord:
    """Outcome of one case, as stored in the manifest (``path`` relative to its folder)."""

    index: int
    name: str
    case_id: str
    parameters: dict[str, Any]
    path: Path
    status: Status = "pending"
    error: str | None = None
    traceback: str | None = None
    wall_time: float | None = None
    cpu_time: float | None = None
    steps: int | None = None
    resumed_steps: int | None = None

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict; ``path`` is the file name next to the manifest."""
        return {**asdict(self), "path": self.path.name}


@dataclass(frozen=True)
class CampaignSummary:
    """Outcome of a campaign: one record per case, in campaign order."""

    name: str
    out_dir: Path
    manifest: Path
    records: tuple[CaseRecord, ...]
    wall_time: float
    workers: int = 0
    dashboard: str | None = field(default=None, compare=False)

    @property
    def failed(self) -> tuple[CaseRecord, ...]:
        """Records of the failed cases."""
        return tuple(r for r in self.records if r.status == "failed")

    @property
    def paths(self) -> list[Path]:
        """Run files of the cases that are complete."""
        return [r.path for r in self.records if r.status in ("done", "skipped")]

    def counts(self) -> dict[str, int]:
        """Number of cases per status."""
        counts = Counter(r.status for r in self.records)
        return {status: counts.get(status, 0) for status in ("done", "skipped", "failed")}

    def table(self) -> str:
        """Summary table, one line per case, then the totals."""
        width = max([len(r.name) for r in self.records] + [4])
        lines = [f"{'#':>3}  {'case':<{width}}  {'case_id':<12}  {'status':<7}  steps  wall [s]"]
        for r in self.records:
            steps = "-" if r.steps is None else str(r.steps)
            wall = "-" if r.wall_time is None or r.status == "skipped" else f"{r.wall_time:.1f}"
            line = f"{r.index:>3}  {r.name:<{width}}  {r.case_id:<12}  {r.status:<7}  {steps:>5}"
            line += f"  {wall:>8}"
            if r.error:
                first = r.error.splitlines()[0]
                line += f"  {first[:60]}{'...' if len(first) > 60 else ''}"
            lines.append(line)
        counts = ", ".join(f"{n} {status}" for status, n in self.counts().items())
        lines.append(f"{self.name}: {counts} in {self.wall_time:.1f} s; manifest {self.manifest}")
        return "\n".join(lines)


class _Manifest:
    """``<out>/<campaign>.manifest.json``, rewritten atomically after every change."""

    def __init__(self, campaign: Campaign, cases: list[CampaignCase], out_dir: Path) -> None:
        self.campaign = campaign
        self.path = out_dir / f"{campaign.name}.manifest.json"
        for stale in out_dir.glob(f".{self.path.name}.*.tmp"):  # a campaign killed mid-write
            stale.unlink(missing_ok=True)
        previous = self._previous()
        self.records = {}
        for c in cases:
            record = CaseRecord(c.index, c.name, c.case_id, c.parameters, out_dir / f"{c.name}.nc")
            old = previous.get(c.case_id, {})
            if old.get("status") in ("done", "skipped"):  # keep the time of the run that did it
                record = replace(
                    record, wall_time=old.get("wall_time"), cpu_time=old.get("cpu_time")
                )
            self.records[c.index] = record

    def _previous(self) -> dict[str, dict[str, Any]]:
        try:
            cases = json.loads(self.path.read_text())["cases"]
            return {c["case_id"]: c for c in cases}
        except (OSError, ValueError, KeyError, TypeError):
            return {}

    def update(self, index: int, **changes: Any) -> None:
        self.records[index] = replace(self.records[index], **changes)

    def write(self) -> None:
        records = list(self.records.values())
        data = {
            "campaign": self.campaign.name,
            "description": self.campaign.description,
            "updated": datetime.now(UTC).isoformat(timespec="seconds"),
            "counts": dict(Counter(r.status for r in records)),
            "cases": [r.to_json() for r in records],
        }
        tmp = self.path.with_name(f".{self.path.name}.{os.getpid()}.tmp")
        with open(tmp, "w") as f:
            json.dump(data, f, indent=2, default=str)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, self.path)


# --------------------------------------------------------------------------- running
def run_campaign(
    campaign: Campaign | str | Path,
    out_dir: str | Path,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool = True,
    simulation_factory: SimulationFactory | None = None,
    overwrite: bool = False,
) -> CampaignSummary:
    """Run every case of ``campaign`` with dask, one task and one file per case.

    Parameters
    ----------
    campaign : Campaign, str or Path
        The campaign, or its file (read with :func:`load_campaign`).
    out_dir : str or Path
        Output folder: ``<case name>.nc`` per case and ``<campaign>.manifest.json``. With
        ``scheduler``, the workers must see it at the same path (shared file system).
    workers : int, optional
        Worker processes of the local cluster (default: one per core, at most one per case).
    scheduler : str, optional
        Address of a running dask scheduler (``tcp://host:8786``) to use instead.
    progress : bool
        Progress bar over the cases; the dashboard link is printed either way (stderr).
    simulation_factory : callable, optional
        ``factory(case) -> simulation`` passed to :func:`sacflow.runner.run_case`; it must be
        importable by the workers (a module-level function).
    overwrite : bool
        Replace runs of other cases stored under the cases' names. Without it such a case is
        not run and fails with a message naming the file, both ids and the fields that differ.

    Returns
    -------
    CampaignSummary
        Records in campaign order; a failed case has ``status == "failed"`` and its message.
    """
    start = time.perf_counter()
    if not isinstance(campaign, Campaign):
        campaign = load_campaign(campaign)
    if workers is not None and (scheduler or workers < 1):
        raise ConfigError(
            "--workers sizes the local cluster; use a positive number and no --scheduler"
        )
    if scheduler:
        check_scheduler_address(scheduler)
    cases = expand_campaign(campaign)
    out_dir = prepare_output_dir(out_dir).resolve()
    manifest = _Manifest(campaign, cases, out_dir)
    pending = _skip_complete(cases, manifest, overwrite)
    if pending and not scheduler:  # its imports overlap the rest, up to the workers' start
        _start_fork_server(plastic=any(not isinstance(c.case.body.hardening, Elastic)
                                       for c in pending))
    manifest.write()
    _say(
        f"{campaign.name}: {len(cases)} cases, {len(cases) - len(pending)} already complete, "
        f"{len(pending)} to run"
    )
    n_workers, dashboard = 0, None
    if pending:
        with _client(scheduler, workers, len(pending)) as client:
            n_workers = len(client.nthreads())
            dashboard = _dashboard(client, local=not scheduler)
            _say(f"dask: {client.scheduler.address}, {n_workers} workers, dashboard {dashboard}")
            _run_pending(client, pending, out_dir, manifest, progress, simulation_factory,
                         overwrite)
    return CampaignSummary(
        name=campaign.name,
        out_dir=out_dir,
        manifest=manifest.path,
        records=tuple(manifest.records.values()),
        wall_time=time.perf_counter() - start,
        workers=n_workers,
        dashboard=dashboard,
    )


def _skip_complete(
    cases: list[CampaignCase], manifest: _Manifest, overwrite: bool = False
) -> list[CampaignCase]:
    """Mark the cases whose run file is complete as skipped; return the others to run.

    A case whose name holds a run of another case (finished or interrupted) is marked failed
    with the message of :func:`sacflow.store.replace_message`, unless ``overwrite``.
    """
    from sacflow.store import replace_message, run_info

    pending = []
    for c in cases:
        info = run_info(manifest.records[c.index].path)
        same = info.exists and info.matches(c.case_id)
        if info.complete and same:
            manifest.update(c.index, status="skipped", steps=info.steps)
        elif info.exists and not same and not info.damaged_only and not overwrite:
            manifest.update(c.index, status="failed", error=replace_message(info, c.case))
        else:
            pending.append(c)
    return pending


def _run_pending(
    client: Any,
    pending: list[CampaignCase],
    out_dir: Path,
    manifest: _Manifest,
    progress: bool,
    simulation_factory: SimulationFactory | None,
    overwrite: bool = False,
) -> None:
    from distributed import as_completed

    # Longest first (dask runs tasks in submission order): a long case started last would keep
    # one worker busy while the others idle. Equal estimates keep the campaign order.
    ordered = sorted(pending, key=_estimated_cost, reverse=True)
    futures = {
        client.submit(
            run_one, c.case.canonical_json(), str(out_dir), simulation_factory, overwrite,
            pure=False,
        ): c
        for c in ordered
    }
    failed = 0
    bar = tqdm(total=len(futures), desc=manifest.campaign.name, unit="case", disable=not progress)
    with bar:
        for future in as_completed(futures):
            case = futures.pop(future)
            try:
                outcome = future.result()
            except Exception as exc:  # the worker died (KilledWorker), or the task was lost
                error = _describe(exc)
                if type(exc).__name__ == "KilledWorker":
                    error = f"{WORKER_DIED}: {error}"
                outcome = {"status": "failed", "error": error}
            manifest.update(case.index, **outcome)
            manifest.write()
            failed += outcome["status"] == "failed"
            bar.set_postfix(failed=failed, refresh=False)
            bar.update()


def _estimated_cost(c: CampaignCase) -> int:
    """Relative cost of a case: grid cells x steps (plasticity or rolling not weighed)."""
    grid = c.case.grid
    steps = sum(getattr(s, "increments", None) or getattr(s, "steps", 1) for s in c.case.load_path)
    return grid.nx * grid.ny * grid.nz * steps


def check_scheduler_address(address: str) -> None:
    """Check that ``address`` has the form of a dask scheduler address, before any work.

    Accepted: ``[scheme://]host:port`` with scheme one of :data:`SCHEDULER_SCHEMES` (dask's
    default is tcp) and a port 1..65535, e.g. ``tcp://10.0.0.1:8786`` or ``localhost:8786``.
    Otherwise dask fails with a ``ValueError`` deep inside its address parsing.

    Raises
    ------
    ConfigError
        Naming ``--scheduler``, the value and the expected form.
    """
    match = _SCHEDULER_ADDRESS.fullmatch(address.strip())
    if match is None or not 1 <= int(match["port"]) <= MAX_PORT:
        raise ConfigError(
            f"--scheduler {address!r} is not a dask scheduler address; {SCHEDULER_FORM}"
        )


@contextmanager
def _client(scheduler: str | None, workers: int | None, tasks: int) -> Iterator[Any]:
    """A dask client: on ``scheduler``, or on a new local cluster closed at the end."""
    if scheduler:
        from distributed import Client

        try:
            client = Client(scheduler, timeout="10s")
        except ValueError as exc:  # an address check_scheduler_address let through
            raise ConfigError(f"--scheduler {scheduler!r}: {exc}; {SCHEDULER_FORM}") from None
        except (OSError, TimeoutError) as exc:
            raise SacflowError(
                f"cannot connect to the dask scheduler at {scheduler} ({exc}); start one with "
                "`dask scheduler` and workers with `dask worker <address>`"
            ) from None
        with client:
            yield client
        return
    n = min(workers or _cores(), tasks)
    method = _start_fork_server()  # started already by run_campaign, else now
    import dask
    from distributed import Client, LocalCluster

    config = {
        # dask sets MALLOC_TRIM_THRESHOLD_=65536 in its workers (and in this process, for good),
        # which turns off glibc's adaptive mmap threshold: every large temporary array is then
        # mapped and zero-filled afresh, and the solver runs about 1.6 times slower (measured on
        # a 96 x 96 x 16 elastic case). Not set here: the workers get sacflow.malloc's settings
        # from the environment of _worker_environ (the fork server's, or this one's for spawn).
        "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
        "distributed.worker.multiprocessing-method": method,
        # The workers' statistical profiler takes the GIL every 10 ms to walk the running
        # task's stack (it feeds the dashboard's profile page): measured, cases ran ~10 %
        # slower in a worker than in a plain process. Off for sacflow's own cluster.
        "distributed.worker.profile.enabled": False,
    }
    # For the cluster's whole life: a worker that died is started again the same way. Spawned
    # workers inherit this process's environment, forked ones the fork server's.
    spawned = _worker_environ() if method == "spawn" else nullcontext()
    # Each nanny writes the thread settings of its worker's environment into this process's
    # os.environ before starting the worker (distributed's "pre-spawn" variables), and leaves
    # them there: a notebook's later subprocesses would run single-threaded BLAS.
    with dask.config.set(config), spawned, _saved_environ(WORKER_ENV):
        cluster = LocalCluster(
            n_workers=n,
            threads_per_worker=1,
            processes=True,
            silence_logs=logging.ERROR,
            env=dict(WORKER_ENV),
        )
        try:
            with Client(cluster) as client:
                yield client
        finally:
            cluster.close()


def _start_fork_server(plastic: bool = False) -> str:
    """Start multiprocessing's fork server for the local cluster; return the start method.

    The fork server imports :data:`WORKER_PRELOAD` once (and :data:`PLASTIC_PRELOAD` for
    ``plastic`` campaigns), then freezes the objects it made (:data:`FORK_SERVER_LAST`); the
    workers forked from it start with everything a case needs loaded
    (a spawned worker imports it all again, about 1 s of a core each) and exit at once (a
    spawned one tears down its interpreter, about 1 s at the end of a campaign). It is started
    once per process, in the environment of :func:`_worker_environ`; a fork server already
    running (started earlier in this process) is used as it is. ``spawn`` where there is no
    fork server (Windows).
    """
    import multiprocessing
    from multiprocessing import forkserver

    if "forkserver" not in multiprocessing.get_all_start_methods():  # pragma: no cover
        return "spawn"
    modules = WORKER_PRELOAD + (PLASTIC_PRELOAD if plastic else ()) + (FORK_SERVER_LAST,)
    forkserver.set_forkserver_preload(list(modules))
    with _worker_environ():
        forkserver.ensure_running()  # returns once started; the imports go on in the server
    _keep_preload()
    return "forkserver"


def _keep_preload() -> None:
    """Tell distributed that the fork server's preload list is set (by us) already.

    Otherwise the first nanny to start a worker (``distributed.utils.get_mp_context``) imports
    distributed's optional packages *in this process*, pandas among them, to replace the list
    with its own: 0.4 s on the way to the workers' start, measured in the event loop of a
    parent process that had not loaded pandas (which neither sacflow's runs nor its workers
    need), and a fork server restarted later would not load sacflow. The flag is a private
    module global of distributed (2024-2026); without it nothing changes.
    """
    import distributed.utils

    if hasattr(distributed.utils, "_forkserver_preload_set"):
        distributed.utils._forkserver_preload_set = True


@contextmanager
def _worker_environ() -> Iterator[None]:
    """``os.environ`` with :data:`WORKER_ENV` and the malloc settings inside the block only.

    The processes started inside (the fork server, or spawned workers) inherit it.
    """
    changes = {**WORKER_ENV, **MALLOC_ENV}
    with _saved_environ(changes):
        os.environ.update(changes)
        yield


@contextmanager
def _saved_environ(keys: Iterable[str]) -> Iterator[None]:
    """Give ``os.environ``'s ``keys`` back their values of the block's start when it ends."""
    saved = {key: os.environ.get(key) for key in keys}
    try:
        yield
    finally:
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


def _cores() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not on Linux
        return max(1, os.cpu_count() or 1)


def _dashboard(client: Any, local: bool) -> str:
    if "dashboard" not in client.scheduler_info().get("services", {}):
        return "not available"
    link = str(client.dashboard_link)
    if local and importlib.util.find_spec("bokeh") is None:
        link += " (install bokeh to see it)"
    return link


def _say(message: str) -> None:
    print(message, file=sys.stderr, flush=True)
