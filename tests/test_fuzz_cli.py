"""Fuzz test of the command line: mutated shipped configs never give a traceback (issue #14).

Starting from ``configs/*.toml`` (the campaign file included), hypothesis mutates the parsed
files -- wrong types, negative values, zeros, NaN/inf, huge and tiny values, missing and extra
keys, load-path segments reordered, deleted or duplicated, odd ``--set`` overrides, truncated
files -- writes them to a temporary folder as TOML and drives ``sacflow.cli.main`` in-process:

* ``validate`` for most examples;
* ``run`` at a tiny grid (16 x 16 x 4 cells, one increment per segment, two rolling steps) for
  fewer;
* ``campaign`` on mutated campaign files, with the dask part replaced by a stand-in (no
  cluster is started: the campaign is loaded, expanded, checked and its manifest written; the
  real cluster runs the smoke campaign in ``tests/test_campaign.py``);
* ``validate``, ``cache info`` and ``info`` under odd ``SACFLOW_*`` environment variables;
* ``compare`` stages given a tiny real run, a case file, garbage, a truncated run, a manifest,
  a folder or a missing file, with odd option values (exit code 0, or 2 with a message).

Every outcome must be exit code 0, or a non-zero code with an ``error: ...`` message; an
exception escaping ``main`` or a "Traceback" in the output fails the test. Deterministic
(``derandomize=True``); the example counts and outcomes are printed (``pytest -s``).
"""

from __future__ import annotations

import contextlib
import copy
import io
import json
import math
import os
import re
import tempfile
import tomllib
from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sacflow.campaign import cluster as cluster_module
from sacflow.campaign import running as running_module
from sacflow.cli import main

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
SHIPPED = {p.stem: tomllib.loads(p.read_text()) for p in sorted(CONFIGS.glob("*.toml"))}
CASES = sorted(name for name in SHIPPED if "campaign" not in name)
CAMPAIGNS = sorted(name for name in SHIPPED if "campaign" in name)
#: Examples per command: validation is cheap (~20 ms), a tiny run ~0.2-1 s.
VALIDATE_EXAMPLES, RUN_EXAMPLES, CAMPAIGN_EXAMPLES = 1000, 32, 150
#: The tiny run: cells across the window (enough for the cases' half-widths) and layers.
TINY_CELLS, TINY_LAYERS, ROLL_STEPS = 16, 4, 2
FUZZ = settings(deadline=None, derandomize=True, database=None, print_blob=True,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                       HealthCheck.filter_too_much])
BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")
#: Outcomes per command: exit codes, and the number of examples.
OUTCOMES: dict[str, Counter] = {"validate": Counter(), "run": Counter(), "campaign": Counter()}


