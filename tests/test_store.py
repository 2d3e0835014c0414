"""Run files: round trip, CF metadata, crash safety (atomic parts), resume, measured surfaces."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from datetime import datetime
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from numpy.testing import assert_array_equal

from sacflow.config.schema import Case
from sacflow.solver.state import (
    COMPONENTS,
    SCALAR_FIELDS,
    SURFACE_FIELDS,
    VOLUME_FIELDS,
    GridCoords,
    State,
)
from sacflow.storage.case_file import load_case
from sacflow.storage.run_parts import parts_dir
from sacflow.storage.run_reader import completed_steps, is_complete, open_run, read_scalars
from sacflow.storage.run_variables import VARIABLES
from sacflow.storage.run_writer import RunExistsError, RunWriter
from sacflow.storage.surface_file import read_measured_surface

CONFIG = Path(__file__).resolve().parents[1] / "configs" / "hertz-elastic.toml"
TENSORS = {"plastic_strain", "residual_stress", "stress", "backstress"}


# --------------------------------------------------------------------------- helpers (shared)
def small_case(**grid: int) -> Case:
    """The shipped Hertz case on a small grid (nx = ny = 16, nz = 3 unless given)."""
    sizes = {"nx": 16, "ny": 16, "nz": 3, **grid}
    return load_case(CONFIG, [f"grid.{k}={v}" for k, v in sizes.items()])


def make_coords(case: Case) -> GridCoords:
    """Cell-centred body grid of ``case``."""
    (l1, l2), (d1, d2) = case.window_extent(), case.cell_size()
    g = case.grid
    depth = g.depth or 2 * case.hertz().a
    return GridCoords(
        np.linspace(-l1 / 2 + d1 / 2, l1 / 2 - d1 / 2, g.nx),
        np.linspace(-l2 / 2 + d2 / 2, l2 / 2 - d2 / 2, g.ny),
        (np.arange(g.nz) + 0.5) * depth / g.nz,
    )


#: Surface fields with two components (x1, x2) per point.
VECTORS = {"shear_traction"}


def make_state(step: int, coords: GridCoords, volume: bool = True) -> State:
    """A reproducible fake state: random fields seeded by ``step``."""
    rng = np.random.default_rng(step)
    shape = coords.shape
    return State(
        step=step,
        segment=0,
        load=0.1 * (step + 1),
        approach=1e-8 * (step + 1),
        load_x1=1e-6 * step,
        load_x2=0.0,
        contact_area=rng.random() * 1e-10,
        max_pressure=rng.random() * 1e10,
        contact_iterations=int(rng.integers(1, 100)),
        plasticity_iterations=int(rng.integers(0, 100)),
        converged=True,
        surface={
            name: rng.standard_normal(shape[:2] + ((2,) if name in VECTORS else ()))
            for name in SURFACE_FIELDS
        },
        volume={
            name: rng.standard_normal(shape + ((6,) if name in TENSORS else ()))
            for name in VOLUME_FIELDS
        }
        if volume
        else {},
    )


def assert_step_matches(ds: xr.Dataset, index: int, state: State) -> None:
    """Stored step ``index`` equals ``state`` (volume NaN where the state had none)."""
    at = ds.isel(step=index)
    assert int(at.step) == state.step
    for name, value in state.scalars().items():
        assert at[name].item() == value, f"{name} at step {index}"
    for name in SURFACE_FIELDS:
        assert_array_equal(at[name].values, state.surface[name], err_msg=name)
    for name in VOLUME_FIELDS:
        if state.volume:
            assert_array_equal(at[name].values, state.volume[name], err_msg=name)
        else:
            assert np.isnan(at[name].values).all(), f"{name} should be NaN at step {index}"


def write_run(
    path: Path, case: Case, coords: GridCoords, volumes: list[bool], overwrite: bool = False
) -> list[State]:
    states = [make_state(i, coords, v) for i, v in enumerate(volumes)]
    with RunWriter(path, case, coords, overwrite=overwrite) as writer:
        for state in states:
            writer.append(state)
    return states


@pytest.fixture(scope="module")
def case() -> Case:
    return small_case()


@pytest.fixture(scope="module")
def coords(case: Case) -> GridCoords:
    return make_coords(case)


# --------------------------------------------------------------------------- metadata table
def test_table_covers_every_state_field():
    assert set(VARIABLES) == set(SCALAR_FIELDS + SURFACE_FIELDS + VOLUME_FIELDS)
    for name, var in VARIABLES.items():
        assert var.units and var.long_name, name
        if name in SURFACE_FIELDS:
            extra = ("direction",) if name in VECTORS else ()
            assert var.dims == ("step", "x1", "x2", *extra), name
        if name in VOLUME_FIELDS:
            assert var.dims[:4] == ("step", "x1", "x2", "x3"), name


# --------------------------------------------------------------------------- round trip
def test_round_trip(tmp_path, case, coords):
    path = tmp_path / "run.nc"
    states = write_run(path, case, coords, [True, False, True])
    assert not parts_dir(path).exists(), "parts must be removed after consolidation"
    assert is_complete(path, case.case_id) and completed_steps(path, case.case_id) == 3

    ds = open_run(path)
    # every variable is written (the writer's default): the traction's direction too
    assert dict(ds.sizes) == {"step": 3, "x1": 16, "x2": 16, "x3": 3, "component": 6,
                              "direction": 2}
    assert list(ds.direction.values) == ["1", "2"]
    for index, state in enumerate(states):
        assert_step_matches(ds, index, state)
    assert ds.converged.dtype == bool
    assert list(ds.component.values) == list(COMPONENTS)
    assert_array_equal(ds.x1.values, coords.x1)
    assert_array_equal(ds.x3.values, coords.x3)
    for name in list(ds.data_vars) + ["x1", "x2", "x3"]:
        assert "units" in ds[name].attrs and "long_name" in ds[name].attrs, name
        assert ds[name].attrs["units"] == VARIABLES.get(name, VARIABLES["load_x1"]).units
    assert ds.pressure.dims == ("step", "x1", "x2")
    assert ds.stress.dims == ("step", "x1", "x2", "x3", "component")
    assert ds.attrs["Conventions"] == "CF-1.10"
    assert ds.attrs["complete"] == 1
    assert ds.attrs["case_id"] == case.case_id
    assert Case.model_validate_json(ds.attrs["case"]) == case
    assert json.loads(ds.attrs["case"]) == json.loads(case.canonical_json())
    assert datetime.fromisoformat(ds.attrs["created"]).tzinfo is not None
    assert "sacflow_version" in ds.attrs and "title" in ds.attrs

    scalars = read_scalars(path)
    assert_array_equal(scalars["load"], [s.load for s in states])
    for name, values in scalars.items():  # as xarray decodes them (bool flags, NaN fill)
        assert values.dtype == ds[name].dtype, name
        assert_array_equal(values, ds[name].values)

    with xr.open_dataset(path) as plain:  # readable without sacflow
        assert plain.sizes["step"] == 3


def test_fields_filter_and_compression(tmp_path, case, coords):
    state = make_state(0, coords)
    for level in (0, 9):
        path = tmp_path / f"run{level}.nc"
        with RunWriter(path, case, coords, fields=["load", "pressure"], compression=level) as w:
            w.append(state)
        ds = open_run(path)
        assert set(ds.data_vars) == {"load", "pressure"}
        assert_array_equal(ds.pressure.isel(step=0).values, state.surface["pressure"])
    with pytest.raises(ValueError, match="unknown output fields"):
        RunWriter(tmp_path / "x.nc", case, coords, fields=["presure"])


def test_bad_state_is_rejected(tmp_path, case, coords):
    writer = RunWriter(tmp_path / "run.nc", case, coords)
    state = make_state(0, coords)
    state.surface["pressure"] = np.zeros((3, 3))
    with pytest.raises(ValueError, match="shape"):
        writer.append(state)
    state = make_state(0, coords)
    state.volume["pressure"] = np.zeros(coords.shape)
    with pytest.raises(ValueError, match="not a volume field"):
        writer.append(state)


def test_open_run_does_not_hold_the_file(tmp_path, case, coords):
    path = tmp_path / "run.nc"
    write_run(path, case, coords, [True])
    first = open_run(path)
    states = write_run(path, case, coords, [False, False], overwrite=True)  # replaces the file
    second = open_run(path)
    assert first.sizes["step"] == 1 and second.sizes["step"] == 2
    assert_step_matches(second, 1, states[1])


def test_open_run_missing(tmp_path):
    with pytest.raises(FileNotFoundError, match="no run"):
        open_run(tmp_path / "nothing.nc")


# --------------------------------------------------------------------------- crash safety
def test_crash_leaves_complete_steps_readable(tmp_path, case, coords):
    path = tmp_path / "run.nc"
    states = [make_state(i, coords, volume=i != 1) for i in range(3)]
    writer = RunWriter(path, case, coords)
    for state in states[:2]:
        writer.append(state)
    # the crash: a half-written temporary part, no consolidated file, no close()
    (parts_dir(path) / ".step-000002.nc.999.tmp").write_bytes(b"\x89HDF\r\n\x1a\ngarbage")
    assert not path.exists()
    del writer  # the crashed writer is gone, and its run lock with it

    ds = open_run(path)
    assert ds.sizes["step"] == 2 and ds.attrs["complete"] == 0
    for index in range(2):
        assert_step_matches(ds, index, states[index])
    assert completed_steps(path, case.case_id) == 2
    assert completed_steps(path, "another-case") == 0

    resumed = RunWriter(path, case, coords, keep_steps=2)
    assert resumed.next_step == 2
    resumed.append(states[2])
    resumed.close()
    ds = open_run(path)
    assert ds.sizes["step"] == 3 and ds.attrs["complete"] == 1
    for index, state in enumerate(states):
        assert_step_matches(ds, index, state)


def test_exception_keeps_parts_and_no_file(tmp_path, case, coords):
    path = tmp_path / "run.nc"
    with pytest.raises(RuntimeError, match="boom"), RunWriter(path, case, coords) as writer:
        writer.append(make_state(0, coords))
        raise RuntimeError("boom")
    assert not path.exists()
    assert completed_steps(path) == 1


def test_resume_rules(tmp_path, case, coords):
    path = tmp_path / "run.nc"
    writer = RunWriter(path, case, coords)
    writer.append(make_state(0, coords))
    writer.abort()  # interrupted
    other = case.model_copy(update={"grid": case.grid.model_copy(update={"nz": 5})})
    with pytest.raises(RunExistsError, match="interrupted run") as err:
        RunWriter(path, other, coords)
    assert "grid.nz: 3 -> 5" in str(err.value) and "--overwrite" in str(err.value)
    assert completed_steps(path) == 1, "the other case's parts are left alone"
    with pytest.raises(ValueError, match="cannot keep"):
        RunWriter(path, other, coords, keep_steps=1)
    assert RunWriter(path, other, coords, overwrite=True).next_step == 0, "asked: replaced"
    assert completed_steps(path) == 0

    write_run(path, case, coords, [True])
    with pytest.raises(ValueError, match="cannot keep"):
        RunWriter(path, case, coords, keep_steps=1)
    with pytest.raises(RunExistsError, match="finished run"):
        RunWriter(path, case, coords)
    assert path.exists(), "a finished run is not removed unless asked"
    assert RunWriter(path, case, coords, overwrite=True).next_step == 0
    assert not path.exists(), "a fresh start asked for removes the old run file"

def elastic_like_state(step: int, coords: GridCoords) -> State:
    """A state as an elastic body gives: zero plastic fields, infinite yield stress."""
    state = make_state(step, coords)
    for name in ("plastic_strain", "equivalent_plastic_strain", "residual_stress"):
        state.volume[name] = np.zeros_like(state.volume[name])
    state.volume["yield_stress"] = np.full(coords.shape, np.inf)
    state.surface["residual_displacement"] = np.zeros(coords.shape[:2])
    state.volume["stress"].reshape(-1)[[0, -1]] = 1.5  # equal ends, different inside
    return state


def test_uniform_fields_are_recorded_by_value_in_parts(tmp_path, case, coords):
    import netCDF4

    path = tmp_path / "run.nc"
    states = [elastic_like_state(i, coords) for i in range(3)]
    writer = RunWriter(path, case, coords)
    for state in states[:2]:
        writer.append(state)
    writer.abort()  # interrupted
    uniform = {"plastic_strain", "equivalent_plastic_strain", "residual_stress",
               "yield_stress", "residual_displacement"}
    part = next(parts_dir(path).glob("step-000001-*.nc"))
    with netCDF4.Dataset(part) as nc:
        recorded = json.loads(nc.uniform_fields)
        assert set(recorded) == uniform
        assert recorded["yield_stress"] == np.inf and recorded["plastic_strain"] == 0.0
        nc.set_auto_mask(False)
        assert np.isnan(nc["residual_stress"][0]).all(), "a uniform field is not written out"
        assert_array_equal(nc["stress"][0], states[1].volume["stress"])

    interrupted = open_run(path)  # the completed steps of an unfinished run
    assert "uniform_fields" not in interrupted.attrs
    for index in range(2):
        assert_step_matches(interrupted, index, states[index])

    resumed = RunWriter(path, case, coords, keep_steps=2)
    resumed.append(states[2])
    resumed.close()
    ds = open_run(path)
    assert "uniform_fields" not in ds.attrs and ds.attrs["complete"] == 1
    for index, state in enumerate(states):
        assert_step_matches(ds, index, state)



WRITER_SCRIPT = """
import sys, time
sys.path.insert(0, {tests!r})
from test_store import make_coords, make_state, small_case
from sacflow.storage.run_writer import RunWriter

