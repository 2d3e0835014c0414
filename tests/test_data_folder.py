"""``data/``: the reference data are what their scripts make, readable, and say what they are."""

from __future__ import annotations

import csv
import importlib.util

import numpy as np
import pytest
from reference_data import DATA, seed_rows, seed_value

from sacflow.config.solver_inputs import simulation_for
from sacflow.mechanics.hertz import hertz_contact
from sacflow.storage.case_file import case_from_dict
from sacflow.storage.surface_file import load_surface, read_measured_surface

SURFACES = DATA / "surfaces"


def _maker():
    spec = importlib.util.spec_from_file_location("make_surfaces", SURFACES / "make_surfaces.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_synthetic_surfaces_are_reproduced_byte_for_byte(tmp_path):
    maker = _maker()
    written = maker.write(tmp_path)
    assert {p.name for p in written} == set(maker.SURFACES)
    for path in written:
        shipped = SURFACES / path.name
        assert shipped.read_bytes() == path.read_bytes(), f"{path.name}: rerun the script"
        assert shipped.read_text().startswith("# SYNTHETIC surface, not measured")
        assert shipped.stat().st_size < 200_000


def test_synthetic_surfaces_read_as_measured_surfaces():
    cap = read_measured_surface(SURFACES / "dent-cap.txt", "text")
    # the grid points nearest the centre are 3.5 µm from it: within 3 % of the 2 µm depth
    assert cap.height.min() == pytest.approx(-2e-6, rel=0.03)
    assert cap.height.max() == 0.0
    rims = read_measured_surface(SURFACES / "dent-rims.txt", "text")
    assert rims.height.min() == pytest.approx(-2e-6, rel=0.03) and rims.height.max() > 0.0
    rough = read_measured_surface(SURFACES / "roughness.txt", "text")
    assert rough.height.shape == (32, 32)
    assert rough.height.std() == pytest.approx(0.1e-6, rel=1e-6)
    assert abs(rough.height.mean()) < 1e-15


def test_a_punch_in_the_synthetic_dent_meets_a_conforming_hollow():
    # The hollow of dent-rims.txt is nearly spherical at its bottom, of radius
    # 1/(A (k² + 2·13/w²)) = 110 µm (k = 2π/w) against the punch's 105 µm: the punch nests in it,
    # so the contact is wider and its pressure lower than on the flat. (Not compared with Hertz
    # at the conforming radius 2.3 mm: the file's 5 µm grid, interpolated, changes the gap by
    # tens of nm, as much as the conforming curvature over the contact.)
    radius, load = 105e-6, 0.65
    base = {
        "body": {"E": 210e9, "nu": 0.3, "hardening": {"law": "elastic"}},
        "counterbody": {"kind": "rigid", "radius": radius},
        "grid": {"nx": 64, "ny": 64, "nz": 4, "extent": [80e-6, 80e-6]},
        "load_path": [{"kind": "load", "to": load, "increments": 1}],
    }
    dented = case_from_dict({**base, "name": "synthetic-dent", "surface": {
        "kind": "measured", "path": str(SURFACES / "dent-rims.txt"), "format": "text"}})
    smooth = case_from_dict({**base, "name": "smooth"})
    in_dent = list(simulation_for(dented, surface=load_surface(dented)).run())[-1]
    on_flat = list(simulation_for(smooth).run())[-1]
    flat = hertz_contact(load, radius, 210e9 / (1.0 - 0.3**2))
    assert on_flat.max_pressure == pytest.approx(flat.p0, rel=0.05)
    assert in_dent.max_pressure < 0.6 * on_flat.max_pressure  # measured 0.49
    assert in_dent.contact_area > 1.5 * on_flat.contact_area


def test_seed_values_table_is_complete():
    rows = seed_rows()
    assert len(rows) >= 30
    with open(DATA / "seed_values.csv", newline="", encoding="utf-8") as f:
        keys = [r["key"] for r in csv.DictReader(x for x in f if not x.startswith("#"))]
    assert len(keys) == len(set(keys)), "keys are unique"
    for key, row in rows.items():
        assert np.isfinite(seed_value(key)), key
        assert row["source"].strip() and row["quote"].strip() and row["unit"].strip(), key
    assert seed_value("print_depth_650mN") == 80e-9
    assert seed_value("dent_peak_ratio_elastic_plastic") == 1.10


def test_config_regression_table_parses():
    with open(DATA / "config_regression.csv", newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(x for x in f if not x.startswith("#")))
    assert rows and all(r for r in rows)