# --------------------------------------------------------------------------- TOML writer
def toml_value(value: Any) -> str:
    """``value`` as a TOML literal (inline tables and arrays; nan/inf as TOML writes them)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)  # a JSON string (ASCII, \\u escapes) is a TOML basic string
    if isinstance(value, list | tuple):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{toml_key(k)} = {toml_value(v)}" for k, v in value.items()) + "}"
    raise TypeError(type(value))


def toml_key(key: str) -> str:
    return key if BARE_KEY.fullmatch(key) else json.dumps(key)


def toml_document(data: dict[str, Any]) -> str:
    """A TOML document: one ``key = value`` line per top-level key (inline tables)."""
    return "".join(f"{toml_key(k)} = {toml_value(v)}\n" for k, v in data.items())


# --------------------------------------------------------------------------- mutations
def paths(node: Any, prefix: tuple = ()) -> Iterator[tuple]:
    """Every key path of a nested dict/list (tables, lists and leaves)."""
    if isinstance(node, dict):
        items = node.items()
    elif isinstance(node, list):
        items = enumerate(node)
    else:
        return
    for key, value in items:
        yield (*prefix, key)
        yield from paths(value, (*prefix, key))


def parent_of(data: Any, path: tuple) -> Any:
    for key in path[:-1]:
        data = data[key]
    return data


def bad_values(old: Any) -> st.SearchStrategy[Any]:
    """Wrong types, signs, zeros, non-finite, huge and tiny values (some derived from ``old``)."""
    fixed = [
        "abc", "", "1e-3", True, [], [1.0], [1.0, "x"], {}, {"x": 1}, 0, 0.0, -1, -1.0,
        math.nan, math.inf, -math.inf, 1e300, -1e300, 1e-300, 5e-324, 10**30, -(10**30), 2**63,
        "load", "roll", "unload", "hold", "elastic", "swift", "tabular", "voce",
    ]
    derived = []
    if isinstance(old, int | float) and not isinstance(old, bool):
        derived = [-old, old * 1e6, old * 1e-6, float(old), int(old) if math.isfinite(old) else 0,
                   str(old), [old, old]]
    elif isinstance(old, list):
        derived = [old[:1], old * 3, list(reversed(old)), [*old, old[-1] if old else 0]]
    return st.sampled_from(fixed + derived)


EXTRA_KEYS = ("extra", "nxx", "hardness", "kind", "law", "to", "0", "load_path", "Name")
SEGMENT_OPS = ("reverse", "rotate", "roll_first", "unload_first", "delete", "duplicate", "empty",
               "kind_swap", "not_a_list", "drop_kind")


#: Mutations: any value (wrong types, non-finite ...), a number scaled (stays a number: the
#: case often stays valid and runs), a key deleted or added, load-path segments changed.
ANY_OPS = ("value", "value", "scale", "scale", "delete", "extra", "segments")
#: For runs: mostly mutations that keep the case valid, so that the solver sees odd cases.
RUN_OPS = ("scale", "scale", "scale", "segments", "value")
SCALES = (0.0, -1.0, 1e-3, 0.1, 0.5, 2.0, 10.0, 1e3, 1e6)


@st.composite
def mutation(draw, data: dict[str, Any], ops: tuple[str, ...] = ANY_OPS) -> str:
    """Apply one random mutation to ``data`` in place; return its description."""
    all_paths = list(paths(data))
    op = draw(st.sampled_from(ops))
    if op == "segments" or not all_paths:
        return _mutate_segments(draw, data)
    if op == "scale":
        numbers = [p for p in all_paths if _is_number(parent_of(data, p)[p[-1]])]
        if numbers:
            path = draw(st.sampled_from(numbers))
            parent, factor = parent_of(data, path), draw(st.sampled_from(SCALES))
            value = parent[path[-1]] * factor
            parent[path[-1]] = int(value) if isinstance(parent[path[-1]], int) else value
            return f"scale {path} by {factor}"
    path = draw(st.sampled_from(all_paths))
    parent = parent_of(data, path)
    if op == "delete":
        del parent[path[-1]]
        return f"delete {path}"
    if op == "extra":
        target = parent[path[-1]] if isinstance(parent[path[-1]], dict) else parent
        if isinstance(target, dict):
            key = draw(st.sampled_from(EXTRA_KEYS))
            target[key] = draw(bad_values(None))
            return f"extra {key} at {path}"
    value = draw(bad_values(parent[path[-1]]))
    parent[path[-1]] = copy.deepcopy(value)
    return f"set {path} = {value!r}"


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _segments_holder(data: dict[str, Any]) -> dict[str, Any] | None:
    if isinstance(data.get("load_path"), list):
        return data
    base = data.get("base")
    if isinstance(base, dict) and isinstance(base.get("load_path"), list):
        return base
    return None


def _mutate_segments(draw, data: dict[str, Any]) -> str:
    holder = _segments_holder(data)
    if holder is None:
        return "no load_path"
    segs = holder["load_path"]
    op = draw(st.sampled_from(SEGMENT_OPS))
    i = draw(st.integers(0, max(0, len(segs) - 1)))
    if op == "reverse":
        segs.reverse()
    elif op == "rotate" and segs:
        segs.append(segs.pop(0))
    elif op in ("roll_first", "unload_first"):
        kind = op.split("_")[0]
        new = ({"kind": "roll", "distance": 1e-4, "steps": 2} if kind == "roll"
               else {"kind": "unload", "to": 0.0, "increments": 1})
        segs.insert(0, new)
    elif op == "delete" and segs:
        del segs[i]
    elif op == "duplicate" and segs:
        segs.insert(i, copy.deepcopy(segs[i]))
    elif op == "empty":
        segs.clear()
    elif op == "kind_swap" and segs and isinstance(segs[i], dict):
        segs[i]["kind"] = draw(st.sampled_from(["load", "unload", "hold", "roll", "jump"]))
    elif op == "not_a_list":
        holder["load_path"] = segs[0] if segs else {}
    elif op == "drop_kind" and segs and isinstance(segs[i], dict):
        segs[i].pop("kind", None)
    return f"segments {op} {i}"


#: ``--set`` items given now and then: odd paths, indices and values.
ODD_OVERRIDES = (
    "load_path.-1.to=1", "load_path.5.to=1", "load_path.x.to=1", "load_path.1.5=2", "grid=3",
    "grid.nx=nan", "grid.nx=1e400", "a..b=1", "=1", "grid.nx", "body.hardening.law=voce",
    "body.hardening.C=0", "surface.kind=measured", "body.radii.7=1", "load_path.0=inf",
    "solver.fft_threads=0", "output.fields=[\"nope\"]", "name=\"bad name\"", "grid.nx=[1,",
)


#: ``--set`` items of runs: valid but extreme options (the schema accepts them: they must run,
#: or fail with a message).
EXTREME_OPTIONS = (
    "solver.fft_threads=1000000000000000000000", "solver.fft_threads=64",
    "solver.anderson_depth=1000000000000000000000", "solver.anderson_depth=1",
    "solver.contact_max_iterations=1", "solver.plasticity_max_iterations=1",
    "solver.coupling_max_iterations=1", 'solver.scheme="nested"', 'solver.acceleration="none"',
    "solver.contact_tolerance=1e-300", "solver.coupling_tolerance=1e300",
    "solver.plastic_margin=1e-300", "solver.plastic_margin=1e300", "grid.depth=1e-12",
    "grid.half_width=1e3", "output.volume_every=1000000000000000000000", "output.compression=0",
    'output.fields=["pressure"]', "output.fields=[]",
)


@st.composite
def case_example(
    draw, ops: tuple[str, ...] = ANY_OPS, most: int = 3, odd_sets: int = 2,
    options: tuple[str, ...] = ODD_OVERRIDES,
) -> tuple[str, dict[str, Any], list[str], list[str], bool]:
    """(config, mutated data, mutation log, --set items, truncate the file text?)."""
    name = draw(st.sampled_from(CASES))
    data = copy.deepcopy(SHIPPED[name])
    log = [draw(mutation(data, ops)) for _ in range(draw(st.integers(0 if odd_sets else 1, most)))]
    sets = draw(st.lists(st.sampled_from(options), max_size=odd_sets))
    return name, data, log, sets, options is ODD_OVERRIDES and draw(st.integers(0, 19)) == 0


def run_cli(argv: list[str]) -> tuple[int, str, str]:
    """Exit code, stdout and stderr of ``sacflow argv`` in-process; argparse exits allowed."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse: usage line and "sacflow: error: ..."
            code = exc.code if isinstance(exc.code, int) else 2
    return code, out.getvalue(), err.getvalue()


