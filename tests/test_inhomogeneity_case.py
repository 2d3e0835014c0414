"""Elastic inhomogeneities as a case sees them (issue #33): schema, ids, translation, run files.

The numerics (rasterisation, Eshelby's equivalent eigenstrain, coupling) are the solver's and
tested there; here: ``[[body.inhomogeneity]]`` validates or fails with a message naming its
field, the ids of cases without inhomogeneities stay what they were, a cells file enters the id
by its contents, the case translates into ``SolverInputs.inhomogeneities``, and a run with the
inclusion fields round-trips through the store (restart included) while the comparison stages
read it as they read any run.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_array_equal
from test_store import make_state

from sacflow.compare.campaign import run_results
from sacflow.compare.fatigue_index import fatigue
from sacflow.config.inclusion_checks import (
    MIN_CELLS_PER_SEMI_AXIS,
    body_cells,
    box_depth,
    region_cells,
)
from sacflow.config.parsing import validate_case
from sacflow.config.schema import Case
from sacflow.config.solver_inputs import solver_inputs
from sacflow.errors import ConfigError, SacflowError
from sacflow.solver.state import INCLUSION_FIELDS, INCLUSION_SCALARS, GridCoords, State
from sacflow.storage.case_file import case_from_dict, load_case, read_file
from sacflow.storage.inclusion_cells_file import read_cells_file, read_inclusion_cells
from sacflow.storage.run_parts import parts_dir
from sacflow.storage.run_reader import open_run, read_scalars, run_info
from sacflow.storage.run_variables import INHOMOGENEITY_VARIABLES, PHASE_FILL, VARIABLES
from sacflow.storage.run_writer import RunWriter

ROOT = Path(__file__).resolve().parents[1]
HERTZ = ROOT / "configs" / "hertz-elastic.toml"
INCLUSION = ROOT / "configs" / "inclusion-hertz.toml"
#: A sphere resolved on hertz-elastic at 16 x 16 cells (1.13 µm) and 8 layers (1.51 µm).
SPHERE = {"shape": "sphere", "centre": [0.0, 0.0, 5e-6], "radius": 3.1e-6, "E": 380e9,
          "nu": 0.25}


def hertz_data(*items: dict, nz: int = 8) -> dict:
    """hertz-elastic at 16 x 16 cells and ``nz`` layers, with the inhomogeneities ``items``."""
    data = read_file(HERTZ)
    data["grid"].update(nx=16, ny=16, nz=nz)
    data["body"]["inhomogeneity"] = [dict(item) for item in items]
    return data


def problem(data: dict) -> str:
    """The one problem line of an invalid case."""
    with pytest.raises(ConfigError) as caught:
        case_from_dict(data, "case.toml")
    return str(caught.value).splitlines()[1].strip()


# --------------------------------------------------------------------------- schema
def test_a_sphere_validates_and_occupies_its_cells():
    case = case_from_dict(hertz_data(SPHERE))
    item = case.body.inhomogeneity[0]
    assert item.semi_axes_m() == (3.1e-6, 3.1e-6, 3.1e-6)
    cells = region_cells(item, body_cells(case))
    # cells whose centre is inside: about the sphere's volume in cells, symmetric about x3's axis
    volume = 4.0 / 3.0 * np.pi * 3.1e-6**3 / np.prod(body_cells(case).size)
    assert 0.6 * volume < len(cells) < 1.4 * volume
    i1 = sorted({c[0] for c in cells})
    assert i1 == sorted({2 * 8 - 1 - i for i in i1}), "symmetric about x1 = 0"


CHANGES = [  # (id, change of the sphere, words the message must hold)
    ("no-size", {"radius": None}, ["body.inhomogeneity.0.radius", "required", "sphere"]),
    ("two-sizes", {"semi_axes": [1e-6, 1e-6, 1e-6]},
     ["body.inhomogeneity.0.semi_axes", "not used", "radius"]),
    ("cuboid-without-half-sides", {"shape": "cuboid"},
     ["body.inhomogeneity.0.half_sides", "required"]),
    ("no-centre", {"centre": None}, ["body.inhomogeneity.0.centre", "required"]),
    ("above-surface", {"centre": [0.0, 0.0, 2e-6]},
     ["body.inhomogeneity.0.centre", "above the surface", "deeper"]),
    ("below-box", {"centre": [0.0, 0.0, 10e-6]},
     ["body.inhomogeneity.0.centre", "x3", "grid.depth"]),
    ("beside-window", {"centre": [8e-6, 0.0, 5e-6]},
     ["body.inhomogeneity.0.centre", "x1", "grid.half_width"]),
    ("unresolved", {"radius": 2e-6},
     ["body.inhomogeneity.0.radius", "cells", "per semi-axis", "grid.nx >="]),
    ("zero-modulus", {"E": 0.0}, ["body.inhomogeneity.0.E", "must be > 0", "cavity"]),
    ("nu-half", {"nu": 0.5}, ["body.inhomogeneity.0.nu", "(-1, 0.5)"]),
    ("unknown-shape", {"shape": "torus"}, ["body.inhomogeneity.0.shape", "'sphere'"]),
    ("cells-with-centre", {"shape": "cells", "radius": None, "cells": "points.txt"},
     ["body.inhomogeneity.0.centre", "not used", "cells"]),
]


@pytest.mark.parametrize(("change", "words"), [c[1:] for c in CHANGES],
                         ids=[c[0] for c in CHANGES])
def test_each_mistake_names_its_field(change, words):
    item = {k: v for k, v in {**SPHERE, **change}.items() if v is not None}
    line = problem(hertz_data(item))
    for word in words:
        assert word in line, line


def test_a_thin_layer_grid_names_nz():
    line = problem(hertz_data(SPHERE, nz=4))  # 3.0 µm layers: 1.03 layers per radius
    assert "body.inhomogeneity.0.radius" in line and "along x3" in line and "grid.nz >=" in line


def test_overlapping_inhomogeneities_are_refused_and_apart_ones_accepted():
    other = {**SPHERE, "centre": [2e-6, 0.0, 5e-6]}
    line = problem(hertz_data(SPHERE, other))
    assert line.startswith("body.inhomogeneity.1.centre: overlaps body.inhomogeneity.0")
    apart = [{**SPHERE, "centre": [-3.5e-6, 0.0, 5e-6]}, {**SPHERE, "centre": [3.5e-6, 0.0, 5e-6]}]
    assert len(case_from_dict(hertz_data(*apart)).body.inhomogeneity) == 2


def test_inclusion_output_fields_need_an_inhomogeneity():
    data = hertz_data()
    data["output"] = {"fields": ["pressure", "phase"]}
    assert problem(data).startswith("output.fields: phase needs an elastic inhomogeneity")
    data = hertz_data(SPHERE)
    data["output"] = {"fields": ["pressure", "phase", "inclusion_iterations"]}
    assert case_from_dict(data).stored_fields() == ("pressure", "phase", "inclusion_iterations")


def test_stored_fields_add_the_inclusion_fields_only_with_an_inhomogeneity():
    plain, holed = case_from_dict(hertz_data()), case_from_dict(hertz_data(SPHERE))
    inclusion = set(INCLUSION_FIELDS + INCLUSION_SCALARS)
    assert not inclusion & set(plain.stored_fields())
    assert set(holed.stored_fields()) == set(plain.stored_fields()) | inclusion


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(x=st.floats(-12e-6, 12e-6), depth=st.floats(-2e-6, 16e-6), radius=st.floats(1e-7, 8e-6),
       shape=st.sampled_from(["sphere", "ellipsoid", "cuboid"]))
def test_any_region_validates_or_names_a_field_of_it(x, depth, radius, shape):
    size = {"sphere": {"radius": radius}, "ellipsoid": {"semi_axes": [radius, radius, radius]},
            "cuboid": {"half_sides": [radius, radius, radius]}}[shape]
    item = {"shape": shape, "centre": [x, 0.0, depth], "E": 380e9, "nu": 0.25, **size}
    try:
        case = validate_case(hertz_data(item), "case.toml")
    except ConfigError as exc:
        line = str(exc).splitlines()[1].strip()
        assert line.startswith("body.inhomogeneity.0."), line
        return
    cells = body_cells(case)
    low1, high1 = cells.bounds(0)
    assert low1 <= x - radius and x + radius <= high1
    assert 0.0 <= depth - radius and depth + radius <= box_depth(case)
    assert min(radius / h for h in cells.size) >= MIN_CELLS_PER_SEMI_AXIS
    assert region_cells(case.body.inhomogeneity[0], cells)


ODD = st.one_of(st.none(), st.booleans(), st.integers(-3, 3), st.text(max_size=4),
                st.sampled_from([0.0, -1e-6, 1e-300, 1e300, float("nan"), float("inf")]),
                st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=4),
                st.dictionaries(st.sampled_from(["law", "E"]), st.integers(), max_size=2))


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(changes=st.dictionaries(
    st.sampled_from(["shape", "centre", "radius", "semi_axes", "half_sides", "cells", "E", "nu",
                     "hardening", "colour"]), ODD, max_size=3))
def test_any_mangled_inhomogeneity_validates_or_raises_config_error(changes):
    item = {**SPHERE, **changes}
    try:
        validate_case(hertz_data(item), "case.toml")
    except ConfigError as exc:
        assert "body.inhomogeneity.0" in str(exc)


# --------------------------------------------------------------------------- case ids
def test_cases_without_inhomogeneities_keep_their_ids():
    shipped = load_case(HERTZ)
    same = load_case(HERTZ, ["body.inhomogeneity=[]", "solver.inclusion_tolerance=1e-8",
                             "solver.inclusion_max_iterations=1000"])
    assert same.case_id == shipped.case_id
    assert "inhomogeneity" not in shipped.identity()["body"]
    assert load_case(HERTZ, ["solver.inclusion_tolerance=1e-6"]).case_id != shipped.case_id


def test_an_inhomogeneity_enters_the_id():
    with_one = case_from_dict(hertz_data(SPHERE))
    stiffer = case_from_dict(hertz_data({**SPHERE, "E": 400e9}))
    without = case_from_dict(hertz_data())
    assert len({with_one.case_id, stiffer.case_id, without.case_id}) == 3


def write_points(path: Path, points: np.ndarray, comment: str = "") -> Path:
    lines = [f"# cell centres x1 x2 x3 [m] {comment}"]
    lines += [" ".join(f"{v:.9e}" for v in p) for p in points]
    path.write_text("\n".join(lines) + "\n")
    return path


#: Points inside hertz-elastic's box at 16 x 16 x 8 cells.
POINTS = np.array([[0.0, 0.0, 4e-6], [1e-6, 0.0, 4e-6], [0.0, 1e-6, 5.5e-6]])


def cells_case_file(folder: Path, points_file: str) -> Path:
    """A case file beside ``folder/points_file`` naming it relatively."""
    text = HERTZ.read_text().replace("nx = 128", "nx = 16").replace("ny = 128", "ny = 16")
    text = text.replace("nz = 16", "nz = 8")
    text += ('\n[[body.inhomogeneity]]\nshape = "cells"\n'
             f'cells = "{points_file}"\nE = 1e9\nnu = 0.3\n')
    path = folder / "case.toml"
    path.write_text(text)
    return path


def test_a_cells_file_is_read_relative_to_the_case_and_its_contents_make_the_id(tmp_path):
    first, second = tmp_path / "a", tmp_path / "b"
    first.mkdir(), second.mkdir()
    write_points(first / "points.txt", POINTS)
    write_points(second / "points.txt", POINTS, comment="(the same points)")
    case = load_case(cells_case_file(first, "points.txt"))
    assert Path(case.body.inhomogeneity[0].cells) == first / "points.txt"
    assert case.identity()["body"]["inhomogeneity"][0]["cells"].startswith("sha256:")
    moved = first / "moved.txt"
    moved.write_bytes((first / "points.txt").read_bytes())
    assert load_case(cells_case_file(first, "moved.txt")).case_id == case.case_id
    assert load_case(cells_case_file(second, "points.txt")).case_id != case.case_id
    (points,) = read_inclusion_cells(case)
    assert_array_equal(points, POINTS)


@pytest.mark.parametrize(("content", "words"), [
    ("", ["no point"]),
    ("1e-6 2e-6\n", ["line 1", "three numbers"]),
    ("1e-6 x 2e-6\n", ["line 1", "three numbers"]),
    ("0 0 nan\n", ["non-finite"]),
    ("0 0 40e-6\n", ["beyond the cuboid box along x3", "grid.depth"]),
    ("50e-6 0 4e-6\n", ["beyond the cuboid box along x1"]),
])
def test_a_bad_cells_file_is_named(tmp_path, content, words):
    (tmp_path / "points.txt").write_text(content)
    with pytest.raises(ConfigError) as caught:
        load_case(cells_case_file(tmp_path, "points.txt"))
    message = str(caught.value)
    assert "body.inhomogeneity.0.cells" in message, message
    for word in words:
        assert word in message, message


def test_a_missing_cells_file_is_named(tmp_path):
    with pytest.raises(ConfigError, match=r"body\.inhomogeneity\.0\.cells: cannot read"):
        load_case(cells_case_file(tmp_path, "absent.txt"))


def test_cells_overlapping_a_sphere_are_refused(tmp_path):
    write_points(tmp_path / "points.txt", np.array([[0.0, 0.0, 5e-6]]))
    path = cells_case_file(tmp_path, "points.txt")
    path.write_text(path.read_text() + '\n[[body.inhomogeneity]]\nshape = "sphere"\n'
                    "centre = [0.0, 0.0, 5e-6]\nradius = 3.1e-6\nE = 380e9\nnu = 0.25\n")
    with pytest.raises(ConfigError, match="overlap body.inhomogeneity.1"):
        load_case(path)


# --------------------------------------------------------------------------- translation
def test_translation_into_solver_inputs(tmp_path):
    case = load_case(INCLUSION, ["solver.inclusion_tolerance=1e-9",
                                 "solver.inclusion_max_iterations=50"])
    inputs = solver_inputs(case)
    (item,) = inputs.inhomogeneities
    assert item.shape == "sphere" and item.cells is None
    assert item.centre == (0.0, 0.0, 151e-6) and item.semi_axes == (32e-6,) * 3
    assert (item.E, item.nu) == (380e9, 0.25)
    assert inputs.settings.inclusion_tolerance == 1e-9
    assert inputs.settings.inclusion_max_iterations == 50
    assert inputs.grid.depth == 300e-6
    assert solver_inputs(load_case(HERTZ)).inhomogeneities == ()
    assert solver_inputs(load_case(HERTZ)).settings.inclusion_tolerance == 1e-8


def test_translation_of_cells_and_its_missing_points(tmp_path):
    write_points(tmp_path / "points.txt", POINTS)
    case = load_case(cells_case_file(tmp_path, "points.txt"))
    with pytest.raises(SacflowError, match="read_inclusion_cells"):
        solver_inputs(case)
    (item,) = solver_inputs(case, cells=read_inclusion_cells(case)).inhomogeneities
    assert item.shape == "cells" and item.cells is not None
    assert_array_equal(item.cells, POINTS)
    assert item.centre == pytest.approx((0.5e-6, 0.5e-6, 4.75e-6))
    assert item.semi_axes == pytest.approx((0.5e-6, 0.5e-6, 0.75e-6))
    assert (item.E, item.nu) == (1e9, 0.3)


def test_ellipsoid_and_cuboid_sizes():
    ellipsoid = {**SPHERE, "shape": "ellipsoid", "radius": None,
                 "semi_axes": [3.0e-6, 2.5e-6, 3.2e-6]}
    cuboid = {**SPHERE, "shape": "cuboid", "radius": None, "half_sides": [2.5e-6, 3e-6, 3.1e-6]}
    for item, size in ((ellipsoid, (3.0e-6, 2.5e-6, 3.2e-6)), (cuboid, (2.5e-6, 3e-6, 3.1e-6))):
        clean = {k: v for k, v in item.items() if v is not None}
        (solved,) = solver_inputs(case_from_dict(hertz_data(clean))).inhomogeneities
        assert solved.shape == item["shape"] and solved.semi_axes == size


# --------------------------------------------------------------------------- run files
def inclusion_state(step: int, coords: GridCoords, phase: np.ndarray, volume: bool) -> State:
    """A fake state of a body with one inhomogeneity (the store's fake, plus its fields)."""
    state = make_state(step, coords, volume)
    state.inclusion_iterations = 3 * step + 1
    if volume:
        rng = np.random.default_rng(100 + step)
        state.volume["equivalent_eigenstrain"] = rng.standard_normal(coords.shape + (6,))
        state.volume["phase"] = phase
    state.restart = {"plastic_strain": np.zeros(coords.shape + (6,)),
                     "equivalent_plastic_strain": np.zeros(coords.shape),
                     "residual_displacement": np.zeros(coords.shape[:2]),
                     "pressure": np.ones(coords.shape[:2]),
                     "equivalent_eigenstrain": np.full(coords.shape + (6,), 1e-4 * step)}
    return state


def grid_of(case: Case) -> tuple[GridCoords, np.ndarray]:
    """The body grid of ``case`` and the phase of its cells (1 in the inhomogeneity)."""
    cells = body_cells(case)
    coords = GridCoords(*cells.centres)
    phase = np.zeros(coords.shape, dtype=np.int8)
    for index in region_cells(case.body.inhomogeneity[0], cells):
        phase[index] = 1
    return coords, phase


@pytest.fixture(scope="module")
def holed() -> Case:
    return case_from_dict(hertz_data(SPHERE))


def test_inclusion_fields_round_trip(tmp_path, holed):
    coords, phase = grid_of(holed)
    states = [inclusion_state(i, coords, phase, v) for i, v in enumerate([True, False, True])]
    path = tmp_path / "holed.nc"
    with RunWriter(path, holed, coords, fields=holed.stored_fields()) as writer:
        for state in states:
            writer.append(state)
    ds = open_run(path)
    for name in INHOMOGENEITY_VARIABLES:
        assert ds[name].attrs["units"] == "1" and ds[name].attrs["long_name"], name
    assert_array_equal(ds["inclusion_iterations"].values, [1, 4, 7])
    assert_array_equal(read_scalars(path)["inclusion_iterations"], [1, 4, 7])
    for index in (0, 2):
        assert_array_equal(ds["equivalent_eigenstrain"].values[index],
                           states[index].volume["equivalent_eigenstrain"])
        assert_array_equal(ds["phase"].values[index], phase)
    assert np.isnan(ds["equivalent_eigenstrain"].values[1]).all()
    assert np.isnan(ds["phase"].values[1]).all(), "phase not stored: missing, as other fields"
    assert ds["phase"].dims == ("step", "x1", "x2", "x3")
    import netCDF4

    with netCDF4.Dataset(path) as nc:
        assert nc["phase"].dtype == np.int8 and nc["phase"]._FillValue == PHASE_FILL
        assert nc["inclusion_iterations"].dtype == np.int32
    info = run_info(path)
    assert "phase" in info.variables
    assert info.case == holed and info.case.case_id == holed.case_id, "the case reads back"


def test_volume_precision_applies_to_the_equivalent_eigenstrain(tmp_path):
    data = hertz_data(SPHERE)
    data["output"] = {"volume_precision": "float32"}
    case = case_from_dict(data)
    coords, phase = grid_of(case)
    path = tmp_path / "single.nc"
    with RunWriter(path, case, coords, fields=case.stored_fields()) as writer:
        writer.append(inclusion_state(0, coords, phase, True))
    import netCDF4

    with netCDF4.Dataset(path) as nc:
        assert nc["equivalent_eigenstrain"].dtype == np.float32
        assert nc["stress"].dtype == np.float32 and nc["phase"].dtype == np.int8


def test_an_interrupted_inclusion_run_keeps_its_warm_start(tmp_path, holed):
    coords, phase = grid_of(holed)
    path = tmp_path / "holed.nc"
    writer = RunWriter(path, holed, coords, fields=holed.stored_fields())
    for step in range(2):
        writer.append(inclusion_state(step, coords, phase, step == 0))
    writer.abort()
    info = run_info(path)
    assert len(info.parts) == 2 and parts_dir(path).is_dir()
    restart = info.restart()
    assert restart is not None
    arrays, _ = restart
    assert_array_equal(arrays["equivalent_eigenstrain"], np.full(coords.shape + (6,), 1e-4))
    assert_array_equal(arrays["pressure"], np.ones(coords.shape[:2]))
    ds = open_run(path)  # the completed steps of the interrupted run
    assert_array_equal(ds["phase"].values[0], phase)
    assert_array_equal(ds["inclusion_iterations"].values, [1, 4])


def test_a_homogeneous_run_has_no_inclusion_variable(tmp_path):
    case = case_from_dict(hertz_data())
    cells_case = case_from_dict(hertz_data(SPHERE))
    coords, _ = grid_of(cells_case)
    path = tmp_path / "plain.nc"
    with RunWriter(path, case, coords, fields=case.stored_fields()) as writer:
        writer.append(make_state(0, coords))
    with RunWriter(tmp_path / "default.nc", case, coords) as writer:  # the writer's default
        writer.append(make_state(0, coords))
    for name in (path, tmp_path / "default.nc"):
        assert not set(INHOMOGENEITY_VARIABLES) & set(open_run(name).data_vars)
    assert not set(INHOMOGENEITY_VARIABLES) & set(VARIABLES)


def test_the_comparison_stages_read_an_inclusion_run_as_any_run(tmp_path, holed):
    """The fatigue stage and the campaign summary give on a run with the inclusion fields what
    they give on the same run without them."""
    coords, phase = grid_of(holed)
    plain = holed.model_copy(update={"body": holed.body.model_copy(update={"inhomogeneity": ()})})
    runs = {}
    for name, case in (("holed", holed), ("plain", plain)):
        runs[name] = tmp_path / f"{name}.nc"
        with RunWriter(runs[name], case, coords, fields=case.stored_fields()) as writer:
            for step in range(4):
                writer.append(inclusion_state(step, coords, phase, True))
    assert "phase" in open_run(runs["holed"]).data_vars
    assert "phase" not in open_run(runs["plain"]).data_vars
    holed_index, plain_index = fatigue(runs["holed"]), fatigue(runs["plain"])
    assert np.isfinite(float(holed_index["dang_van_max"]))
    for name in ("dang_van", "crossland"):
        assert_array_equal(holed_index[name].values, plain_index[name].values)
    holed_results = run_results(open_run(runs["holed"]))
    plain_results = run_results(open_run(runs["plain"]))
    for key, value in plain_results.items():
        if key != "wall_time":
            assert holed_results[key] == pytest.approx(value, nan_ok=True), key


def test_cells_file_reader_accepts_commas_and_comments(tmp_path):
    path = tmp_path / "p.csv"
    path.write_text("# x1, x2, x3\n1e-6, 2e-6, 3e-6  # first\n\n4e-6,5e-6,6e-6\n")
    assert_array_equal(read_cells_file(path), [[1e-6, 2e-6, 3e-6], [4e-6, 5e-6, 6e-6]])


# --------------------------------------------------------------------------- campaign pipeline
def test_the_campaign_pipeline_summarises_a_run_and_plots_index_against_depth(tmp_path, holed):
    import importlib.util

    from sacflow.compare.output import write

    spec = importlib.util.spec_from_file_location(
        "inclusion_campaign", ROOT / "pipelines" / "inclusion_campaign.py")
    assert spec is not None and spec.loader is not None
    pipeline = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(pipeline)
    coords, phase = grid_of(holed)
    with RunWriter(tmp_path / "one.nc", holed, coords, fields=holed.stored_fields()) as writer:
        for step in range(3):
            writer.append(inclusion_state(step, coords, phase, True))
    index = fatigue(tmp_path / "one.nc")
    write(index, tmp_path / "fatigue", "one-fatigue")
    row = pipeline.summary_row({"name": "one", "path": "one.nc"}, tmp_path,
                        tmp_path / "fatigue" / "one-fatigue.nc")
    assert set(row) == set(pipeline.COLUMNS)
    assert row["depth_over_a"] == pytest.approx(5e-6 / holed.hertz().a)
    assert row["modulus_ratio"] == pytest.approx(380 / 210)
    assert row["dang_van_max"] == float(index["dang_van_max"])
    assert row["inclusion_iterations_total"] == 1 + 4 + 7
    rows = [dict(row, depth_over_a=d, modulus_ratio=r, dang_van_max=d * r)
            for d in (0.25, 0.48) for r in (1.0, 1.81)]
    figure = pipeline.plot_index_vs_depth(rows)
    assert [line.get_label() for line in figure.axes[0].lines][:2] == ["$E_i/E$ = 1",
                                                                      "$E_i/E$ = 1.81"]
    table = pipeline.write_table(rows, tmp_path / "summary.csv")
    assert len(table.read_text().splitlines()) == 1 + len(rows)


def test_a_campaign_resolves_cells_files_against_the_files_naming_them(tmp_path):
    from sacflow.campaign import expand_campaign, load_campaign

    base_dir = tmp_path / "cases"
    base_dir.mkdir()
    write_points(base_dir / "points.txt", POINTS)
    cells_case_file(base_dir, "points.txt")
    write_points(tmp_path / "one.txt", POINTS[:1])
    write_points(tmp_path / "two.txt", POINTS[1:])
    campaign = tmp_path / "campaign.toml"
    campaign.write_text('name = "cells"\nbase = "cases/case.toml"\n[[sweep]]\nmode = "product"\n'
                        'parameters = { "body.inhomogeneity.0.cells" = ["one.txt", "two.txt"] }\n')
    cases = [c.case for c in expand_campaign(load_campaign(campaign))]
    assert [Path(c.body.inhomogeneity[0].cells) for c in cases] == [tmp_path / "one.txt",
                                                                   tmp_path / "two.txt"]
    assert cases[0].case_id != cases[1].case_id
    base = load_case(base_dir / "case.toml")
    assert Path(base.body.inhomogeneity[0].cells) == base_dir / "points.txt"


def test_the_memory_estimate_counts_the_eigenstrain_operator_of_an_elastic_holed_body(holed):
    from sacflow.config.solver_inputs import case_body_grid, estimate_case_memory
    from sacflow.solver.memory_estimate import estimate_memory

    plain = holed.model_copy(update={"body": holed.body.model_copy(update={"inhomogeneity": ()})})
    assert holed.body.hardening.law == "elastic"
    grid = case_body_grid(holed)
    assert estimate_case_memory(holed) == estimate_memory(grid, True, 5)
    assert estimate_case_memory(plain) == estimate_memory(grid, False, 5)
    assert estimate_case_memory(holed).total > estimate_case_memory(plain).total
