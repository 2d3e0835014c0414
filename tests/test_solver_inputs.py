"""The translation of a case into the solver's plain inputs (sacflow.config.solver_inputs)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sacflow.config.solver_inputs import case_body_grid, case_steps, solver_inputs
from sacflow.errors import SacflowError
from sacflow.mechanics.hardening import NoPlasticity, SwiftHardening
from sacflow.solver.layout import Hold, Ramp, Roll, plan_steps
from sacflow.storage.case_file import load_case

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
TRACTION = CONFIGS / "rolling-smooth-traction.toml"
HERTZ = CONFIGS / "hertz-elastic.toml"
SMALL = ["grid.nx=12", "grid.ny=12", "grid.nz=4", "load_path.1.steps=3"]


def test_the_inputs_are_the_case_s_numbers():
    case = load_case(TRACTION, SMALL)
    inputs = solver_inputs(case)
    material, contact, grid = inputs.material, inputs.contact, inputs.grid
    assert (material.E, material.nu) == (case.body.E, case.body.nu)
    assert isinstance(material.law, SwiftHardening) and material.plastic
    assert material.kinematic is None
    assert contact.e_star == case.contact_modulus() and contact.radii == case.effective_radii()
    assert contact.hertz == case.hertz()
    assert contact.friction and contact.traction == (0.2, 0.0)
    assert grid.window == (12, 12) and grid.cell == case.cell_size() and grid.nz == 4
    assert grid.depth > case.hertz().a, "sized on the Hertz field below yield"
    assert inputs.steps == tuple(case_steps(case)) and len(inputs.steps) == 5 + 3 + 2
    assert inputs.settings.anderson_depth == case.solver.anderson_depth
    assert inputs.initial.stress is None and not inputs.initial.equivalent_plastic_strain.any()
    assert inputs.initial.equivalent_plastic_strain.shape == (4,)


def test_no_acceleration_no_friction_elastic_body():
    case = load_case(HERTZ, ["grid.nx=16", "grid.ny=16", "grid.nz=4",
                             "solver.acceleration=none", "friction.coefficient=0"])
    inputs = solver_inputs(case)
    assert inputs.settings.anderson_depth == 0, "plain sweeps"
    assert inputs.contact.friction and inputs.contact.traction is None, "μ = 0: frictionless"
    assert isinstance(inputs.material.law, NoPlasticity) and not inputs.material.plastic
    assert case.grid.depth is not None and inputs.grid.depth == case.grid.depth, "as given"


def test_a_measured_surface_needs_its_heights(tmp_path):
    path = tmp_path / "flat.txt"
    points = np.linspace(-20e-6, 20e-6, 5)
    path.write_text("".join(f"{x} {y} 0\n" for x in points for y in points))
    case = load_case(HERTZ, ["grid.nx=16", "grid.ny=16", "grid.nz=4", "surface.kind=measured",
                             f"surface.path={path}"])
    with pytest.raises(SacflowError, match="load_surface"):
        solver_inputs(case)


def test_segments_expand_as_the_schema_s():
    segments = (Ramp(1.0, 2), Hold(1), Roll(3e-3, 3, (1.0, 0.0), pass_count=2),
                Ramp(0.0, 1))
    plan = plan_steps(segments)
    # 2 load, 1 hold, 3 rolled, 2 + 2 lifted between the passes, 3 rolled, 1 unload
    assert len(plan) == 2 + 1 + 3 + 4 + 3 + 1
    assert [s.pass_index for s in plan if s.pass_end] == [0, 1]
    assert plan[-2].position == pytest.approx((3e-3, 0.0))
    case = load_case(TRACTION, SMALL)
    grid = case_body_grid(case)
    assert grid.body[0] > grid.window[0] and grid.body[1] == grid.window[1], "swept along x1"
