"""Comparison stages never read an edge cell as a position beyond the stored grid (issue #14).

A run whose cuboid box is 14 µm deep (7 layers of 2 µm) used to give ``residual-map`` at its
default 65 µm the numbers of its bottom layer, labelled as asked. A position outside the stored
x1/x2/x3 cells is now an error naming the option, the position and the stored range; the
defaults are chosen from the run (the layer of the extreme residual stress).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from numpy.testing import assert_allclose

from sacflow.cli import main
from sacflow.compare import (
    CompareError,
    case_vs_reference,
    residual_map,
    track,
    vertical_vs_rolling,
)
from sacflow.compare.core import cell_bounds
from sacflow.solver.state import COMPONENTS, GridCoords, State
from sacflow.storage.case_file import load_case
from sacflow.storage.run_reader import open_run
from sacflow.storage.run_writer import RunWriter

HERTZ = Path(__file__).resolve().parents[1] / "configs" / "hertz-elastic.toml"
#: The shallow box of the issue: 7 layers of 2 µm, 14 µm deep.
LAYER, LAYERS = 2e-6, 7
#: Layer of the extreme residual σ11 in :func:`shallow_run`.
EXTREME = 4
CELL = 1e-6


@pytest.fixture(scope="module")
def case():
    return load_case(HERTZ, ["grid.nx=16", "grid.ny=16", "grid.nz=4"])


def coords() -> GridCoords:
    centres = (np.arange(11) - 5) * CELL
    return GridCoords(centres, centres.copy(), (np.arange(LAYERS) + 0.5) * LAYER)


def shallow_run(path: Path, case) -> xr.Dataset:
    """One step, residual σ11 = −(100 MPa) · (1 + layer) · bump(x1, x2), extreme in EXTREME."""
    grid = coords()
    x1, x2, _ = np.meshgrid(grid.x1, grid.x2, grid.x3, indexing="ij")
    weight = np.array([1.0, 2.0, 3.0, 4.0, 9.0, 5.0, 6.0])  # layer EXTREME stands out
    s11 = -100e6 * weight * np.exp(-(x1**2 + x2**2) / (3 * CELL) ** 2)
    stress = np.zeros((*grid.shape, len(COMPONENTS)))
    stress[..., 0] = s11
    u = np.repeat(np.linspace(0.0, 1e-9, grid.x1.size)[:, None], grid.x2.size, axis=1)
    states = [
        State(step=k, segment=0, load=1.0 - k, approach=0.0, load_x1=2 * CELL * k, load_x2=0.0,
              contact_area=0.0, max_pressure=0.0, contact_iterations=1, plasticity_iterations=0,
              surface={"residual_displacement": u, "pressure": u},
              volume={"residual_stress": stress})
        for k in range(2)
    ]
    with RunWriter(path, case, grid) as writer:
        for state in states:
            writer.append(state)
    return open_run(path)


def test_cell_bounds_cover_the_cells():
    assert cell_bounds(np.array([1e-6, 3e-6, 5e-6]), "x3") == pytest.approx((0.0, 6e-6))
    assert cell_bounds(np.array([1e-6]), "x3") == pytest.approx((0.0, 2e-6))
    assert cell_bounds(np.array([-1.5, -0.5, 0.5, 1.5]), "x1") == pytest.approx((-2.0, 2.0))


def test_residual_map_depth_below_the_box_is_an_error(tmp_path, case):
    ds = shallow_run(tmp_path / "shallow.nc", case)
    with pytest.raises(CompareError) as error:
        residual_map(ds, depth=65e-6)
    message = str(error.value)
    assert "--depth 6.5e-05 m" in message, "the option and the depth asked for"
    assert "[0, 1.4e-05] m" in message, "the box range"
    assert "inside that range" in message and "leave it out" in message, "the fix"
    inside = residual_map(ds, depth=13.9e-6)  # the bottom layer's own cell is fine
    assert inside.attrs["depth"] == pytest.approx(13e-6)


def test_residual_map_default_is_the_layer_of_the_extreme_stress(tmp_path, case):
    ds = shallow_run(tmp_path / "shallow.nc", case)
    result = residual_map(ds)
    assert result.attrs["depth"] == pytest.approx((EXTREME + 0.5) * LAYER)
    assert "extreme" in result.attrs["depth_choice"]
    assert "requested_depth" not in result.attrs
    assert_allclose(float(result.map_min), -900e6, rtol=1e-12)


def test_cli_residual_map_default_and_out_of_box_depth(tmp_path, case, capsys):
    shallow_run(tmp_path / "shallow.nc", case)
    run = str(tmp_path / "shallow.nc")
    out = ["--out", str(tmp_path / "cmp")]
    assert main(["compare", "residual-map", run, *out]) == 0
    assert "map_min" in capsys.readouterr().out
    assert main(["compare", "residual-map", run, *out, "--depth", "65e-6"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "--depth 6.5e-05 m" in err and "Traceback" not in err


def test_vertical_vs_rolling_positions_outside_a_run_are_errors(tmp_path, case):
    ds = shallow_run(tmp_path / "v.nc", case)
    with pytest.raises(CompareError, match=r"--depth 7\.5e-05 m .*cuboid box"):
        vertical_vs_rolling(ds, ds, depth=75e-6)
    with pytest.raises(CompareError, match=r"--x2 2e-05 m .*surface grid"):
        vertical_vs_rolling(ds, ds, depth=5e-6, x2=20e-6)
    result = vertical_vs_rolling(ds, ds)  # default: the depth of the vertical run's minimum
    assert result.attrs["depth_vertical"] == pytest.approx((EXTREME + 0.5) * LAYER)


def test_track_x2_outside_the_grid_is_an_error(tmp_path, case):
    ds = shallow_run(tmp_path / "track.nc", case)
    with pytest.raises(CompareError, match=r"--x2 -3e-05 m .*\[-5\.5e-06, 5\.5e-06\]"):
        track(ds, x2=-30e-6, end_margin=0.0)


def test_case_vs_reference_selection_outside_the_grid_is_an_error(tmp_path, case):
    ds = shallow_run(tmp_path / "ref.nc", case)
    csv = tmp_path / "ref.csv"
    csv.write_text("x1, pressure\n0.0, 0.0\n")
    with pytest.raises(CompareError, match=r"--select x2 0\.001 m .*surface grid"):
        case_vs_reference(ds, csv, "pressure", select={"x2": 1e-3})
