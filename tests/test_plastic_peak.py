"""The shape of a flat maximum (sacflow.studies.plastic_peak), on fields of known shape."""

from __future__ import annotations

import numpy as np
import pytest

from sacflow.studies.plastic_peak import peak_shape, plastic_extent

#: Cells of 4 µm across a 200 µm square, layers of 2 µm to 60 µm.
X = np.arange(-98e-6, 100e-6, 4e-6)
Z = np.arange(1e-6, 60e-6, 2e-6)


def ring(peak: float = 0.07, r0: float = 50e-6, z0: float = 21.3e-6, alpha: float = 2e8,
         beta: float = 4e8) -> np.ndarray:
    """εp = peak (1 − α (r − r0)² − β (z − z0)²): a ring of radius r0 at depth z0."""
    r = np.hypot(X[:, None, None], X[None, :, None])
    return peak * (1.0 - alpha * (r - r0) ** 2 - beta * (Z[None, None, :] - z0) ** 2)


def test_a_parabola_in_depth_is_read_exactly() -> None:
    shape = peak_shape(ring(), X, X, Z)
    assert shape.depth == pytest.approx(21.3e-6, rel=1e-9)
    assert shape.curvature == pytest.approx(2 * 4e8 * 0.07 / shape_value_at_vertex(), rel=1e-9)
    assert shape.layer == pytest.approx(2e-6)
    # the drop at another depth is β (z − z0)² of the peak, over the column's vertex value
    assert shape.drop_at(25.3e-6) == pytest.approx(4e8 * 0.07 * (4e-6) ** 2
                                                   / shape_value_at_vertex(), rel=1e-9)
    assert shape.drop_at(shape.depth) == 0.0
    assert shape.above < 0.0 and shape.below < 0.0


def shape_value_at_vertex() -> float:
    """The column's value at z0 through the largest cell of :func:`ring`."""
    field = ring()
    i, j, _ = np.unravel_index(int(np.argmax(field)), field.shape)
    r = float(np.hypot(X[i], X[j]))
    return 0.07 * (1.0 - 2e8 * (r - 50e-6) ** 2)


def test_the_ring_radius_and_its_spread_round_the_axis() -> None:
    shape = peak_shape(ring(), X, X, Z)
    assert abs(shape.radius - 50e-6) <= 2e-6 * np.sqrt(2)
    # cells within half a cell of the largest one's radius differ by at most α (2 µm)² of it
    assert 0.0 < shape.ring_spread <= 2e8 * (2e-6 * np.sqrt(2) + 2e-6) ** 2
    flat = peak_shape(ring(alpha=0.0), X, X, Z)
    assert flat.ring_spread == pytest.approx(0.0, abs=1e-15)


def test_nan_cells_outside_the_box_are_ignored_and_edge_layers_refused() -> None:
    field = ring()
    field[:5] = np.nan
    assert peak_shape(field, X, X, Z).depth == pytest.approx(21.3e-6, rel=1e-9)
    with pytest.raises(ValueError, match="layer 0 of"):
        peak_shape(ring(z0=0.0), X, X, Z)


def block(half_x1: float, half_x2: float, deepest: float) -> np.ndarray:
    """1 on the cells whose centres lie within |x1| ≤ half_x1, |x2| ≤ half_x2, x3 ≤ deepest."""
    inside = ((np.abs(X)[:, None, None] <= half_x1) & (np.abs(X)[None, :, None] <= half_x2)
              & (Z[None, None, :] <= deepest))
    return inside.astype(float)


