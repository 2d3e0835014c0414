"""Runner and command line with a fake simulation: run files, resume, skip, exit codes."""

from __future__ import annotations

import json
import pickle
import re
from pathlib import Path

import pytest
from test_store import make_coords, make_state

import sacflow
from sacflow import runner
from sacflow.cli import main
from sacflow.config.schema import Case
from sacflow.errors import ConvergenceError, SacflowError
from sacflow.storage.run_reader import completed_steps

HERTZ = Path(__file__).resolve().parents[1] / "configs" / "hertz-elastic.toml"
SMALL = ["grid.nx=16", "grid.ny=16", "grid.nz=3", "load_path.0.increments=4"]


class FakeSimulation:
    """Honours the Simulation contract; fails at step ``fail_at`` if given."""

    def __init__(self, case: Case, fail_at: int | None = None) -> None:
        self.case = case
        self.coords = make_coords(case)
        self.total_steps = sum(getattr(s, "increments", 0) for s in case.load_path)
        self.fail_at = fail_at

    def run(self):
        for step in range(self.total_steps):
            if step == self.fail_at:
                raise ConvergenceError("coupling", step, 1e-3, 1e-6, iterations=200)
            yield make_state(step, self.coords, volume=step % 2 == 0)


def failing(case: Case) -> FakeSimulation:
    return FakeSimulation(case, fail_at=2)


@pytest.fixture
def small_case() -> Case:
    return sacflow.load_case(HERTZ, SMALL)


def test_run_case_resumes_skips_and_restarts(tmp_path, small_case):
    path = tmp_path / "hertz-elastic.nc"
    with pytest.raises(ConvergenceError, match="step 2"):
        runner.run_case(small_case, tmp_path, progress=False, simulation_factory=failing)
    assert not path.exists() and completed_steps(path, small_case.case_id) == 2
    assert sacflow.open_run(path).attrs["complete"] == 0

    summary = runner.run_case(
        small_case, tmp_path, progress=True, simulation_factory=FakeSimulation
    )
    assert (summary.steps, summary.resumed_steps, summary.skipped) == (4, 2, False)
    assert summary.path == path and summary.case_id == small_case.case_id
    assert summary.load == pytest.approx(0.4)
    ds = sacflow.open_run(path)
    assert ds.sizes["step"] == 4 and ds.attrs["complete"] == 1
    assert list(ds.step.values) == [0, 1, 2, 3]

    again = runner.run_case(small_case, tmp_path, progress=False, simulation_factory=failing)
    assert again.skipped and again.steps == 4, "a finished run is not run again"
    fresh = runner.run_case(
        small_case, tmp_path, progress=False, simulation_factory=FakeSimulation, resume=False
    )
    assert fresh.resumed_steps == 0 and not fresh.skipped and fresh.steps == 4
    assert "4 steps" in fresh.line() and "hertz-elastic" in fresh.line()


def test_cli_run_writes_a_run_file(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(runner, "_default_factory", lambda: FakeSimulation)
    sets = [f"--set={item}" for item in SMALL]
    assert main(["run", str(HERTZ), "--out", str(tmp_path), "--no-progress", *sets]) == 0
    out = capsys.readouterr().out.splitlines()
    assert len(out) == 1 and out[0].startswith("hertz-elastic (") and "4 steps" in out[0]
    ds = sacflow.open_run(tmp_path / "hertz-elastic.nc")
    assert ds.sizes["step"] == 4 and ds.pressure.attrs["units"] == "Pa"


def test_cli_run_failure_exits_1_without_traceback(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(runner, "_default_factory", lambda: failing)
    sets = [f"--set={item}" for item in SMALL]
    assert main(["run", str(HERTZ), "--out", str(tmp_path), "--no-progress", *sets]) == 1
    err = capsys.readouterr().err
    assert err.startswith("error: hertz-elastic: coupling iteration did not converge at step 2")
    assert "Traceback" not in err


def test_cli_validate(capsys):
    assert main(["validate", str(HERTZ)]) == 0
    out = capsys.readouterr().out.strip()
    assert re.fullmatch(
        r"OK hertz-elastic \([0-9a-f]{12}\): a = 6\.053 µm, p0 = 8\.470 GPa, "
        r"window 128 x 128 cells, memory [0-9.]+ MiB \(largest: .+\)",
        out,
    ), out


def test_cli_schema_prints_valid_json(capsys):
    assert main(["schema"]) == 0

    def reject(constant: str) -> None:
        raise ValueError(f"non-standard JSON constant {constant}")

    schema = json.loads(capsys.readouterr().out, parse_constant=reject)
    assert {"body", "counterbody", "grid", "load_path"} <= set(schema["properties"])
    assert schema["additionalProperties"] is False


def test_convergence_error():
    exc = ConvergenceError("plasticity", 7, 2.5e-4, 1e-6, iterations=500)
    assert isinstance(exc, SacflowError)
    assert (exc.what, exc.step, exc.residual, exc.tolerance) == ("plasticity", 7, 2.5e-4, 1e-6)
    assert "step 7" in str(exc) and "plasticity_max_iterations" in str(exc)
    copy = pickle.loads(pickle.dumps(exc))
    assert str(copy) == str(exc) and copy.step == 7
