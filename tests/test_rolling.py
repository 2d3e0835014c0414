"""Rolling and dented contacts: elastic rolling moves Hertz with the load, dent symmetry."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from sacflow.config.solver_inputs import simulation_for
from sacflow.storage.case_file import case_from_dict, load_case

E, NU = 210e9, 0.3


def elastic_rolling_case(nx=96, cells=6):
    """Elastic sphere on an elastic flat rolled by ``cells`` whole cells, one cell per step."""
    data = {
        "name": "elastic-rolling",
        "body": {"E": E, "nu": NU, "hardening": {"law": "elastic"}},
        "counterbody": {"kind": "elastic", "E": E, "nu": NU, "radius": 20e-3},
        "grid": {"nx": nx, "ny": nx, "nz": 4, "half_width": 1.5},
        "load_path": [{"kind": "load", "to": 4200.0, "increments": 1}],
    }
    dx = case_from_dict(data).cell_size()[0]
    data["load_path"].append(
        {"kind": "roll", "distance": cells * dx, "steps": cells, "direction": [1.0, 0.0]})
    return case_from_dict(data)


def test_elastic_rolling_reproduces_hertz_and_moves_with_the_load():
    case = elastic_rolling_case()
    hz = case.hertz()
    states = list(simulation_for(case).run())
    first = states[0].surface["pressure"]
    for shift, state in enumerate(states):
        assert_allclose(state.max_pressure, hz.p0, rtol=5e-3, err_msg=f"p0 at step {shift}")
        assert_allclose(state.approach, hz.approach, rtol=3e-3, err_msg=f"approach {shift}")
        moved = np.roll(first, shift, axis=0)
        assert_allclose(state.surface["pressure"], moved, rtol=0, atol=1e-8 * hz.p0,
                        err_msg=f"pressure field did not move with the load (step {shift})")
        assert_allclose(state.load_x1, shift * case.cell_size()[0], rtol=1e-12)


def test_dented_vertical_pressure_keeps_the_dent_symmetry():
    case = load_case("configs/dent-vertical.toml", [
        "grid.nx=32", "grid.ny=32", "grid.nz=4", 'body.hardening={law="elastic"}',
        "load_path.0.increments=1"])
    state = next(iter(simulation_for(case).run()))
    p = state.surface["pressure"]
    scale = p.max()
    for name, other in (("x1 -> -x1", p[::-1]), ("x2 -> -x2", p[:, ::-1]), ("x1 <-> x2", p.T)):
        assert_allclose(p, other, rtol=0, atol=1e-8 * scale, err_msg=f"dent symmetry {name}")
    # the dent carries no load at its centre: the peak sits on the shoulders, off the centre
    centre = p[15:17, 15:17].max()
    assert centre < 0.5 * scale, "pressure at the dent centre should be relieved"


@pytest.mark.slow
def test_rolling_smooth_reaches_a_steady_state():
    case = load_case("configs/rolling-smooth.toml", ["load_path.1.steps=60"])
    sim = simulation_for(case)
    for _ in sim.run():
        pass
    track = sim.residual_displacement[:, sim.body_shape[1] // 2]
    x = sim.coords.x1
    a = case.hertz().a
    rolled = (x > 2.5 * a) & (x < 4.2e-3 - 1.5 * a)
    plateau = np.median(track[rolled])
    assert plateau > 0
    assert np.abs(track[rolled] / plateau - 1).max() < 0.05
