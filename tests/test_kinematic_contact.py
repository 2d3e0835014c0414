"""Kinematic hardening in contact runs (issue #19, part): backstress as a solver state.

* C = 0 gives the isotropic run (the two return mappings agree to their tolerance);
* an Armstrong–Frederick body stores its backstress, which is deviatoric and stays on the yield
  surface with the stress where the body flowed last;
* an interrupted run resumes from the stored backstress and equals the uninterrupted one;
* ``backstress`` cannot be asked for without kinematic hardening;
* a chained case carries the source's backstress over, and refuses to drop it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import sacflow
from sacflow import runner
from sacflow.config.solver_inputs import simulation_for, solver_inputs
from sacflow.errors import SacflowError
from sacflow.solver.simulation import Simulation
from sacflow.storage.case_file import load_case
from sacflow.storage.run_reader import run_info

ROOT = Path(__file__).resolve().parents[1]
CASE = ROOT / "configs" / "rolling-cycles-shakedown.toml"
TINY = ["grid.nx=12", "grid.ny=12", "grid.nz=6", "load_path.1.steps=8", "load_path.1.passes=2"]
AF = ["body.hardening.kinematic.modulus=50e9", "body.hardening.kinematic.recall=100"]


def test_zero_kinematic_modulus_is_the_isotropic_run():
    iso = list(simulation_for(load_case(CASE, TINY)).run())
    kin = list(simulation_for(load_case(CASE, [*TINY, "body.hardening.kinematic.modulus=0"]))
               .run())
    a, b = iso[-1].volume, kin[-1].volume
    scale = float(np.abs(a["plastic_strain"]).max())
    assert scale > 0
    # both returns solve their consistency equation to 1e-12 of σY; the coupled fixed point
    # to its 1e-6: agreement far below that
    assert np.abs(a["plastic_strain"] - b["plastic_strain"]).max() < 1e-6 * scale
    assert not b["backstress"].any()


def test_backstress_is_stored_deviatoric_and_consistent(tmp_path):
    case = load_case(CASE, [*TINY, *AF])
    path = runner.run_case(case, tmp_path, progress=False).path
    ds = sacflow.open_run(path)
    x = ds["backstress"].isel(step=-1).values
    assert ds["backstress"].attrs["units"] == "Pa" and np.abs(x).max() > 1e6
    assert np.abs(x[..., :3].sum(axis=-1)).max() < 1e-6 * np.abs(x).max()
    # where the backstress is largest the material flowed: it is bounded by C/γ (uniaxial 3/2 X)
    q = np.sqrt(1.5 * ((x[..., :3] ** 2).sum(-1) + 2 * (x[..., 3:] ** 2).sum(-1)))
    assert q.max() <= 50e9 / 100 * (1 + 1e-9)


class Interrupted(Simulation):
    """The real simulation, interrupted after ``stop_after`` states."""

    stop_after = 9

    @classmethod
    def of(cls, case):
        """The simulation factory: this simulation of ``case``."""
        return cls(solver_inputs(case))

    def run(self, start: int = 0):
        for count, state in enumerate(super().run(start)):
            if count == self.stop_after:
                raise KeyboardInterrupt
            yield state


def test_resume_restores_the_backstress(tmp_path):
    case = load_case(CASE, [*TINY, *AF])
    whole = sacflow.open_run(runner.run_case(case, tmp_path / "whole", progress=False).path)
    out = tmp_path / "cut"
    with pytest.raises(KeyboardInterrupt):
        runner.run_case(case, out, progress=False, simulation_factory=Interrupted.of)
    assert run_info(out / f"{case.name}.nc").steps == Interrupted.stop_after
    resumed = sacflow.open_run(runner.run_case(case, out, progress=False).path)
    for name in ("backstress", "plastic_strain", "equivalent_plastic_strain", "pressure"):
        a = np.asarray(resumed[name].values, float)
        b = np.asarray(whole[name].values, float)
        scale = float(np.nanmax(np.abs(b))) or 1.0
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-9 * scale, equal_nan=True,
                                   err_msg=name)


def test_backstress_field_needs_kinematic_hardening():
    with pytest.raises(SacflowError, match="needs kinematic hardening"):
        load_case(CASE, ['output.fields=["load", "backstress"]'])


def _chained_runs(out: Path) -> tuple[Path, Path, Path]:
    """Two lifted passes in one run, and the same as one pass + a chained second pass."""
    same_lift = ["load_path.1.lift_increments=4"]
    whole = load_case(CASE, [*TINY, *AF, *same_lift, "name=whole"])
    first = load_case(CASE, [*TINY, *AF, "load_path.1.passes=1", "load_path.2.increments=4",
                               "name=first"])
    paths = [runner.run_case(c, out, progress=False).path for c in (whole, first)]
    second = load_case(CASE, [*TINY, *AF, "load_path.1.passes=1", "name=second",
                              f"initial_state.run={paths[1]}"])
    return (*paths, runner.run_case(second, out, progress=False).path)


def test_chained_case_carries_the_backstress_over(tmp_path):
    whole_path, first_path, second_path = _chained_runs(tmp_path)
    whole, second = sacflow.open_run(whole_path), sacflow.open_run(second_path)
    assert sacflow.open_run(first_path)["backstress"].isel(step=-1).any()
    # the chained pass is the whole run's second pass: reload, roll, unload
    np.testing.assert_allclose(second["load"].values, whole["load"].values[-14:])
    for name in ("backstress", "plastic_strain", "equivalent_plastic_strain"):
        a = np.asarray(second[name].isel(step=-1).values, float)
        b = np.asarray(whole[name].isel(step=-1).values, float)
        scale = float(np.abs(b).max())
        assert scale > 0, name
        # the same arrays in, the same solves after: equal to round-off
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-9 * scale, err_msg=name)


def test_chained_case_without_kinematic_hardening_is_refused(tmp_path):
    first = load_case(CASE, [*TINY, *AF, "load_path.1.passes=1"])
    path = runner.run_case(first, tmp_path, progress=False).path
    with pytest.raises(SacflowError, match="backstress would be lost"):
        runner.run_case(load_case(CASE, [*TINY, "name=second", f"initial_state.run={path}"]),
                        tmp_path, progress=False)
