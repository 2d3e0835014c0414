"""The press's pressure at its peak load on sub-cells (``pipelines/press_pressure_profile.py``).

* :class:`~sacflow.kernels.subcell_displacement.SubcellResidualDisplacement` equals Chiu's
  cuboids summed directly at the sub-cells' centres, and a strain uniform over 2 × 2 cells gives
  the displacement of the one cuboid they tile (an independent closed form);
* the oscillation measure of :func:`~sacflow.studies.pressure_profile.sawtooth` is an
  alternating profile's amplitude, and (nearly) zero on a smooth one or the edge's fall;
* the script runs a tiny press and keeps its tables.
"""

from __future__ import annotations

import csv
import importlib.util
from pathlib import Path

import numpy as np
import pytest

from sacflow.kernels.residual_displacement import cuboid_surface_displacement
from sacflow.kernels.subcell_displacement import SubcellResidualDisplacement
from sacflow.studies.pressure_profile import row_profile, sawtooth

NU = 0.3


def sub_points(n: int, dx: float, s: int) -> np.ndarray:
    """Sub-cell centres along one axis of n cells of size dx centred at 0, dx, ..."""
    offsets = (np.arange(s) + 0.5) / s - 0.5
    return (np.arange(n)[:, None] * dx + offsets[None, :] * dx).ravel()


@pytest.mark.parametrize("subcells", [2, 3])
def test_the_operator_sums_the_cuboids_at_the_sub_cells(subcells):
    rng = np.random.default_rng(7)
    n1, n2, nz = 5, 4, 3
    dx1, dx2 = 1.0e-6, 1.3e-6
    z = np.array([0.4, 1.2, 2.0]) * 1e-6
    half = np.full(3, 0.4e-6)
    strain = rng.normal(size=(n1, n2, nz, 6)) * 1e-3
    fine = SubcellResidualDisplacement((n1, n2, nz), (dx1, dx2), z, half, NU, subcells)(strain)
    p1, p2 = sub_points(n1, dx1, subcells), sub_points(n2, dx2, subcells)
    c1, c2 = np.arange(n1) * dx1, np.arange(n2) * dx2
    direct = np.array([[np.sum(cuboid_surface_displacement(
        a - c1[:, None, None], b - c2[None, :, None], z[None, None, :], dx1 / 2, dx2 / 2,
        half[None, None, :], NU) * strain) for b in p2] for a in p1])
    assert fine.shape == (n1 * subcells, n2 * subcells)
    assert np.abs(fine - direct).max() < 1e-12 * np.abs(direct).max()


def test_a_strain_uniform_over_two_by_two_cells_is_one_cuboid():
    """Four cuboids that tile a larger one displace the surface as that one does."""
    n, dx, dz = 6, 1.0e-6, 0.5e-6
    strain = np.zeros((n, n, 1, 6))
    strain[2:4, 2:4, 0] = [1e-3, -2e-3, 5e-4, 3e-4, -1e-4, 2e-4]
    fine = SubcellResidualDisplacement((n, n, 1), (dx, dx), np.array([dz]), np.array([dz]),
                                       NU, 2)(strain)
    p = sub_points(n, dx, 2)
    centre = 2.5 * dx
    whole = cuboid_surface_displacement(p[:, None] - centre, p[None, :] - centre, dz, dx, dx, dz,
                                        NU) @ strain[2, 2, 0]
    assert np.abs(fine - whole).max() < 1e-12 * np.abs(whole).max()


def test_the_oscillation_measure_is_the_alternations_amplitude():
    """An alternation A gives A; a smooth curvature and the edge's fall give (nearly) none."""
    h = 1e-6
    r = (np.arange(41) + 0.5) * h
    alternating = 8e9 + 5e7 * (-1.0) ** np.arange(41)
    assert sawtooth(r, alternating, 41 * h) == pytest.approx(5e7, rel=1e-12)
    smooth = 8e9 - 1e18 * r**2  # second difference 1e6 Pa at every point
    assert sawtooth(r, smooth, 41 * h) < 1e6 / 30
    edge = smooth.copy()
    edge[r > 0.8 * 41 * h] = 0.0  # the contact's edge inside the counted part: one dip
    assert sawtooth(r, edge, 41 * h) < 8e9 / 30
    assert sawtooth(r, alternating + smooth, 41 * h) == pytest.approx(5e7, rel=0.05)


def test_the_row_is_the_one_nearest_the_axis_ahead_of_it():
    x = (np.arange(8) - 3.5) * 1.0
    values = np.arange(64.0).reshape(8, 8)
    r, row = row_profile(values, x, x, (0.0, 0.2))
    assert r.tolist() == [0.5, 1.5, 2.5, 3.5]
    assert row.tolist() == [36.0, 44.0, 52.0, 60.0]


SCRIPT = Path(__file__).parent.parent / "pipelines" / "press_pressure_profile.py"


def load_script():
    spec = importlib.util.spec_from_file_location("press_pressure_profile", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_script_runs_the_press_and_keeps_its_tables(tmp_path, capsys):
    module = load_script()
    table, profiles = tmp_path / "peak.csv", tmp_path / "rows.csv"
    module.main(["--runs", "24", "--layers", "12", "--increments", "3", "1",
                 "--table", str(table), "--profiles", str(profiles)])
    (row,) = csv.DictReader(table.open())
    assert int(row["nx"]) == 24 and int(row["layers"]) == 12
    assert 0.0 < float(row["peak_radius"]) <= float(row["contact_radius"])
    assert float(row["subcell_peak_pressure"]) >= float(row["peak_pressure"]) > 0.0
    assert float(row["peak_pressure_splines"]) == pytest.approx(float(row["peak_pressure"]),
                                                                rel=1e-6)
    sources = {r["source"] for r in csv.DictReader(profiles.open())}
    assert sources == {"cells", "subcells_splines", "subcells_cuboids"}
    before = table.read_bytes()
    with pytest.raises(SystemExit, match="exists; nothing was changed"):
        module.main(["--runs", "24", "--table", str(table)])
    assert table.read_bytes() == before
    with pytest.raises(SystemExit):
        module.main(["--runs", "30"])
    assert "of the contact radius" in capsys.readouterr().out
