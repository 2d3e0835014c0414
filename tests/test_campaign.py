"""Campaigns: expansion, names and ids, error messages, dask runs, resume, failures, SIGKILL.

The module-level simulation factories below are imported by the dask workers (forked or spawned,
they get this process's ``sys.path``, so ``test_campaign`` is importable there), hence they live
at top level.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import importlib.util
import json
import multiprocessing
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import psutil
import pytest
from test_store import make_coords, make_state

import sacflow.campaign as campaign_module
from sacflow import runner
from sacflow.campaign import (
    CampaignConflictError,
    case_names,
    expand_campaign,
    load_campaign,
    run_campaign,
)
from sacflow.campaign import cluster as cluster_module
from sacflow.campaign.opening import open_campaign
from sacflow.cli import main
from sacflow.config.schema import NAME_PATTERN, Case
from sacflow.errors import ConfigError, ConvergenceError
from sacflow.machine.malloc import MALLOC_ENV
from sacflow.machine.resources import available_memory
from sacflow.storage.case_file import load_case
from sacflow.storage.run_reader import completed_steps, is_complete, open_run

ROOT = Path(__file__).resolve().parents[1]
SMOKE = ROOT / "configs" / "campaign-smoke.toml"
HERTZ = ROOT / "configs" / "hertz-elastic.toml"
TESTS = Path(__file__).resolve().parent


# --------------------------------------------------------------------------- fake simulations
class FakeSimulation:
    """Honours the Simulation contract with reproducible fake states; optional sleep per step.

    Fails with a ConvergenceError at step 1 when the case's load is ``fail_load``.
    """

    def __init__(self, case: Case, sleep: float = 0.0, fail_load: float | None = None) -> None:
        self.case = case
        self.coords = make_coords(case)
        self.total_steps = sum(getattr(s, "increments", 0) for s in case.load_path)
        self.sleep = sleep
        self.fail = fail_load is not None and case.max_load == fail_load

    def run(self):
        for step in range(self.total_steps):
            time.sleep(self.sleep)
            if self.fail and step == 1:
                raise ConvergenceError("coupling", step, 2e-3, 1e-6, iterations=200)
            yield make_state(step, self.coords, volume=step % 2 == 0)


def fake_simulation(case: Case) -> FakeSimulation:
    return FakeSimulation(case)


def failing_simulation(case: Case) -> FakeSimulation:
    """The case at 0.65 N does not converge at step 1."""
    return FakeSimulation(case, fail_load=0.65)


def dying_simulation(case: Case) -> FakeSimulation:
    """The worker process dies (as on out-of-memory) on the case at 0.65 N, R = 100 µm."""
    if case.max_load == 0.65 and case.counterbody.radius == 1e-4:
        os._exit(3)
    return FakeSimulation(case)


def slow_simulation(case: Case) -> FakeSimulation:
    return FakeSimulation(case, sleep=float(os.environ.get("SACFLOW_TEST_SLEEP", "0.3")))


# --------------------------------------------------------------------------- helpers
def write(folder: Path, text: str, name: str = "study.toml") -> Path:
    path = folder / name
    path.write_text(text)
    return path


def campaign_text(sweep: str, base: str = 'base = "base.toml"', name: str = "study") -> str:
    return f'name = "{name}"\n{base}\n{sweep}\n'


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    """A folder holding ``base.toml`` (the shipped Hertz case at 16 x 16 x 3 cells)."""
    text = HERTZ.read_text()
    text = re.sub(r"(?m)^nx = .*$", "nx = 16", text)
    text = re.sub(r"(?m)^ny = .*$", "ny = 16", text)
    text = re.sub(r"(?m)^nz = .*$", "nz = 3", text)
    (tmp_path / "base.toml").write_text(text)
    return tmp_path


def fake_campaign(folder: Path, increments: int = 3, name: str = "fake") -> Path:
    """Four cases (two loads x two radii) of ``increments`` steps, on a copy of base.toml."""
    base = (folder / "base.toml").read_text()
    base = re.sub(r"(?m)^increments = .*$", f"increments = {increments}", base)
    (folder / f"{name}-base.toml").write_text(base)
    sweep = (
        '[[sweep]]\nmode = "product"\n'
        'parameters = { "load_path.0.to" = [0.19, 0.65], "counterbody.radius" = [1e-4, 2e-4] }'
    )
    text = campaign_text(sweep, base=f'base = "{name}-base.toml"', name=name)
    return write(folder, text, f"{name}.toml")


def manifest(out: Path, name: str) -> dict:
    return json.loads((out / f"{name}.manifest.json").read_text())


def statuses(out: Path, name: str) -> dict[str, str]:
    return {c["name"]: c["status"] for c in manifest(out, name)["cases"]}


def assert_same_runs(a: Path, b: Path) -> None:
    """Same data variables and values (bitwise), same case, both complete."""
    da, db = open_run(a), open_run(b)
    assert da.attrs["complete"] == db.attrs["complete"] == 1, f"{a.name} complete"
    assert da.attrs["case_id"] == db.attrs["case_id"], a.name
    assert sorted(da.data_vars) == sorted(db.data_vars), a.name
    for name in da.data_vars:
        np.testing.assert_array_equal(da[name].values, db[name].values, err_msg=f"{a.name}: {name}")


def run_serially(campaign_path: Path, out: Path, factory=None) -> list[Path]:
    """The campaign's cases one by one with runner.run_case, single-threaded FFTs as in a
    campaign worker."""
    cases = expand_campaign(load_campaign(campaign_path))
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("SACFLOW_FFT_THREADS", "1")
        for c in cases:
            runner.run_case(c.case, out, progress=False, simulation_factory=factory)
    return [out / f"{c.name}.nc" for c in cases]


@pytest.fixture(scope="module")
def shared_cluster():
    """Address of one local cluster of 2 workers (sacflow's: forked, single-threaded), shared by
    the tests that need some cluster but do not test how the local cluster starts or restarts
    its workers; they pass it to ``run_campaign`` as ``scheduler`` (``--scheduler``)."""
    with cluster_module.connect(None, 2, 2) as client:
        yield client.scheduler.address


@pytest.fixture(scope="module")
def smoke_serial(tmp_path_factory) -> list[Path]:
    """The smoke campaign's run files, computed one by one (real solver)."""
    return run_serially(SMOKE, tmp_path_factory.mktemp("serial"))


# --------------------------------------------------------------------------- expansion
def test_product_expansion_names_and_ids():
    cases = expand_campaign(load_campaign(SMOKE))
    loads, radii = [0.19, 0.4, 0.65], [105e-6, 200e-6]
    assert [(c.case.max_load, c.case.counterbody.radius) for c in cases] == [
        (w, r) for w in loads for r in radii
    ], "product: the first parameter varies slowest"
    assert [c.index for c in cases] == list(range(1, 7))
    names = [c.name for c in cases]
    assert names[0] == "campaign-smoke-to0.19-radius0.000105"
    assert len(set(names)) == len(names), "names are unique"
    assert all(re.match(NAME_PATTERN, n) for n in names), "names are file-name safe"
    assert names == [c.name for c in expand_campaign(load_campaign(SMOKE))], "deterministic"
    for c in cases:
        identity = json.dumps(c.case.identity(), sort_keys=True, separators=(",", ":"))
        digest = hashlib.sha256(identity.encode()).hexdigest()[:12]
        assert c.case_id == c.case.case_id == digest
        assert c.parameters == {
            "load_path.0.to": c.case.max_load,
            "counterbody.radius": c.case.counterbody.radius,
        }
        assert "load_path.0.to=" in c.label()
    assert len({c.case_id for c in cases}) == 6
    assert all(c.case.grid.nx == 16 and c.case.body.hardening.law == "elastic" for c in cases)


def test_zip_and_blocks_combine_as_a_product(folder):
    sweep = """
[[sweep]]
mode = "zip"
parameters = { "load_path.0.to" = [0.19, 0.4, 0.65], "load_path.0.increments" = [1, 2, 3] }
[[sweep]]
mode = "product"
parameters = { "grid.nz" = [2, 4] }
"""
    cases = expand_campaign(load_campaign(write(folder, campaign_text(sweep))))
    got = [(c.case.max_load, c.case.load_path[0].increments, c.case.grid.nz) for c in cases]
    assert got == [(0.19, 1, 2), (0.19, 1, 4), (0.4, 2, 2), (0.4, 2, 4), (0.65, 3, 2), (0.65, 3, 4)]
    assert cases[0].name == "study-to0.19-increments1-nz2"


def test_base_file_is_relative_to_the_campaign_and_set_applies_to_the_base(folder, monkeypatch):
    sweep = '[[sweep]]\nmode = "product"\nparameters = { "grid.nx" = [16, 32] }'
    path = write(folder, campaign_text(sweep))
    monkeypatch.chdir(folder.parent)
    campaign = load_campaign(path, ["grid.nz=5", 'description="set"'])
    cases = expand_campaign(campaign)
    assert [c.case.grid.nx for c in cases] == [16, 32]
    assert all(c.case.grid.nz == 5 and c.case.description == "set" for c in cases)
    assert cases[0].case.counterbody.radius == 105e-6, "values from base.toml"
    reference = load_case(folder / "base.toml", ["grid.nz=5", 'description="set"', 'name="x"'])
    assert cases[0].case.model_copy(update={"name": "x"}) == reference


def test_case_names_are_short_unique_and_safe():
    rows = [{"body.E": 2.1e11, "counterbody.E": 2e-5}, {"body.E": 2.1e11, "counterbody.E": 1e20}]
    assert case_names("c", rows) == [
        "c-body.E210000000000-counterbody.E2e-5",
        "c-body.E210000000000-counterbody.E1e20",
    ]
    rows = [{"load_path.0.to": 1.0, "load_path.1.to": 0.5, "grid.nx": 32}]
    assert case_names("c", rows) == ["c-load_path.0.to1-load_path.1.to0.5-nx32"]
    rows = [{"description": "a b"}, {"description": "a/b"}, {"description": "ok"}]
    names = case_names("c", rows)
    assert names[2] == "c-descriptionok" and len(set(names)) == 3, "collisions get a digest"
    assert all(re.match(NAME_PATTERN, n) for n in names)
    rows = [{"body.radii": [1e-3, float("inf")], "body.hardening": {"law": "elastic"}}]
    (name,) = case_names("c", rows)
    assert name.startswith("c-radii0.001xinf-hardeningh") and re.match(NAME_PATTERN, name)
    long = case_names("c", [{"description": "x" * 300}])[0]
    assert len(long) <= campaign_module.MAX_NAME and re.match(NAME_PATTERN, long)
    assert long != case_names("c", [{"description": "x" * 301}])[0]


# --------------------------------------------------------------------------- invalid campaigns
def config_error(path: Path) -> str:
    with pytest.raises(ConfigError) as info:
        load_campaign(path)
    message = str(info.value)
    assert message.startswith(f"{path}: invalid campaign"), message
    assert len(message.splitlines()) <= campaign_module.MAX_PROBLEMS + 2, "one screen"
    return message


@pytest.mark.parametrize(
    ("sweep", "expected"),
    [
        (
            'mode = "zip"\nparameters = { "load_path.0.to" = [0.1, 0.2], "grid.nx" = [16] }',
            "sweep.0.parameters: zip needs lists of equal length "
            "(got load_path.0.to: 2, grid.nx: 1)",
        ),
        (
            'mode = "product"\nparameters = { "grid.nxx" = [16] }',
            "sweep.0.parameters.\"grid.nxx\": grid has no field 'nxx', did you mean 'nx'?",
        ),
        (
            'mode = "product"\nparameters = { "load_path.to" = [1.0] }',
            "sweep.0.parameters.\"load_path.to\": 'to' is not a list index (load_path is a "
            "list, indexed by whole numbers from 0; negative indices are not supported); use "
            "e.g. load_path.0",
        ),
        (
            'mode = "product"\nparameters = { "grid.nx.y" = [1] }',
            "grid.nx is a value, not a table",
        ),
        (
            'mode = "product"\nparameters = { "load_path.0.to" = [0.19, -1, 0.65] }',
            "case 2 (load_path.0.to=-1): load_path.0.to: must be > 0",
        ),
        (
            'mode = "product"\nparameters = { "load_path.3.to" = [0.19] }',
            "load_path.3.to: index 3 is out of range for load_path; it has 1 item: use index 0,",
        ),
        ('mode = "sum"\nparameters = { "grid.nx" = [16] }', "sweep.0.mode: must be 'product'"),
        (
            'mode = "zip"\nparameters = { "grid.nx" = 16 }',
            'sweep.0.parameters."grid.nx": expected a list',
        ),
        ('mode = "zip"\nparameters = { "grid.nx" = [16, 16] }', "cases 1 and 2 have the same"),
        ('mode = "zip"\nparameters = { name = ["a"] }', '"name" cannot be swept'),
        ('mode = "zip"\nparameters = { grid = [{nx = 16}], "grid.nz" = [2] }', "overlaps"),
        ('mode = "zip"\nparameters = { }', "sweep.0.parameters: needs at least one parameter"),
    ],
)
def test_invalid_sweeps_name_the_field(folder, sweep, expected):
    message = config_error(write(folder, campaign_text(f"[[sweep]]\n{sweep}")))
    assert expected in message, message


def test_invalid_campaign_fields_and_base(folder):
    sweep = '[[sweep]]\nmode = "product"\nparameters = { "grid.nx" = [16] }'
    message = config_error(write(folder, campaign_text(sweep, base='base = "nowhere.toml"')))
    assert "base: case file 'nowhere.toml' not found" in message
    assert str(folder / "nowhere.toml") in message, "says where it looked"

    text = 'name = "bad name"\nbase = 3\nsweeps = 1\n' + sweep
    message = config_error(write(folder, text))
    assert "name: must start with a letter or digit" in message
    assert "base: expected a case file path or an inline [base] table; got 3" in message
    assert "sweeps: unknown key, did you mean 'sweep'?" in message
    assert len(message.splitlines()) == 4, "one line per problem, no duplicates"

    message = config_error(write(folder, 'name = "x"\nbase = "base.toml"\n'))
    assert "sweep: required field missing" in message


def test_a_problem_of_every_case_is_reported_once(folder):
    sweep = '[[sweep]]\nmode = "product"\nparameters = { "load_path.0.to" = [0.1, 0.2, -3] }'
    path = write(folder, campaign_text(sweep))
    with pytest.raises(ConfigError) as info:
        load_campaign(path, ["grid.nx=4"])
    lines = str(info.value).splitlines()
    assert lines[1].strip().startswith("base (all cases): grid.nx: must be in [8, 65536]"), lines
    assert sum("grid.nx" in line for line in lines) == 1
    assert any(line.strip().startswith("case 3 (load_path.0.to=-3):") for line in lines)


def test_cli_reports_a_bad_campaign_without_traceback(folder, capsys):
    sweep = '[[sweep]]\nmode = "zip"\nparameters = { "grid.nz" = [2, 3], "grid.nx" = [16] }'
    path = write(folder, campaign_text(sweep))
    assert main(["campaign", str(path), "--out", str(folder / "out")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "zip needs lists of equal length" in err
    assert "Traceback" not in err and not (folder / "out").exists()
    assert main(["campaign", str(SMOKE), "--out", str(folder / "out"), "--workers", "0"]) == 2
    assert "--workers" in capsys.readouterr().err


# --------------------------------------------------------------------------- running (dask)
def test_smoke_campaign_matches_hertz(smoke_serial):
    """Each shipped example checks one number: p_max and approach of every case vs Hertz."""
    cases = {c.name: c.case for c in expand_campaign(load_campaign(SMOKE))}
    for path in smoke_serial:
        ds, hertz = open_run(path), cases[path.stem].hertz()
        np.testing.assert_allclose(
            ds.max_pressure.values[-1], hertz.p0, rtol=0.05, err_msg=f"{path.stem}: p_max"
        )
        np.testing.assert_allclose(
            ds.approach.values[-1], hertz.approach, rtol=0.05, err_msg=f"{path.stem}: approach"
        )


def test_cluster_matches_serial_runs_and_skips_on_rerun(tmp_path, smoke_serial, shared_cluster):
    """Real solver: 2 workers give the files run_case gives one by one; a re-run runs nothing."""
    out = tmp_path / "campaign"
    summary = run_campaign(load_campaign(SMOKE), out, scheduler=shared_cluster, progress=False)
    assert summary.counts() == {"done": 6, "skipped": 0, "failed": 0}, summary.table()
    assert summary.workers == 2 and not summary.failed
    assert [p.name for p in sorted(out.glob("*.nc"))] == sorted(p.name for p in summary.paths)
    data = manifest(out, "campaign-smoke")
    assert [c["status"] for c in data["cases"]] == ["done"] * 6
    assert all(c["steps"] == 1 and c["error"] is None for c in data["cases"])
    assert data["cases"][0]["parameters"] == {"load_path.0.to": 0.19, "counterbody.radius": 105e-6}

    for path in smoke_serial:
        assert_same_runs(out / path.name, path)

    mtimes = {p: p.stat().st_mtime_ns for p in out.glob("*.nc")}
    again = run_campaign(load_campaign(SMOKE), out, scheduler=shared_cluster, progress=False)
    assert again.counts() == {"done": 0, "skipped": 6, "failed": 0} and again.workers == 0
    assert {p: p.stat().st_mtime_ns for p in out.glob("*.nc")} == mtimes, "nothing rewritten"
    assert set(statuses(out, "campaign-smoke").values()) == {"skipped"}
    assert "6 skipped" in again.table()


def test_failed_case_is_recorded_others_finish_exit_code_1(
    folder, capsys, monkeypatch, shared_cluster
):
    """Through the CLI: one case raises, the others finish; a fixed re-run resumes that one."""
    path = fake_campaign(folder)
    out = folder / "out"
    monkeypatch.setattr(
        campaign_module,
        "run_campaign",
        functools.partial(run_campaign, simulation_factory=failing_simulation),
    )
    args = ["campaign", str(path), "--out", str(out), "--scheduler", shared_cluster,
            "--no-progress"]
    assert main(args) == 1
    captured = capsys.readouterr()
    data = manifest(out, "fake")
    failed = [c for c in data["cases"] if c["status"] == "failed"]
    assert [c["parameters"]["load_path.0.to"] for c in failed] == [0.65, 0.65]
    assert all("coupling iteration did not converge at step 1" in c["error"] for c in failed)
    assert all(c["wall_time"] is not None and c["traceback"] is None for c in failed)
    assert data["counts"] == {"done": 2, "failed": 2}
    for c in data["cases"]:
        assert (out / c["path"]).exists() == (c["status"] == "done"), c["name"]
    assert "2 done, 0 skipped, 2 failed" in captured.out
    rows = {line.split()[1]: line for line in captured.out.splitlines()[1:-1]}
    assert all(" failed " in rows[c["name"]] for c in failed), captured.out
    assert f"error: {failed[0]['name']}: coupling iteration" in captured.err

    monkeypatch.setattr(
        campaign_module,
        "run_campaign",
        functools.partial(run_campaign, simulation_factory=fake_simulation),
    )
    assert main(args) == 0
    data = manifest(out, "fake")
    by_status = {c["name"]: (c["status"], c["resumed_steps"]) for c in data["cases"]}
    for c in failed:
        assert by_status[c["name"]] == ("done", 1), "resumed after the stored step"
    assert sorted(s for s, _ in by_status.values()) == ["done", "done", "skipped", "skipped"]


def worker_threads() -> dict:
    """Runs in a worker: its thread settings and whether the solver was imported before."""
    from threadpoolctl import threadpool_info

    names = [*campaign_module.WORKER_ENV, *MALLOC_ENV]
    return {
        "env": {name: os.environ.get(name) for name in names},
        "pools": {(p["user_api"], p["num_threads"]) for p in threadpool_info()},
        "solver": "sacflow.solver.simulation" in sys.modules,
        "profiler": __import__("dask").config.get("distributed.worker.profile.enabled"),
        "frozen": __import__("gc").get_freeze_count(),
    }


def test_local_cluster_workers_are_single_threaded_and_preloaded():
    """One thread per library in each worker; the fork server imported the solver once."""
    before = {
        name: os.environ.get(name)
        for name in (campaign_module.FFT_THREADS_ENV, *campaign_module.WORKER_ENV, *MALLOC_ENV)
    }
    with cluster_module.connect(None, 2, 2) as client:
        info = client.run(worker_threads)
    assert len(info) == 2
    for worker in info.values():
        assert worker["env"] == {**campaign_module.WORKER_ENV, **MALLOC_ENV}
        assert {n for api, n in worker["pools"] if api in ("blas", "openmp")} == {1}, worker
        if "forkserver" in multiprocessing.get_all_start_methods():
            assert worker["solver"], "forked from a server that imported the solver"
            assert worker["frozen"] > 10_000, "the server froze its imported objects"
        assert worker["profiler"] is False, "the statistical profiler is off"
    after = {name: os.environ.get(name) for name in before}
    assert after == before, "this process's environment is left as it was"


def test_local_cluster_keeps_sacflow_preload_list():
    """distributed's first nanny replaces the fork server's preload list with its own (read only
    if the fork server starts again); the local cluster sets sacflow's back. The campaign
    process itself does not import the solver's FFT modules."""
    if "forkserver" not in multiprocessing.get_all_start_methods():
        pytest.skip("no fork server on this platform")
    code = (
        "import sys\n"
        "from multiprocessing import forkserver\n"
        "from sacflow.campaign import FORK_SERVER_LAST, WORKER_PRELOAD\n"
        "from sacflow.campaign.cluster import connect\n"
        "calls, set_preload = [], forkserver.set_forkserver_preload\n"
        "def record(names):\n"
        "    calls.append(list(names))\n"
        "    set_preload(names)\n"
        "forkserver.set_forkserver_preload = record\n"
        "if __name__ == '__main__':\n"
        "    with connect(None, 1, 1) as client:\n"
        "        assert client.submit(sum, [1, 2]).result() == 3\n"
        "    print(len(calls) >= 2, calls[-1][-1] == FORK_SERVER_LAST,\n"
        "          set(WORKER_PRELOAD) <= set(calls[-1]), 'scipy.fft' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.split() == ["True", "True", "True", "False"]


def test_fork_server_preloads_plasticity_only_for_plastic_campaigns(folder, monkeypatch):
    """The fork server imports eigenstrain operators and numba only when a case needs them."""
    from multiprocessing import forkserver

    if "forkserver" not in multiprocessing.get_all_start_methods():
        pytest.skip("no fork server on this platform")
    preloads: list[list[str]] = []
    monkeypatch.setattr(forkserver, "set_forkserver_preload", preloads.append)
    monkeypatch.setattr(forkserver, "ensure_running", lambda: None)
    monkeypatch.setattr(cluster_module, "connect", _no_client)
    monkeypatch.setattr(cluster_module, "_preload", [])  # this process's real list stays as it is
    elastic = '[[sweep]]\nmode = "zip"\nparameters = { "load_path.0.to" = [0.2, 0.3] }'
    mixed = (
        '[[sweep]]\nmode = "zip"\nparameters = { "body.hardening" = '
        '[{ law = "elastic" }, { law = "perfectly_plastic", yield_stress = 2e9 }] }'
    )
    for name, sweep in (("elastic", elastic), ("mixed", mixed)):
        path = write(folder, campaign_text(sweep, name=name), f"{name}.toml")
        with pytest.raises(_Stop):  # after the fork server's start, at the cluster's
            run_campaign(load_campaign(path), folder / name, workers=1, progress=False)
    elastic_list, mixed_list = preloads
    assert set(campaign_module.WORKER_PRELOAD) <= set(elastic_list)
    assert not set(campaign_module.PLASTIC_PRELOAD) & set(elastic_list)
    plastic = campaign_module.WORKER_PRELOAD + campaign_module.PLASTIC_PRELOAD
    assert set(plastic) | {campaign_module.FORK_SERVER_LAST} == set(mixed_list)
    assert elastic_list[-1] == mixed_list[-1] == campaign_module.FORK_SERVER_LAST
    for module in (*campaign_module.PLASTIC_PRELOAD, campaign_module.FORK_SERVER_LAST):
        assert importlib.util.find_spec(module) is not None, module


@contextlib.contextmanager
def _no_client(*args):
    """Stands in for the dask client: a campaign whose cases are never submitted."""
    raise _Stop
    yield


class _Stop(Exception):
    pass


def test_longest_cases_are_submitted_first(folder):
    """One worker runs the cases in submission order: the finer grid (more cells) first.

    Its own local cluster of one worker: also run_campaign's path that starts a local cluster."""
    base = (folder / "base.toml").read_text()
    (folder / "fake-base.toml").write_text(base)
    sweep = '[[sweep]]\nmode = "zip"\nparameters = { "grid.nx" = [16, 24, 32] }'
    path = write(folder, campaign_text(sweep, base='base = "fake-base.toml"', name="order"))
    out = folder / "out"
    summary = run_campaign(
        load_campaign(path), out, workers=1, progress=False, simulation_factory=fake_simulation
    )
    assert summary.counts()["done"] == 3, summary.table()
    finished = sorted(out.glob("*.nc"), key=lambda p: p.stat().st_mtime_ns)
    assert [p.stem for p in finished] == ["order-nx32", "order-nx24", "order-nx16"]


def test_unexpected_errors_keep_their_traceback(folder, shared_cluster):
    out = folder / "out"
    summary = run_campaign(
        load_campaign(fake_campaign(folder)),
        out,
        scheduler=shared_cluster,
        progress=False,
        simulation_factory=broken_simulation,
    )
    assert len(summary.failed) == 4
    record = summary.failed[0]
    assert record.error == "ZeroDivisionError: division by zero"
    assert "broken_simulation" in record.traceback


def broken_simulation(case: Case) -> FakeSimulation:
    return 1 / 0


@pytest.mark.slow
def test_a_dying_worker_fails_its_case_only(folder):
    out = folder / "out"
    summary = run_campaign(
        load_campaign(fake_campaign(folder)),
        out,
        workers=2,
        progress=False,
        simulation_factory=dying_simulation,
    )
    assert summary.counts() == {"done": 3, "skipped": 0, "failed": 1}, summary.table()
    (record,) = summary.failed
    assert record.parameters == {"load_path.0.to": 0.65, "counterbody.radius": 1e-4}
    assert record.error.startswith(campaign_module.WORKER_DIED) and "KilledWorker" in record.error
    assert statuses(out, "fake")[record.name] == "failed"


def _campaign_process(path: Path, out: Path) -> subprocess.Popen:
    """``sacflow campaign`` in a subprocess, with the slow fake simulation."""
    script = (
        "import functools, sys\n"
        "import sacflow.campaign as c, test_campaign as t\n"
        "c.run_campaign = functools.partial(c.run_campaign, simulation_factory=t.slow_simulation)\n"
        "from sacflow.cli import main\n"
        "sys.exit(main(sys.argv[1:]))\n"
    )
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(TESTS), os.environ.get("PYTHONPATH", "")]),
    }
    args = ["campaign", str(path), "--out", str(out), "--workers", "2", "--no-progress"]
    return subprocess.Popen(
        [sys.executable, "-c", script, *args],
        env=env,
        cwd=path.parent,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


@pytest.mark.slow
def test_sigkill_then_rerun_completes_without_recomputing(folder):
    """Kill the campaign process part-way (SIGKILL); the re-run finishes the rest only."""
    path = fake_campaign(folder, increments=4)
    case_ids = {c.name: c.case_id for c in expand_campaign(load_campaign(path))}
    out = folder / "out"
    proc = _campaign_process(path, out)
    deadline = time.monotonic() + 90
    while time.monotonic() < deadline:  # the manifest appears (atomically) after the folder
        written = (out / "fake.manifest.json").exists()
        done = [n for n, s in statuses(out, "fake").items() if s == "done"] if written else []
        if done or proc.poll() is not None:
            break
        time.sleep(0.05)
    assert proc.poll() is None, f"finished before the kill: {proc.communicate()}"
    children = _children(proc.pid)
    proc.send_signal(signal.SIGKILL)
    proc.communicate()
    _, alive = psutil.wait_procs(children, timeout=20)
    for child in alive:
        child.kill()
    assert not alive, "the workers stop when the campaign process dies"

    # Finished: a complete file (the manifest may lag: killed before recording the last one).
    before = statuses(out, "fake")
    finished = {n for n in before if is_complete(out / f"{n}.nc", case_ids[n])}
    assert {n for n, s in before.items() if s == "done"} <= finished, before
    assert 1 <= len(finished) < 4, before
    mtimes = {n: (out / f"{n}.nc").stat().st_mtime_ns for n in finished}
    stored = {n: completed_steps(out / f"{n}.nc") for n in before if n not in finished}
    for name in before:  # nothing corrupt: finished files and stored steps all open
        if name in finished:
            ds = open_run(out / f"{name}.nc")
            assert ds.attrs["complete"] == 1 and ds.sizes["step"] == 4, name
        elif stored[name]:
            ds = open_run(out / f"{name}.nc")
            assert ds.attrs["complete"] == 0 and ds.sizes["step"] == stored[name], name

    proc = _campaign_process(path, out)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 0, stderr
    data = manifest(out, "fake")
    for c in data["cases"]:
        if c["name"] in finished:
            assert c["status"] == "skipped", c
            assert (out / c["path"]).stat().st_mtime_ns == mtimes[c["name"]], "not recomputed"
        else:
            assert c["status"] == "done" and c["resumed_steps"] == stored[c["name"]], c
    assert not list(out.glob("*.parts")) and not list(out.glob(".*.tmp"))

    serial = run_serially(path, folder / "serial", factory=fake_simulation)
    for reference in serial:
        assert_same_runs(out / reference.name, reference)


# --------------------------------------------------------------------------- external cluster
def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _children(pid: int) -> list[psutil.Process]:
    try:
        return psutil.Process(pid).children(recursive=True)
    except psutil.NoSuchProcess:
        return []


@pytest.fixture
def dask_cluster():
    """``dask scheduler`` and ``dask worker`` (2 processes) on 127.0.0.1, as subprocesses."""
    from distributed import Client

    dask = shutil.which("dask")
    if dask is None:
        pytest.skip("the dask command line is not installed")
    address = f"tcp://127.0.0.1:{_free_port()}"
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL}
    procs = []
    try:
        procs.append(
            subprocess.Popen(
                [
                    dask,
                    "scheduler",
                    "--host",
                    "127.0.0.1",
                    "--port",
                    address.rsplit(":", 1)[1],
                    "--no-dashboard",
                ],
                **quiet,
            )
        )
        procs.append(
            subprocess.Popen(
                [
                    dask,
                    "worker",
                    address,
                    "--nworkers",
                    "2",
                    "--nthreads",
                    "1",
                    "--no-dashboard",
                    "--host",
                    "127.0.0.1",
                ],
                **quiet,
            )
        )
        with Client(address, timeout="30s") as client:
            client.wait_for_workers(2, timeout=60)
        yield address
    finally:  # SIGKILL: the worker processes exit with their parent; no graceful close
        tree = [p for proc in procs for p in _children(proc.pid)]
        for proc in procs:
            proc.kill()
            proc.wait()
        _, alive = psutil.wait_procs(tree, timeout=15)
        for leftover in alive:
            leftover.kill()


def test_external_scheduler_gives_the_same_results(tmp_path, dask_cluster, smoke_serial):
    out = tmp_path / "campaign"
    summary = run_campaign(load_campaign(SMOKE), out, scheduler=dask_cluster, progress=False)
    assert summary.counts()["done"] == 6 and summary.workers == 2, summary.table()
    for path in smoke_serial:
        assert_same_runs(out / path.name, path)


def test_workers_and_scheduler_exclude_each_other(tmp_path, capsys):
    args = ["campaign", str(SMOKE), "--out", str(tmp_path), "--scheduler", "tcp://127.0.0.1:1"]
    assert main([*args, "--workers", "2"]) == 2
    assert "--workers" in capsys.readouterr().err


@pytest.mark.slow
def test_unreachable_scheduler_is_a_clear_error(tmp_path, capsys):
    address = f"tcp://127.0.0.1:{_free_port()}"
    args = ["campaign", str(SMOKE), "--out", str(tmp_path), "--scheduler", address]
    assert main(args) == 1
    assert f"cannot connect to the dask scheduler at {address}" in capsys.readouterr().err


def test_campaign_never_overwrites_a_run_of_another_case(folder, shared_cluster):
    """Names holding other cases' runs: the re-run refuses, manifest and runs untouched (#31)."""
    base = (folder / "base.toml").read_text()
    (folder / "fake-base.toml").write_text(base)
    sweep = '[[sweep]]\nmode = "zip"\nparameters = { "grid.nx" = [16, 24] }'
    path = write(folder, campaign_text(sweep, base='base = "fake-base.toml"', name="keep"))
    out = folder / "out"
    first = run_campaign(load_campaign(path), out, scheduler=shared_cluster, progress=False,
                         simulation_factory=fake_simulation)
    assert first.counts()["done"] == 2, first.table()
    stored = (out / "keep-nx16.nc").read_bytes()
    manifest = first.manifest.read_bytes()

    # the sequence: the same campaign again with --set grid.nz=... (other case ids)
    with pytest.raises(CampaignConflictError) as caught:
        run_campaign(load_campaign(path, ["grid.nz=4"]), out, scheduler=shared_cluster,
                     progress=False, simulation_factory=fake_simulation)
    error = str(caught.value)
    assert "2 of 2 cases" in error and "grid.nz: 3 -> 4" in error and "--overwrite" in error
    assert "--out" in error and "keep-nx16.nc" in error
    assert first.manifest.read_bytes() == manifest and (out / "keep-nx16.nc").read_bytes() == stored
    opened = open_campaign(out)
    try:
        assert list(opened.summary["status"].values) == ["done", "done"]
        assert opened.fields["keep-nx16"].ds.sizes["x3"] == 3
    finally:
        opened.close()

    # the CLI says the same, exit code 2, no traceback
    main_args = ["campaign", str(path), "--out", str(out), "--scheduler", shared_cluster,
                 "--set", "grid.nz=4", "--no-progress"]
    assert main(main_args) == 2
    assert first.manifest.read_bytes() == manifest

    third = run_campaign(load_campaign(path, ["grid.nz=4"]), out, scheduler=shared_cluster,
                         progress=False, simulation_factory=fake_simulation, overwrite=True)
    assert third.counts()["done"] == 2, third.table()


def test_no_more_local_workers_than_cases_fit_in_memory():
    """Issue #31: as many single-threaded workers as the largest case fits in memory."""
    available = available_memory()
    with cluster_module.connect(None, None, 3, largest_task=int(0.6 * available)) as client:
        assert len(client.nthreads()) == 1, "two cases of 60 % of the memory do not fit"
        assert set(client.nthreads().values()) == {1}, "one case at a time"


def test_tasks_declare_their_memory_to_workers_declaring_theirs(folder):
    """A cluster of one's own, its workers declaring memory: tasks declare their estimates,
    at most what a worker has (a task asking more would wait for ever: here every case's
    estimate is above the 1 MB declared, so the cases run one at a time and finish)."""
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=2, processes=True,
                      dashboard_address=None,
                      resources={cluster_module.MEMORY_RESOURCE: 1e6}) as local, \
            Client(local) as client:
        assert cluster_module.worker_memory(client) == 1e6
        summary = run_campaign(load_campaign(fake_campaign(folder)), folder / "out",
                               scheduler=local.scheduler_address, progress=False,
                               simulation_factory=fake_simulation)
        assert summary.counts()["done"] == 4, summary.table()


def test_tasks_declare_memory_only_where_every_worker_declares_it():
    def client(*resources):
        workers = {str(i): {"resources": r} for i, r in enumerate(resources)}
        return SimpleNamespace(scheduler_info=lambda: {"workers": workers})

    assert cluster_module.worker_memory(client({"memory": 4e9}, {"memory": 2e9})) == 2e9
    assert cluster_module.worker_memory(client({"memory": 4e9}, {})) is None
    assert cluster_module.worker_memory(client()) is None