def test_the_extent_of_the_flow_is_read_to_the_outer_faces_of_its_cells() -> None:
    # centres to ±30 µm along x1 (faces ±32 µm), ±10 µm along x2; layers to 21 µm
    # (lower face 22 µm); the box's faces at ±100 µm and 0 to 60 µm
    field = block(31e-6, 11e-6, 22e-6)
    extent = plastic_extent(field, X, X, Z)
    assert extent.half_width == pytest.approx(32e-6, rel=1e-12)
    assert extent.box_half_width == pytest.approx(100e-6, rel=1e-12)
    assert extent.depth == pytest.approx(22e-6, rel=1e-12)
    assert extent.box_depth == pytest.approx(60e-6, rel=1e-12)
    assert extent.share == (16 * 6 * 11) / field.size
    assert extent.volume_share == pytest.approx(0.32**2 * 22 / 60, rel=1e-12)
    # about an axis at x1 = 8 µm the square reaches the face at −32 µm, 40 µm from it
    shifted = plastic_extent(field, X, X, Z, axis=(8e-6, 0.0))
    assert shifted.half_width == pytest.approx(40e-6, rel=1e-12)
    assert shifted.box_half_width == pytest.approx(108e-6, rel=1e-12)


def test_the_extent_ignores_nan_cells_and_refuses_a_field_that_never_flowed() -> None:
    field = block(31e-6, 31e-6, 22e-6)
    field[np.abs(X) > 60e-6] = np.nan
    extent = plastic_extent(field, X, X, Z)
    assert extent.half_width == pytest.approx(32e-6, rel=1e-12)
    with pytest.raises(ValueError, match="no cell"):
        plastic_extent(np.zeros_like(field), X, X, Z)


def run_file(path, field: np.ndarray) -> None:
    """A run file of two steps, ``field`` the last step's εp (as ``sacflow run`` stores it)."""
    import xarray as xr

    eqps = np.stack([np.zeros_like(field), field])
    xr.Dataset({"equivalent_plastic_strain": (("step", "x1", "x2", "x3"), eqps),
                "contact_area": (("step",), [0.0, np.pi * (60e-6) ** 2])},
               coords={"step": [0, 1], "x1": X, "x2": X, "x3": Z}).to_netcdf(path)


def _script():
    """``pipelines/press_plastic_peak.py`` as a module."""
    import importlib.util
    from pathlib import Path

    script = Path(__file__).resolve().parents[1] / "pipelines" / "press_plastic_peak.py"
    spec = importlib.util.spec_from_file_location("press_plastic_peak", script)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_script_reads_a_run_and_never_replaces_a_table(tmp_path, capsys) -> None:
    module = _script()
    run, table = tmp_path / "press.nc", tmp_path / "peak.csv"
    run_file(run, ring())
    assert module.main([str(run), "--table", str(table)]) == 0
    rows = {r.split(",")[0]: r.split(",")[1] for r in table.read_text().splitlines()[1:]}
    assert float(rows["its_depth"]) == pytest.approx(21.3e-6, rel=1e-9)
    assert float(rows["contact_radius"]) == pytest.approx(60e-6)
    limit = float(rows["certified_depth_limit"])
    assert float(rows["drop_at_certified_limit"]) == pytest.approx(
        4e8 * 0.07 * (limit - 21.3e-6) ** 2 / shape_value_at_vertex(), rel=1e-9)
    assert float(rows["plastic_share"]) == pytest.approx(float((ring() > 0).mean()), rel=1e-9)
    assert float(rows["plastic_depth"]) == pytest.approx(float(rows["box_depth"]), rel=1e-9)
    before = table.read_text()
    assert module.main([str(run), "--table", str(table)]) == 1
    assert "exists" in capsys.readouterr().err and table.read_text() == before
    assert module.main([str(tmp_path / "missing.nc")]) == 1
    assert "cannot read" in capsys.readouterr().err


def test_the_script_says_what_a_run_file_lacks(tmp_path, capsys) -> None:
    import xarray as xr

    module = _script()
    no_area = tmp_path / "no-area.nc"
    xr.Dataset({"equivalent_plastic_strain": (("step", "x1", "x2", "x3"), ring()[None])},
               coords={"step": [0], "x1": X, "x2": X, "x3": Z}).to_netcdf(no_area)
    assert module.main([str(no_area)]) == 1
    assert "stores no contact_area" in capsys.readouterr().err
    elastic = tmp_path / "elastic.nc"
    run_file(elastic, np.zeros_like(ring()))
    assert module.main([str(elastic)]) == 1
    assert "no plastic strain" in capsys.readouterr().err