def check_outcome(command: str, code: int, out: str, err: str, log: Any) -> None:
    OUTCOMES[command][code] += 1
    OUTCOMES[command]["examples"] += 1
    text = out + err
    assert "Traceback" not in text, f"traceback after {log}:\n{text}"
    if code != 0:
        assert "error: " in err, f"exit {code} without an error message after {log}:\n{text}"
        assert len(err.splitlines()) <= 60, f"more than one screen after {log}:\n{err}"


def write_case(folder: Path, name: str, data: dict[str, Any], truncate: bool) -> Path:
    text = toml_document(data)
    if truncate:
        text = text[: len(text) // 2]
    path = folder / f"{name}.toml"
    path.write_text(text)
    return path


# --------------------------------------------------------------------------- validate
@settings(FUZZ, max_examples=VALIDATE_EXAMPLES)
@given(example=case_example())
def _fuzz_validate(example) -> None:
    name, data, log, sets, truncate = example
    with tempfile.TemporaryDirectory() as tmp:
        path = write_case(Path(tmp), name, data, truncate)
        code, out, err = run_cli(["validate", str(path), *(f"--set={s}" for s in sets)])
    check_outcome("validate", code, out, err, (name, log, sets, truncate))


def test_fuzz_validate() -> None:
    OUTCOMES["validate"].clear()
    _fuzz_validate()
    print(f"\nfuzz validate: {dict(OUTCOMES['validate'])}")
    assert OUTCOMES["validate"]["examples"] >= VALIDATE_EXAMPLES // 2
    assert OUTCOMES["validate"][0] > 0 and OUTCOMES["validate"][2] > 0


# --------------------------------------------------------------------------- run
def tiny_overrides(data: dict[str, Any]) -> list[str]:
    """``--set`` items making the case tiny: few cells and layers, one increment per segment."""
    sets = [f"grid.nx={TINY_CELLS}", f"grid.ny={TINY_CELLS}", f"grid.nz={TINY_LAYERS}"]
    segments = data.get("load_path")
    for i, seg in enumerate(segments if isinstance(segments, list) else []):
        if isinstance(seg, dict) and seg.get("kind") == "roll":
            sets.append(f"load_path.{i}.steps={ROLL_STEPS}")
        elif isinstance(seg, dict):
            sets.append(f"load_path.{i}.increments=1")
    return [f"--set={s}" for s in sets]


@settings(FUZZ, max_examples=RUN_EXAMPLES)
@given(example=case_example(RUN_OPS, most=1, odd_sets=1, options=EXTREME_OPTIONS))
def _fuzz_run(example) -> None:
    name, data, log, sets, truncate = example
    with tempfile.TemporaryDirectory() as tmp:
        path = write_case(Path(tmp), name, data, truncate)
        argv = ["run", str(path), "--out", str(Path(tmp) / "runs"), "--no-progress",
                *(f"--set={s}" for s in sets), *tiny_overrides(data)]
        code, out, err = run_cli(argv)
    check_outcome("run", code, out, err, (name, log, sets, truncate))


def test_fuzz_run() -> None:
    OUTCOMES["run"].clear()
    _fuzz_run()
    print(f"\nfuzz run: {dict(OUTCOMES['run'])}")
    assert OUTCOMES["run"]["examples"] >= RUN_EXAMPLES // 2


# --------------------------------------------------------------------------- campaign
SWEEP_KEYS = ("load_path.0.to", "load_path.-1.to", "load_path.7.to", "grid.nx", "grid..nx",
              "grid.nope", "name", "counterbody", "body.radii.0", "body.radii.2", "", "a.b.c",
              "body.hardening.C", "load_path.x.to", "load_path.²", "solver.scheme")
CAMPAIGN_OPTIONS = ((), (), (), ("--workers", "0"), ("--workers", "2"),
                    ("--scheduler", "not-an-address"), ("--scheduler", "tcp://host"),
                    ("--set", "load_path.-1.to=1"), ("--set", "grid.nz=0"))


@st.composite
def campaign_example(draw) -> tuple[str, dict[str, Any], list[str], tuple[str, ...]]:
    name = draw(st.sampled_from(CAMPAIGNS))
    data = copy.deepcopy(SHIPPED[name])
    log = []
    for _ in range(draw(st.integers(0, 3))):
        if draw(st.booleans()) and isinstance(data.get("sweep"), list) and data["sweep"]:
            block = data["sweep"][0]
            if isinstance(block, dict) and isinstance(block.get("parameters"), dict):
                key = draw(st.sampled_from(SWEEP_KEYS))
                block["parameters"][key] = draw(st.sampled_from(
                    [[1.0], [0.5, 0.7], [], 3, [math.nan], [-1], ["x"], [8, 8], [{"a": 1}]]))
                log.append(f"sweep {key!r} = {block['parameters'][key]!r}")
                continue
        log.append(draw(mutation(data)))
    return name, data, log, draw(st.sampled_from(CAMPAIGN_OPTIONS))


@contextlib.contextmanager
def _stand_in_client(scheduler, workers, tasks, largest_task=0):
    """No cluster: a client with no workers (the tasks are not run)."""
    yield SimpleNamespace(nthreads=dict, scheduler=SimpleNamespace(address="inproc://fuzz"),
                          scheduler_info=lambda: {"services": {}})


def _no_tasks(client, pending, out_dir, manifest, *args) -> None:
    for c in pending:
        manifest.update(c.index, status="skipped")


@settings(FUZZ, max_examples=CAMPAIGN_EXAMPLES)
@given(example=campaign_example())
def _fuzz_campaign(example) -> None:
    name, data, log, options = example
    with tempfile.TemporaryDirectory() as tmp:
        path = write_case(Path(tmp), name, data, truncate=False)
        argv = ["campaign", str(path), "--out", str(Path(tmp) / "runs"), "--no-progress",
                *options]
        code, out, err = run_cli(argv)
    check_outcome("campaign", code, out, err, (name, log, options))


def test_fuzz_campaign(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(cluster_module, "connect", _stand_in_client)
    monkeypatch.setattr(running_module, "_run_pending", _no_tasks)
    monkeypatch.setattr(cluster_module, "start_fork_server", lambda plastic=False: "forkserver")
    OUTCOMES["campaign"].clear()
    _fuzz_campaign()
    print(f"\nfuzz campaign: {dict(OUTCOMES['campaign'])}")
    assert OUTCOMES["campaign"]["examples"] >= CAMPAIGN_EXAMPLES // 2
    assert OUTCOMES["campaign"][0] > 0 and OUTCOMES["campaign"][2] > 0


# --------------------------------------------------------------------------- environment
#: The SACFLOW_* variables and values to try (good, bad, odd); a file path is added per example.
ENVIRONMENT = ("SACFLOW_FFT_THREADS", "SACFLOW_FFTW_PLANNER", "SACFLOW_CACHE_DIR",
               "SACFLOW_CACHE_MAX_BYTES")
ENV_VALUES = ("", "0", "-1", "1", "2", " 4 ", "1.5", "abc", "nan", "inf", "1e3", "0x10",
              "99999999999999999999", "measure", "ESTIMATE", "patient", "off", "OFF", "none",
              "/proc/sacflow", "/dev/null", "~/nowhere/cache", "20G", "500M", "1T", "-5M", "0B",
              "12 GiB", "1.5G", "G", "<file>")
ENV_COMMANDS = (("validate",), ("cache", "info"), ("info",))
ENV_EXAMPLES = 150


@st.composite
def environment_example(draw) -> tuple[dict[str, str], tuple[str, ...]]:
    names = draw(st.lists(st.sampled_from(ENVIRONMENT), min_size=1, max_size=3, unique=True))
    return ({name: draw(st.sampled_from(ENV_VALUES)) for name in names},
            draw(st.sampled_from(ENV_COMMANDS)))


@settings(FUZZ, max_examples=ENV_EXAMPLES)
@given(example=environment_example())
def _fuzz_environment(example) -> None:
    values, command = example
    with tempfile.TemporaryDirectory() as tmp:
        a_file = Path(tmp) / "a-file"
        a_file.write_text("")
        env = {k: str(a_file) if v == "<file>" else v for k, v in values.items()}
        argv = list(command)
        if command[0] == "validate":
            argv += [str(CONFIGS / "hertz-elastic.toml"), "--set=grid.nx=16", "--set=grid.ny=16"]
        elif command[0] == "info":
            argv += [str(a_file)]
        with cluster_module.saved_environ(env):
            os.environ.update(env)
            code, out, err = run_cli(argv)
    check_outcome("environment", code, out, err, (values, command))
    if command[0] == "validate":
        assert code in (0, 2), f"exit {code} after {values}:\n{err}"


def test_fuzz_environment() -> None:
    """SACFLOW_* variables of any value: a result or a clear message, never a traceback."""
    OUTCOMES["environment"] = Counter()
    _fuzz_environment()
    print(f"\nfuzz environment: {dict(OUTCOMES['environment'])}")
    assert OUTCOMES["environment"]["examples"] >= ENV_EXAMPLES // 2
    assert OUTCOMES["environment"][0] > 0 and OUTCOMES["environment"][2] > 0


# --------------------------------------------------------------------------- compare
#: What a compare stage may be given as a run: a real tiny run, and files that are not runs.
COMPARE_INPUTS = ("run", "run", "case", "garbage", "truncated", "manifest", "missing", "folder",
                  "netcdf")
COMPARE_VALUES = ("0", "-1", "-9e8", "1e-6", "2.5e-5", "nan", "inf", "-inf", "abc", "1e300", "",
                  "last", "max_load", "99", "-3", "x2=0", "component=11", "=", "11", "uniaxial")
COMPARE_EXAMPLES = 120


@st.composite
def compare_example(draw) -> tuple[str, list[str], list[str]]:
    from sacflow.compare.command import STAGES

    stage = draw(st.sampled_from(sorted(STAGES)))
    n = {"1": 1, "2": 2, "+": 2}[STAGES[stage].runs]
    if draw(st.integers(0, 9)) == 0:
        n = draw(st.integers(1, 3))  # sometimes the wrong count
    inputs = [draw(st.sampled_from(COMPARE_INPUTS)) for _ in range(n)]
    options = []
    names = list(STAGES[stage].options) + ["depth", "step"]
    for name in draw(st.lists(st.sampled_from(names), max_size=3, unique=True)):
        options += [f"--{name.replace('_', '-')}", draw(st.sampled_from(COMPARE_VALUES))]
    return stage, inputs, options


_COMPARE_FILES: dict[str, Path] = {}


@settings(FUZZ, max_examples=COMPARE_EXAMPLES)
@given(example=compare_example())
def _fuzz_compare(example) -> None:
    stage, inputs, options = example
    with tempfile.TemporaryDirectory() as tmp:
        argv = ["compare", stage, *(str(_COMPARE_FILES[i]) for i in inputs), "--out",
                str(Path(tmp) / "cmp"), *options]
        code, out, err = run_cli(argv)
    check_outcome("compare", code, out, err, (stage, inputs, options))
    assert code in (0, 2), f"exit {code} after {(stage, inputs, options)}:\n{err}"


def test_fuzz_compare(tmp_path_factory) -> None:
    """Compare stages on runs and non-runs, odd options: a result or exit 2 with a message."""
    import numpy as np
    import xarray as xr

    folder = tmp_path_factory.mktemp("compare-inputs")
    case = CONFIGS / "hertz-elastic.toml"
    code, _, err = run_cli(["run", str(case), "--out", str(folder), "--no-progress",
                            f"--set=grid.nx={TINY_CELLS}", f"--set=grid.ny={TINY_CELLS}",
                            f"--set=grid.nz={TINY_LAYERS}"])
    assert code == 0, err
    run = folder / "hertz-elastic.nc"
    files = {"run": run, "case": case, "missing": folder / "absent.nc", "folder": folder,
             "garbage": folder / "garbage.nc", "truncated": folder / "truncated.nc",
             "manifest": folder / "study.manifest.json", "netcdf": folder / "other.nc"}
    files["garbage"].write_bytes(b"\x00garbage" * 64)
    files["truncated"].write_bytes(run.read_bytes()[: run.stat().st_size // 2])
    files["manifest"].write_text('{"campaign": "study", "cases": []}')
    xr.Dataset({"a": ("x", np.arange(3.0))}).to_netcdf(files["netcdf"])
    _COMPARE_FILES.update(files)
    OUTCOMES["compare"] = Counter()
    _fuzz_compare()
    print(f"\nfuzz compare: {dict(OUTCOMES['compare'])}")
    assert OUTCOMES["compare"]["examples"] >= COMPARE_EXAMPLES // 2
    assert OUTCOMES["compare"][0] > 0 and OUTCOMES["compare"][2] > 0