case = small_case()
coords = make_coords(case)
with RunWriter({path!r}, case, coords) as writer:
    for step in range(5):
        writer.append(make_state(step, coords, volume=step % 2 == 0))
        time.sleep(0.6)
"""


def test_sigkill_mid_run_then_resume(tmp_path, case, coords):
    path = tmp_path / "killed.nc"
    script = WRITER_SCRIPT.format(tests=str(Path(__file__).parent), path=str(path))
    proc = subprocess.Popen([sys.executable, "-c", script])
    try:
        deadline = time.monotonic() + 60
        while completed_steps(path) < 2:
            assert proc.poll() is None, "writer process ended early"
            assert time.monotonic() < deadline, "writer too slow"
            time.sleep(0.05)
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        proc.kill()
        proc.wait()
    assert proc.returncode == -signal.SIGKILL
    assert not path.exists()

    states = [make_state(step, coords, volume=step % 2 == 0) for step in range(5)]
    ds = open_run(path)
    done = ds.sizes["step"]
    assert 2 <= done < 5 and ds.attrs["complete"] == 0
    for index in range(done):
        assert_step_matches(ds, index, states[index])

    with RunWriter(path, case, coords, keep_steps=done) as writer:
        assert writer.next_step == done
        for state in states[done:]:
            writer.append(state)
    ds = open_run(path)
    assert ds.sizes["step"] == 5 and ds.attrs["complete"] == 1
    for index, state in enumerate(states):
        assert_step_matches(ds, index, state)


# --------------------------------------------------------------------------- measured surfaces
def test_read_measured_surface_text_and_netcdf(tmp_path):
    x1, x2 = np.linspace(-1e-5, 1e-5, 5), np.linspace(-2e-5, 2e-5, 4)
    height = np.random.default_rng(1).standard_normal((5, 4)) * 1e-7
    g1, g2 = np.meshgrid(x1, x2, indexing="ij")
    rows = np.column_stack([g1.ravel(), g2.ravel(), height.ravel()])[::-1]  # any order
    text = tmp_path / "surface.txt"
    np.savetxt(text, rows, header="x1 x2 height [m]")
    csv = tmp_path / "surface.csv"
    np.savetxt(csv, rows, delimiter=",")
    nc = tmp_path / "surface.nc"
    xr.Dataset(
        {"z": (("a", "b"), height, {"units": "m"})},
        coords={"a": ("a", x1, {"units": "m"}), "b": ("b", x2, {"units": "m"})},
    ).to_netcdf(nc)
    for surface in (
        read_measured_surface(text),
        read_measured_surface(csv, "text"),
        read_measured_surface(nc, variable="z"),
    ):
        np.testing.assert_allclose(surface.x1, x1, rtol=1e-15)
        np.testing.assert_allclose(surface.x2, x2, rtol=1e-15)
        np.testing.assert_allclose(surface.height, height, rtol=1e-15)
    with pytest.raises(ValueError, match="no variable 'height'"):
        read_measured_surface(nc)


@pytest.mark.parametrize(
    ("content", "match"),
    [
        (None, "file not found"),
        ("0 0 1\n1 0 1\n0 1 1\n", "rectangular"),
        ("0 0\n1 1\n", "found 2 columns; expected three numeric columns"),
        ("hello world\n", "line 1: 'hello world' is not three numbers"),
    ],
)
def test_read_measured_surface_errors(tmp_path, content, match):
    path = tmp_path / "surface.txt"
    if content is not None:
        path.write_text(content)
    with pytest.raises(ValueError, match=match):
        read_measured_surface(path)
