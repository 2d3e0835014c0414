"""Runs are never lost or silently wrong: true resume, damaged parts, identity, approach at W = 0.

Each test here failed on the code before true resume (replay from step 0, silent overwrite,
approach 0 after unloading, contact stopped on the pressure change).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

import sacflow
from sacflow import runner
from sacflow.cli import main
from sacflow.config.solver_inputs import solver_inputs
from sacflow.errors import ConvergenceError
from sacflow.solver.simulation import Simulation
from sacflow.storage.run_parts import parts_dir
from sacflow.storage.run_reader import run_info
from sacflow.storage.run_writer import RunExistsError

ROOT = Path(__file__).resolve().parents[1]
INDENT = ROOT / "configs" / "nanoindentation-650mN.toml"
HERTZ = ROOT / "configs" / "hertz-elastic.toml"
#: The 650 mN indentation at a tiny grid: 4 load and 2 unload increments (6 steps, ~3 s),
#: its fixed points converged far below the default 1e-6. A resumed step starts from the stored
#: state, equal to the uninterrupted run's to round-off, not bit for bit (the residual stress is
#: recomputed); a fixed point stopped at 1e-6 can then stop one iteration apart and differ by
#: about 1e-9 (measured with the config's ``solver.traction_beyond_box``), where the comparison
#: below is to round-off. Converged to 1e-10 the two runs agreed to about 3e-12 on one machine;
#: on another (an AMD EPYC) the contact solve, stopped at its default relative gap error of
#: 1e-10, left the peak-load pressure 1.3e-9 apart: it is converged to 1e-13 too.
TINY_INDENT = ["grid.nx=16", "grid.ny=16", "grid.nz=8", "load_path.0.increments=4",
               "load_path.1.increments=2", "solver.plasticity_tolerance=1e-10",
               "solver.coupling_tolerance=1e-10", "solver.contact_tolerance=1e-13"]
TINY_HERTZ = ["grid.nx=16", "grid.ny=16", "grid.nz=3"]
#: Fields compared between a resumed and an uninterrupted run.
COMPARED = ("load", "approach", "max_pressure", "pressure", "gap", "residual_displacement",
            "surface_displacement", "plastic_strain", "equivalent_plastic_strain",
            "residual_stress", "stress", "yield_stress")


class Interrupted(Simulation):
    """The real simulation, interrupted (as by Ctrl-C) after ``stop_after`` states."""

    stop_after = 3

    @classmethod
    def of(cls, case):
        """The simulation factory: this simulation of ``case``."""
        return cls(solver_inputs(case))

    def run(self, start: int = 0):
        for count, state in enumerate(super().run(start)):
            if count == self.stop_after:
                raise KeyboardInterrupt
            yield state


@pytest.fixture(scope="module")
def indent_case():
    return sacflow.load_case(INDENT, TINY_INDENT)


@pytest.fixture(scope="module")
def uninterrupted(indent_case, tmp_path_factory):
    out = tmp_path_factory.mktemp("uninterrupted")
    summary = runner.run_case(indent_case, out, progress=False)
    return sacflow.open_run(summary.path)


@pytest.fixture
def solved_steps(monkeypatch):
    """Count the increments the solver computes."""
    counted: list[int] = []
    original = Simulation.solve_increment

    def solve_increment(self, step, plan):
        if not counted or counted[-1] != step:  # a step cut back is one step
            counted.append(step)
        return original(self, step, plan)

    monkeypatch.setattr(Simulation, "solve_increment", solve_increment)
    return counted


def interrupt(case, out: Path, after: int) -> Path:
    """Run ``case`` into ``out`` and interrupt it after ``after`` stored steps."""
    factory = type("Stop", (Interrupted,), {"stop_after": after}).of
    with pytest.raises(KeyboardInterrupt):
        runner.run_case(case, out, progress=False, simulation_factory=factory)
    path = out / f"{case.name}.nc"
    assert not path.exists() and run_info(path).steps == after
    return path


def assert_same_run(resumed, reference) -> None:
    """Every compared field equal to round-off (the restored state is the whole solver state).

    The tolerance, 1e-9 of each field's largest value, is far below the solver tolerances of
    the default cases (contact 1e-10 relative gap error; plasticity and coupling 1e-6), so a
    resume that restored less than the full state (a warm start, the first-contact offset, the
    residual fields) would show; the tiny cases here converge their fixed points to 1e-10
    (:data:`TINY_INDENT`). A field the file stores in float32 (``output.volume_precision``)
    may also be one float32 rounding apart: its float64 values, equal to round-off, can fall
    either side of a rounding boundary.
    """
    assert resumed.sizes["step"] == reference.sizes["step"]
    for name in COMPARED:
        a = np.asarray(resumed[name].values, dtype=float)
        b = np.asarray(reference[name].values, dtype=float)
        scale = float(np.nanmax(np.abs(b[np.isfinite(b)]), initial=0.0)) or 1.0
        if reference[name].dtype != np.float32:
            assert_allclose(a, b, rtol=0, atol=1e-9 * scale, equal_nan=True,
                            err_msg=f"{name} of the resumed run")
            continue
        rounding = np.spacing(np.abs(reference[name].values)).astype(float)
        apart = np.abs(a - b) > np.maximum(1e-9 * scale, rounding)
        apart &= ~(np.isnan(a) & np.isnan(b))
        assert not apart.any(), (f"{name} of the resumed run: {int(apart.sum())} values more "
                                 f"than one float32 rounding apart")


def test_resume_goes_on_from_the_stored_state(indent_case, uninterrupted, tmp_path,
                                              solved_steps):
    path = interrupt(indent_case, tmp_path, after=3)
    solved_steps.clear()
    summary = runner.run_case(indent_case, tmp_path, progress=False)
    assert solved_steps == [3, 4, 5], "only the steps after the stored ones are solved"
    assert summary.resumed_steps == 3 and summary.steps == 6 and not summary.skipped
    assert_same_run(sacflow.open_run(path), uninterrupted)


def test_damaged_part_is_named_dropped_and_recomputed(indent_case, uninterrupted, tmp_path,
                                                      solved_steps, capsys):
    path = interrupt(indent_case, tmp_path, after=4)
    damaged = next(parts_dir(path).glob("step-000002-*.nc"))
    data = bytearray(damaged.read_bytes())
    data[len(data) // 2] ^= 0xFF  # one flipped byte in the middle of the file
    damaged.write_bytes(bytes(data))

    info = run_info(path)
    assert info.steps == 2 and damaged in info.damaged and damaged.name in info.problem
    solved_steps.clear()
    summary = runner.run_case(indent_case, tmp_path, progress=False)
    said = capsys.readouterr()
    assert damaged.name in said.out + said.err, "the damaged part is named"
    assert solved_steps == [2, 3, 4, 5], "recomputed from the last sound step, not from 0"
    assert summary.resumed_steps == 2
    assert_same_run(sacflow.open_run(path), uninterrupted)


def test_a_run_of_another_case_is_never_overwritten(tmp_path, capsys):
    out = ["--out", str(tmp_path), "--no-progress"]
    sets = [f"--set={item}" for item in TINY_HERTZ]
    assert main(["run", str(HERTZ), *out, *sets]) == 0
    path = tmp_path / "hertz-elastic.nc"
    stored = path.read_bytes()
    first_id = run_info(path).case_id
    capsys.readouterr()

    # Thread count and description change no number: the same case, already complete.
    assert main(["run", str(HERTZ), *out, *sets, "--set", "solver.fft_threads=1",
                 "--set", "description=again"]) == 0
    assert "already complete" in capsys.readouterr().out

    code = main(["run", str(HERTZ), *out, *sets, "--set", "grid.nx=24"])
    err = capsys.readouterr().err
    assert code != 0 and path.read_bytes() == stored, "the finished run is kept"
    other_id = sacflow.load_case(HERTZ, [*TINY_HERTZ, "grid.nx=24"]).case_id
    for expected in (str(path), first_id, other_id, "grid.nx: 16 -> 24", "--overwrite"):
        assert expected in err, f"{expected!r} missing from the message:\n{err}"
    assert "Traceback" not in err

    assert main(["run", str(HERTZ), *out, *sets, "--set", "grid.nx=24", "--overwrite"]) == 0
    assert run_info(path).case_id == other_id


def test_interrupted_run_of_another_case_is_kept(indent_case, tmp_path):
    path = interrupt(indent_case, tmp_path, after=1)
    other = sacflow.load_case(INDENT, [*TINY_INDENT, "grid.nz=9"])
    with pytest.raises(RunExistsError, match="grid.nz: 8 -> 9"):
        runner.run_case(other, tmp_path, progress=False)
    assert run_info(path).steps == 1 and run_info(path).case_id == indent_case.case_id


def test_approach_at_zero_load_is_the_residual_print(uninterrupted):
    last = uninterrupted.isel(step=-1)
    assert float(last["load"]) == 0.0
    # The counter-body rests in the print: the approach is the lowest initial separation on the
    # deformed surface, min(h + u3r) (the stored geometry h is relative to the first-contact
    # datum), i.e. the print depth at the centre cells plus the sphere's height over them.
    geometry = last["geometry"].values
    u3r = last["residual_displacement"].values
    expected = np.nanmin(geometry + u3r)
    assert float(last["approach"]) > 0.9 * float(u3r.max()), "the curve ends at the print"
    assert_allclose(float(last["approach"]), expected, rtol=1e-12)


def test_elastic_unloading_returns_to_zero_approach(tmp_path):
    case = sacflow.load_case(HERTZ, [*TINY_HERTZ])
    data = case.model_dump()
    data["load_path"] = [*data["load_path"], {"kind": "unload", "increments": 1}]
    case = sacflow.config.schema.Case.model_validate(data)
    ds = sacflow.open_run(runner.run_case(case, tmp_path, progress=False).path)
    loaded, unloaded = (float(ds["approach"].isel(step=i)) for i in (0, -1))
    # No print: the sphere's lowest point returns to where it first touched the surface, the
    # cell centres; the approach ends at their height under it (the datum is the load point).
    assert unloaded == float(np.nanmin(ds["geometry"].isel(step=-1).values))
    assert 0.0 <= unloaded < 0.01 * loaded


def test_each_step_stores_its_loops_residuals(uninterrupted, indent_case):
    opts = indent_case.solver
    for loop, tol in (("contact", opts.contact_tolerance),
                      ("plasticity", opts.plasticity_tolerance),
                      ("coupling", opts.coupling_tolerance)):
        residual = uninterrupted[f"{loop}_residual"].values
        assert np.all(residual < tol) and np.all(residual >= 0.0), loop
        assert uninterrupted[f"{loop}_converged"].values.all(), loop
    plastic = uninterrupted["plasticity_iterations"].values > 0
    assert (uninterrupted["plasticity_residual"].values[plastic] > 0.0).all(), \
        "plastic steps report their real residual, not a constant"
    assert uninterrupted["converged"].values.all()


def test_non_converged_step_raises_after_storing_the_completed_steps(tmp_path):
    # Two elastic increments (p0 about 2 GPa, below the onset of yield), then a plastic one
    # that cannot converge in 2 plasticity iterations, even cut back into eighths (the last
    # attempt, from 0.01 to 0.09 N, ends in the contact solve of its second sweep).
    sets = ["grid.nx=16", "grid.ny=16", "grid.nz=8", "load_path.0.to=0.01",
            "load_path.0.increments=2", "solver.plasticity_max_iterations=2"]
    case = sacflow.load_case(INDENT, sets)
    data = case.model_dump()
    data["load_path"] = [data["load_path"][0], {"kind": "load", "to": 0.65, "increments": 1}]
    data["grid"]["half_width"] = 2.0
    case = sacflow.config.schema.Case.model_validate(data)
    with pytest.raises(ConvergenceError, match="step 2") as err:
        runner.run_case(case, tmp_path, progress=False)
    assert err.value.step == 2 and err.value.residual > err.value.tolerance
    info = run_info(tmp_path / f"{case.name}.nc")
    assert info.steps == 2 and not info.complete, "the two converged steps are stored"


def test_load_approach_stage_reports_the_residual_print(uninterrupted, tmp_path):
    from sacflow.compare import load_approach

    path = tmp_path / "run.nc"
    uninterrupted.to_netcdf(path)
    out = load_approach(path)
    residual = float(out["residual_approach"])
    assert residual == float(uninterrupted["approach"].isel(step=-1)) and residual > 0.0
    # the print is deeper than the residual surface displacement's peak minus the sphere's
    # height over the centre cells: the curve ends in the print, not at the origin
    assert residual >= float(uninterrupted["residual_displacement"].isel(step=-1).max())


def test_info_says_what_is_stored(indent_case, tmp_path, capsys):
    path = interrupt(indent_case, tmp_path, after=2)
    assert main(["info", str(path)]) == 0
    said = capsys.readouterr().out
    assert f"interrupted run of case {indent_case.case_id} (2 steps stored)" in said
    assert "resumable: yes" in said and indent_case.name in said
    assert main(["info", str(tmp_path / "nothing.nc")]) != 0
    assert "no run" in capsys.readouterr().out


class InterruptedWhenGrown(Simulation):
    """Interrupted after one state, but only once its box has been deepened (nz > 4)."""

    @classmethod
    def of(cls, case):
        """The simulation factory: this simulation of ``case``."""
        return cls(solver_inputs(case))

    def run(self, start: int = 0):
        for count, state in enumerate(super().run(start)):
            if count == 1 and self.nz > 4:
                raise KeyboardInterrupt
            yield state


def test_interrupted_run_with_a_grown_box_resumes_as_grown(tmp_path, solved_steps):
    from test_solver import NU, E, R, load_for_ratio, sphere_case

    from sacflow.mechanics.hertz import composite_modulus, hertz_contact

    sigma_y = 4.0e9
    load = load_for_ratio(2.2, sigma_y)
    a = hertz_contact(load, R, composite_modulus(E, NU)).a
    law = {"law": "linear", "yield_stress": sigma_y, "modulus": 0.05 * E}
    path = [{"kind": "load", "to": load, "increments": 1}, {"kind": "hold", "increments": 2}]
    case = sphere_case(law, path, nx=24, nz=4, depth=0.4 * a)
    with pytest.warns(RuntimeWarning, match="running again"), pytest.raises(KeyboardInterrupt):
        runner.run_case(case, tmp_path, progress=False, simulation_factory=InterruptedWhenGrown.of)
    info = run_info(tmp_path / f"{case.name}.nc")
    assert info.steps == 1 and info.matches(case.case_id) and info.case_id != case.case_id
    solved_steps.clear()
    summary = runner.run_case(case, tmp_path, progress=False)
    assert summary.resumed_steps == 1 and solved_steps == [1, 2], "resumed in the grown box"
    ds = sacflow.open_run(summary.path)
    assert ds.attrs["requested_case_id"] == case.case_id and ds.sizes["x3"] > 4


def test_run_refuses_a_grid_too_large_before_allocating(tmp_path):
    from sacflow.errors import GridTooLargeError

    case = sacflow.load_case(HERTZ, ["grid.nx=4096", "grid.ny=4096", "grid.nz=256"])

    def never(case):
        raise AssertionError("the simulation must not be built")

    with pytest.raises(GridTooLargeError, match="grid.nx"):
        runner.run_case(case, tmp_path, progress=False, simulation_factory=never)
    assert not run_info(tmp_path / f"{case.name}.nc").exists
