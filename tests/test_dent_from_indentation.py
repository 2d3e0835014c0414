"""The dent-from-indentation pipeline at a tiny grid: a chained case against its geometric twin."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from scipy.interpolate import RegularGridInterpolator

from sacflow.config.solver_inputs import simulation_for
from sacflow.storage.case_file import load_case
from sacflow.storage.initial_state_file import read_initial_state

#: The press, the chained rolling, its twin and both fatigue stages: slow, so that the default
#: suite keeps within its CI budget (``tests/test_clear_messages.py`` checks the pipeline's
#: overrides in the default run).
pytestmark = pytest.mark.slow

PIPELINE = Path(__file__).resolve().parents[1] / "pipelines" / "dent_from_indentation.py"
ROLLING = ["grid.nx=40", "grid.ny=40", "grid.nz=8", "load_path.1.steps=12"]
PRESS = ["grid.nx=24", "grid.ny=24", "grid.nz=8"]


def _pipeline():
    spec = importlib.util.spec_from_file_location("dent_from_indentation", PIPELINE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    out = tmp_path_factory.mktemp("dfi")
    module = _pipeline()
    numbers = module.compare_histories(out, ROLLING, PRESS, progress=False)
    return out, module, numbers


def test_the_indentation_history_is_carried_into_the_rolling(result):
    out, _, numbers = result
    with xr.open_dataset(out / "dent-from-indentation-press.nc") as press:
        press_eqps = float(press["equivalent_plastic_strain"].isel(step=-1).max())
        press_s11 = float(press["residual_stress"].isel(step=-1).sel(component="11").min())
    # the chained body keeps the indentation's plastic strain and compressive residual stress
    assert numbers["max_plastic_strain_chained"] > 0.5 * press_eqps
    assert numbers["max_plastic_strain_geometric"] < 0.01 * numbers["max_plastic_strain_chained"]
    assert numbers["residual_stress_11_min_chained"] < 0.25 * press_s11 < 0.0
    assert numbers["residual_stress_11_min_geometric"] > 0.1 * numbers[
        "residual_stress_11_min_chained"]
    assert (out / "dent-from-indentation-comparison.png").stat().st_size > 10_000
    for stem in ("dent-from-indentation-rolling", "dent-from-indentation-geometric"):
        assert (out / "fatigue" / f"{stem}-fatigue.nc").exists()


def test_chained_start_surface_is_the_press_dent(result):
    out, module, _ = result
    source = out / "dent-from-indentation-press.nc"
    case = load_case(module.CHAINED, [*ROLLING, f"initial_state.run={source}"])
    sim = simulation_for(case, initial=read_initial_state(case))
    with xr.open_dataset(out / "dent-from-indentation-press.nc") as press:
        u = press["residual_displacement"].isel(step=-1).transpose("x1", "x2")
        x1, x2 = u["x1"].values, u["x2"].values
        inside1 = (sim.coords.x1 >= x1[0]) & (sim.coords.x1 <= x1[-1])
        inside2 = (sim.coords.x2 >= x2[0]) & (sim.coords.x2 <= x2[-1])
        points = np.stack(np.meshgrid(sim.coords.x1[inside1], sim.coords.x2[inside2],
                                      indexing="ij"), axis=-1)
        expected = RegularGridInterpolator((x1, x2), u.values)(points)
    got = sim.residual_displacement[np.ix_(inside1, inside2)]
    depth = float(u.max())
    # recomputed on the coarser rolling grid from the mapped plastic strain: the dent's depth
    # within 10 % of the press's (38 µm rolling cells, 36 µm press cells: 8 across the dent);
    # measured 4.5 % shallower, and 1.9 % of the depth at most from point to point
    assert float(got.max()) == pytest.approx(depth, rel=0.10)
    assert np.abs(got - expected).max() < 0.05 * depth
