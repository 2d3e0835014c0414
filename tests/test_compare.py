"""Comparison stages on synthetic runs with known answers, files, CLI, and one real Hertz run.

Synthetic runs are written with the real store (:class:`sacflow.storage.run_writer.RunWriter` from
:class:`sacflow.solver.state.State` objects) so that the stages see the exact data model. Fields are
chosen so that the answer is known in closed form: Hertz fields for the Hertz check, fields
linear in x1 and x2 where a stage interpolates laterally (linear interpolation is then exact),
even/odd profiles for the asymmetry, a ramp to a known plateau for the rolled track.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from numpy.testing import assert_allclose

from sacflow.cli import main
from sacflow.compare import (
    CompareError,
    campaign_summary,
    case_vs_reference,
    elastic_vs_plastic,
    hertz_check,
    indentation,
    load_approach,
    residual_map,
    summary,
    track,
    vertical_vs_rolling,
    write,
)
from sacflow.compare.core import RESULTS
from sacflow.compare.pairs import asymmetry
from sacflow.config.schema import Case, Dent, Dented
from sacflow.mechanics.hertz import hertz_contact, hertz_pressure
from sacflow.solver.state import COMPONENTS, GridCoords, State
from sacflow.storage.case_file import load_case
from sacflow.storage.run_reader import open_run
from sacflow.storage.run_writer import RunWriter

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
HERTZ = CONFIGS / "hertz-elastic.toml"
NANO = CONFIGS / "nanoindentation-190mN.toml"
SMALL = ["grid.nx=16", "grid.ny=16", "grid.nz=4"]
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


# --------------------------------------------------------------------------- builders
def centred(n: int, d: float, centre: float = 0.0) -> np.ndarray:
    """``n`` cell centres of spacing ``d`` around ``centre`` (a cell on it when n is odd)."""
    return centre + (np.arange(n) - (n - 1) / 2) * d


def make_coords(n1: int, n2: int, d: float, x3: np.ndarray, x1_0: float = 0.0) -> GridCoords:
    return GridCoords(centred(n1, d, x1_0), centred(n2, d), np.asarray(x3, dtype=float))


def mesh(coords: GridCoords) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x1, x2, x3) broadcast to the volume shape."""
    return np.meshgrid(coords.x1, coords.x2, coords.x3, indexing="ij")


def tensor(coords: GridCoords, **components: np.ndarray) -> np.ndarray:
    """A (n1, n2, n3, 6) tensor field from the named components (others zero)."""
    out = np.zeros((*coords.shape, 6))
    for name, values in components.items():
        out[..., COMPONENTS.index(name.lstrip("s"))] = values
    return out


def state(step: int, load: float, **kw) -> State:
    """A State with zero defaults for the scalars not given."""
    scalars = dict(
        segment=0,
        approach=0.0,
        load_x1=0.0,
        load_x2=0.0,
        contact_area=0.0,
        max_pressure=0.0,
        contact_iterations=1,
        plasticity_iterations=0,
    )
    surface, volume = kw.pop("surface", {}), kw.pop("volume", {})
    scalars.update(kw)
    return State(step=step, load=load, surface=surface, volume=volume, **scalars)


def write_run(path: Path, case: Case, coords: GridCoords, states: list[State], **attrs):
    """Write ``states`` with the store, add global attributes, return the opened run."""
    with RunWriter(path, case, coords) as writer:
        for s in states:
            writer.append(s)
    if attrs:
        ds = open_run(path)
        ds.attrs.update(attrs)
        ds.to_netcdf(path.with_suffix(".tmp"))
        path.with_suffix(".tmp").replace(path)
    return open_run(path)


def assert_written(result: xr.Dataset, tmp_path: Path, stem: str) -> xr.Dataset:
    """write() makes stem.nc (reopenable, same numbers, CF metadata) and a PNG."""
    nc, png = write(result, tmp_path / "out", stem)
    assert nc == tmp_path / "out" / f"{stem}.nc" and png.suffix == ".png"
    assert png.read_bytes()[:8] == PNG_SIGNATURE and png.stat().st_size > 10_000
    assert not list((tmp_path / "out").glob(".*.tmp")), "temporary files left behind"
    with xr.open_dataset(nc) as back:
        back = back.load()
    for name in list(back.variables):
        assert back[name].attrs.get("units") and back[name].attrs.get("long_name"), name
    for name, var in result.data_vars.items():
        if var.ndim == 0:
            assert_allclose(float(back[name]), float(var), rtol=1e-12, err_msg=name)
    assert back.attrs["stage"] == result.attrs["stage"]
    assert summary(result).splitlines()[0].startswith(result.attrs["stage"])
    return back


@pytest.fixture(scope="module")
def hertz_case() -> Case:
    return load_case(HERTZ, [*SMALL, "load_path.0.increments=4"])


@pytest.fixture(scope="module")
def nano_case() -> Case:
    return load_case(NANO, [*SMALL, "load_path.0.increments=2", "load_path.1.increments=2"])


# --------------------------------------------------------------------------- 1. hertz_check
def hertz_run(path: Path, case: Case, pressure_factor: float = 1.0) -> xr.Dataset:
    """Every step exactly Hertz (odd grid: a cell centre on the load axis)."""
    ref = case.hertz()
    coords = make_coords(25, 25, 3 * ref.a / 25, [ref.a / 2])
    x1, x2 = np.meshgrid(coords.x1, coords.x2, indexing="ij")
    states = []
    for k, load in enumerate(np.linspace(0, case.max_load, 5)[1:]):
        h = hertz_contact(load, ref.radius, ref.e_star)
        p = hertz_pressure(np.hypot(x1, x2), h.a, h.p0) * pressure_factor
        states.append(
            state(
                k,
                load,
                approach=h.approach,
                contact_area=math.pi * h.a**2,
                max_pressure=p.max(),
                surface={"pressure": p},
            )
        )
    return write_run(path, case, coords, states)


def test_hertz_check_exact_hertz_gives_zero_error(tmp_path, hertz_case):
    ds = hertz_run(tmp_path / "hertz.nc", hertz_case)
    result = hertz_check(ds)
    ref = hertz_case.hertz()
    assert_allclose(float(result.p0_hertz), ref.p0, rtol=1e-12, err_msg="Hertz p0 of the case")
    for name in ("p0_error", "contact_radius_error", "approach_max_error", "profile_error"):
        assert abs(float(result[name])) < 1e-12, name
    assert_allclose(result.approach_error, 0.0, atol=1e-12, err_msg="approach along the steps")
    assert_allclose(result.pressure, result.pressure_hertz, rtol=0, atol=1e-9 * ref.p0)
    assert result.attrs["step_max_load"] == 3 and result.sizes["step"] == 4
    back = assert_written(result, tmp_path, "hertz")
    assert back.pressure.attrs["units"] == "Pa" and back.p0_error.attrs["units"] == "1"


def test_hertz_check_measures_a_known_error(tmp_path, hertz_case):
    result = hertz_check(hertz_run(tmp_path / "hertz.nc", hertz_case, pressure_factor=1.03))
    assert_allclose(float(result.p0_error), 0.03, rtol=1e-9, err_msg="3 % too high pressure")
    assert_allclose(float(result.profile_error), 0.03, rtol=1e-9)


# --------------------------------------------------------------------------- 2. indentation
L = 10e-6  # length scale of the lateral (linear) variation of the synthetic fields


def eps_depth(x3):
    return 0.006 * np.exp(-(((x3 - 1.25e-6) / 1e-6) ** 2))


def s11_depth(x3):
    return -400e6 + 300e6 * x3 / 1e-6


def s33_depth(x3):
    return -50e6 * np.exp(-x3 / 1e-6)


def indentation_run(
    path: Path, case: Case, cells: int = 15, paraboloid: bool = False
) -> tuple[xr.Dataset, GridCoords]:
    """Load to 0.19 N in 2 steps, unload in 2; fields f(x3) · (1 + x1/L + x2/L).

    The print is an 80 nm deep Gaussian, or with ``paraboloid`` 80 nm (1 − r²/(6 µm)²).
    """
    coords = make_coords(cells, cells, 1e-6, (np.arange(6) + 0.5) * 0.5e-6)
    x1, x2, x3 = mesh(coords)
    lateral = 1 + x1 / L + x2 / L
    r2 = coords.x1[:, None] ** 2 + coords.x2[None, :] ** 2
    states = []
    # with ``paraboloid``, σ11 is a bowl: -400 MPa (1 - r²/(6 µm)²) (1 - (x3 - 1.3 µm)²/(2 µm)²),
    # quadratic along each axis, deepest on the axis at 1.3 µm, between layer centres
    s11 = (-400e6 * (1 - (x1**2 + x2**2) / (6e-6) ** 2) * (1 - ((x3 - 1.3e-6) / 2e-6) ** 2)
           if paraboloid else s11_depth(x3) * lateral)
    for k, (load, seg, factor) in enumerate(
        [(0.095, 0, 0.5), (0.19, 0, 0.9), (0.095, 1, 1.0), (0.0, 1, 1.0)]
    ):
        volume = {
            "equivalent_plastic_strain": factor * eps_depth(x3) * lateral,
            "residual_stress": factor * tensor(coords, s11=s11, s33=s33_depth(x3) * lateral),
        }
        shape = 1.0 - r2 / (6e-6) ** 2 if paraboloid else np.exp(-r2 / (3e-6) ** 2)
        surface = {"residual_displacement": factor * 80e-9 * shape}
        states.append(state(k, load, segment=seg, surface=surface, volume=volume))
    return write_run(path, case, coords, states), coords


def test_indentation_profiles_known_fields(tmp_path, nano_case):
    ds, coords = indentation_run(tmp_path / "nano.nc", nano_case)
    result = indentation(ds, offsets=(0.0, 2e-6))
    x3 = coords.x3
    assert list(result.when.values) == ["max_load", "last"]
    assert list(result.step.values) == [1, 3]
    for when, factor in (("max_load", 0.9), ("last", 1.0)):
        for offset, lateral in ((0.0, 1.0), (2e-6, 1.2)):
            at = result.sel(when=when, offset=offset)
            msg = f"{when}, offset {offset}"
            assert_allclose(
                at.equivalent_plastic_strain,
                factor * lateral * eps_depth(x3),
                rtol=1e-10,
                err_msg=msg,
            )
            assert_allclose(
                at.residual_stress_11, factor * lateral * s11_depth(x3), rtol=1e-10, err_msg=msg
            )
            assert_allclose(
                at.residual_stress_33, factor * lateral * s33_depth(x3), rtol=1e-10, err_msg=msg
            )
    # global maximum: the corner x1 = x2 = 7 µm, in the layer at 1.25 µm
    assert_allclose(float(result.max_plastic_strain), 0.006 * (1 + 1.4), rtol=1e-12)
    assert_allclose(
        [
            float(result.max_plastic_strain_x1),
            float(result.max_plastic_strain_x2),
            float(result.max_plastic_strain_depth),
        ],
        [7e-6, 7e-6, 1.25e-6],
        rtol=1e-12,
    )
    assert_allclose(float(result.print_depth), 80e-9, rtol=1e-12)
    assert_allclose(float(result.print_depth_refined), 80e-9, rtol=1e-12)
    assert_allclose(float(result.residual_stress_11_first_layer), s11_depth(x3[0]), rtol=1e-10)
    assert_allclose(float(result.residual_stress_33_first_layer), s33_depth(x3[0]), rtol=1e-10)
    assert_allclose(float(result.residual_stress_11_axis_min), s11_depth(x3).min(), rtol=1e-10)
    assert_allclose(float(result.residual_stress_11_axis_min_depth), x3[0], rtol=1e-12)
    assert_allclose(float(result.residual_stress_11_axis_min_refined), s11_depth(x3).min(),
                    rtol=1e-10)
    assert_allclose(float(result.residual_stress_11_axis_max), s11_depth(x3).max(), rtol=1e-10)
    assert_allclose(float(result.residual_stress_33_axis_min), s33_depth(x3).min(), rtol=1e-10)
    assert_allclose(float(result.residual_stress_33_axis_max), s33_depth(x3).max(), rtol=1e-10)
    assert_written(result, tmp_path, "indentation")


def test_print_depth_refined_finds_the_axis_between_cell_centres(tmp_path, nano_case):
    # 16 cells: the axis lies on the corner of four cells, half a cell from their centres,
    # where the print is 80 nm (1 - 0.5 µm² / 36 µm²) deep; a paraboloid is refined exactly.
    ds, _ = indentation_run(tmp_path / "even.nc", nano_case, cells=16, paraboloid=True)
    result = indentation(ds, offsets=(0.0,))
    assert_allclose(float(result.print_depth), 80e-9 * (1 - 0.5 / 36), rtol=1e-12)
    assert_allclose(float(result.print_depth_refined), 80e-9, rtol=1e-12)
    # σ11's bowl: on the axis at 1.3 µm it is -400 MPa; the linear reading at the corner and
    # the layer centres misses that, the quadratic one to the axis and the parabola in depth not
    assert float(result.residual_stress_11_axis_min) > -400e6 * (1 - 0.25 / 36)
    assert_allclose(float(result.residual_stress_11_axis_min_refined), -400e6, rtol=1e-12)


def test_quadratic_at_is_exact_for_quadratics_in_each_coordinate():
    from sacflow.compare.fields import quadratic_at

    x = np.arange(8) + 0.5 - 4.0
    y = 0.5 * (np.arange(6) + 0.5)
    z = np.linspace(0.1, 2.0, 5)
    X, Y, Z = np.meshgrid(x, y, z, indexing="ij")

    def f(a, b, c):
        return 3 + 0.2 * a**2 - 0.1 * b**2 + 0.3 * a * b + 0.5 * a + c**2 + a**2 * b**2

    values = f(X, Y, Z)
    # the corner of four cells (the axis of an even grid), an edge, outside by half a cell
    for point in ((0.0, 1.5), (3.9, 0.1), (-4.0, 3.0)):
        assert_allclose(quadratic_at(values, (x, y), point), f(*point, z), rtol=1e-13)
    assert_allclose(quadratic_at(values, (x, y, z), (0.0, 1.5, 1.3)), f(0.0, 1.5, 1.3),
                    rtol=1e-13)
    # a cubic is not exact: the rule is of order h³, not a global fit
    cubic = X**3
    assert abs(float(quadratic_at(cubic, (x,), (0.0,))[0, 0])) > 0.0


# --------------------------------------------------------------------------- 3. load_approach
def test_load_approach_shifted_unloading(tmp_path, nano_case):
    ref = nano_case.hertz()

    def d_h(w):
        return hertz_contact(w, ref.radius, ref.e_star).approach

    shift = 0.2 * d_h(0.19)
    steps = [
        (0.095, 0, 1.2 * d_h(0.095)),
        (0.19, 0, 1.2 * d_h(0.19)),
        (0.095, 1, d_h(0.095) + shift),
        (0.0, 1, shift),
    ]
    coords = make_coords(9, 9, 1e-6, [1e-6])
    states = [state(k, w, segment=s, approach=d) for k, (w, s, d) in enumerate(steps)]
    ds = write_run(tmp_path / "nano.nc", nano_case, coords, states)
    csv = tmp_path / "fe.csv"
    csv.write_text("# finite elements\napproach,load\n0,0\n1e-7,0.05\n2e-7,0.12\n")
    result = load_approach(ds, reference=csv)
    assert list(result.branch.values) == ["loading", "loading", "unloading", "unloading"]
    assert_allclose(float(result.unloading_shift), shift, rtol=1e-12)
    assert abs(float(result.unloading_deviation)) < 1e-12, "shifted unloading lies on Hertz"
    assert_allclose(float(result.residual_approach), shift, rtol=1e-12)
    assert_allclose(float(result.approach_max_error), 0.2, rtol=1e-12)
    assert_allclose(result.approach_shifted.values[2:], [d_h(0.095), 0.0], atol=1e-18)
    assert np.isnan(result.approach_shifted.values[:2]).all()
    assert_allclose(result.hertz_approach[-1], d_h(0.19), rtol=1e-12)
    assert_allclose(result.reference_load, [0, 0.05, 0.12])
    assert_written(result, tmp_path, "load-approach")


# --------------------------------------------------------------------------- 4. elastic_vs_plastic
def test_elastic_vs_plastic_peak_ratio(tmp_path, hertz_case):
    coords = make_coords(41, 9, 5e-6, [1e-6])
    x1, x2 = np.meshgrid(coords.x1, coords.x2, indexing="ij")
    ring = np.exp(-(((np.abs(x1) - 40e-6) / 20e-6) ** 2)) * (1 - (x2 / 30e-6) ** 2)
    runs = {}
    for name, peak in (("elastic", 2.75e9), ("plastic", 2.5e9)):
        states = [
            state(0, 1.0, surface={"pressure": 0.5 * peak * ring}),
            state(1, 2.0, surface={"pressure": peak * ring}),
        ]
        case = hertz_case.model_copy(update={"name": f"dent-{name}"})
        runs[name] = write_run(tmp_path / f"{name}.nc", case, coords, states)
    result = elastic_vs_plastic(runs["elastic"], runs["plastic"])
    assert_allclose(float(result.peak_ratio), 1.1, rtol=1e-12, err_msg="10 % higher elastic peak")
    assert_allclose(float(result.peak_elastic), 2.75e9, rtol=1e-12)
    assert_allclose(float(result.peak_plastic), 2.5e9, rtol=1e-12)
    assert abs(float(result.peak_elastic_x1)) == pytest.approx(40e-6, rel=1e-9)
    assert result.attrs["profile_x2_elastic"] == 0.0 and result.attrs["step_plastic"] == 1
    assert result.attrs["case"] == "dent-elastic vs dent-plastic"
    assert_written(result, tmp_path, "elastic-vs-plastic")


# --------------------------------------------------------------------------- 5. vertical_vs_rolling
def sigma_run(path: Path, case: Case, coords: GridCoords, profile, layer: int) -> xr.Dataset:
    """Residual σ11 = profile(x1) · (1 − (x2/L2)²) in ``layer``, half of it elsewhere."""
    x1, x2, _ = mesh(coords)
    s11 = 0.5 * profile(x1) * (1 - (x2 / 300e-6) ** 2)
    s11[:, :, layer] *= 2.0
    volume = {"residual_stress": tensor(coords, s11=s11)}
    return write_run(
        path, case, coords, [state(0, 1318.0, volume=volume), state(1, 0.0, volume=volume)]
    )


def test_vertical_vs_rolling_min_and_asymmetry(tmp_path, hertz_case):
    dent_x1, w = 20e-6, 60e-6
    dented = hertz_case.model_copy(
        update={
            "name": "dent-vertical",
            "surface": Dented(dents=(Dent(depth=35e-6, width=450e-6, x1=dent_x1),)),
        }
    )
    coords = make_coords(41, 9, 10e-6, [15e-6, 45e-6, 75e-6, 105e-6], x1_0=dent_x1)

    def even(x):
        return np.exp(-(((x - dent_x1) / w) ** 2))

    def vertical(x):
        return -500e6 * even(x)

    def rolling(x):
        return -650e6 * even(x) + 100e6 * (x - dent_x1) / w * even(x)

    ds_v = sigma_run(tmp_path / "v.nc", dented, coords, vertical, layer=2)
    ds_r = sigma_run(
        tmp_path / "r.nc",
        dented.model_copy(update={"name": "dent-rolling"}),
        coords,
        rolling,
        layer=2,
    )
    result = vertical_vs_rolling(ds_v, ds_r, depth=70e-6, x2=2e-6)
    assert result.attrs["depth_vertical"] == 75e-6 and result.attrs["x2_rolling"] == 0.0
    assert result.attrs["centre"] == dent_x1, "default centre: the dent"
    x = coords.x1
    assert_allclose(float(result.min_vertical), -500e6, rtol=1e-12)
    assert_allclose(float(result.min_vertical_x1), dent_x1, rtol=1e-12)
    assert_allclose(float(result.min_rolling), rolling(x).min(), rtol=1e-12)
    assert_allclose(float(result.min_rolling_x1), x[np.argmin(rolling(x))], rtol=1e-12)
    assert_allclose(float(result.min_ratio), rolling(x).min() / -500e6, rtol=1e-12)
    assert float(result.asymmetry_vertical) < 1e-12, "symmetric about the dent"
    odd = 100e6 * (x - dent_x1) / w * even(x)
    assert_allclose(
        float(result.asymmetry_rolling), np.abs(2 * odd).max() / -rolling(x).min(), rtol=1e-10
    )
    assert_written(result, tmp_path, "vertical-vs-rolling")


def test_asymmetry_of_a_shifted_centre():
    x = np.linspace(-1, 1, 201)
    assert asymmetry(x, -np.exp(-(x**2)), 0.0) < 1e-12
    assert asymmetry(x, -np.exp(-(x**2)), 0.3) > 0.1


# --------------------------------------------------------------------------- 6. track
def track_run(path: Path, case: Case, profile) -> xr.Dataset:
    """Load at x1 = 0, roll to 100 µm in 10 steps, unload; residual displacement profile(x1)."""
    coords = make_coords(281, 3, 0.5e-6, [1e-6], x1_0=50e-6)
    u = np.repeat(profile(coords.x1)[:, None], 3, axis=1)
    states = [
        state(k, 1.0, load_x1=10e-6 * k, surface={"residual_displacement": u}) for k in range(11)
    ]
    states.append(state(11, 0.0, load_x1=100e-6, surface={"residual_displacement": u}))
    return write_run(path, case, coords, states)


def test_track_profile_steady_state_distance(tmp_path, hertz_case):
    plateau, s0 = 40e-9, 20e-6

    def ramp(x):
        return np.where(x > 100e-6, 0.0, plateau * np.clip(x / s0, 0.0, 1.0))

    result = track(track_run(tmp_path / "roll.nc", hertz_case, ramp))
    assert_allclose(float(result.plateau), plateau, rtol=1e-12)
    # first cell centre at or beyond 0.98 s0 (cells every 0.5 µm on integer half-microns)
    assert_allclose(float(result.steady_state_distance), 20e-6, rtol=1e-9)
    assert_allclose(
        float(result.steady_state_distance_over_a), 20e-6 / hertz_case.hertz().a, rtol=1e-9
    )
    assert (float(result.track_start), float(result.track_end)) == (0.0, 100e-6)
    assert_allclose(result.track_distance, result.x1, atol=1e-18)
    assert_written(result, tmp_path, "track")

    slope = track(
        track_run(tmp_path / "slope.nc", hertz_case, lambda x: plateau * np.clip(x / 100e-6, 0, 1))
    )
    assert np.isnan(float(slope.steady_state_distance)), "never steady"


def test_track_profile_needs_a_rolled_track(tmp_path, hertz_case):
    ds, _ = indentation_run(tmp_path / "nano.nc", hertz_case)
    with pytest.raises(CompareError, match="no rolled track"):
        track(ds)


# --------------------------------------------------------------------------- 7. residual_map
def test_residual_map_layer_and_extrema(tmp_path, hertz_case):
    coords = make_coords(21, 15, 10e-6, [35e-6, 65e-6, 95e-6])
    x1, x2, x3 = mesh(coords)
    field = (
        -500e6
        * np.exp(-((x1 - 30e-6) ** 2 + (x2 + 20e-6) ** 2) / (50e-6) ** 2)
        * (1 + (x3 - 65e-6) / 100e-6)
    )
    ds = write_run(
        tmp_path / "dent.nc",
        hertz_case,
        coords,
        [state(0, 1.0, volume={"residual_stress": tensor(coords, s33=field)})],
    )
    result = residual_map(ds, depth=60e-6, component="33")
    assert result.attrs["depth"] == 65e-6 and result.attrs["component"] == "33"
    assert_allclose(result.residual_stress_map.transpose("x1", "x2"), field[:, :, 1], rtol=1e-12)
    assert_allclose(float(result.map_min), -500e6, rtol=1e-12)
    assert_allclose(
        [float(result.map_min_x1), float(result.map_min_x2)], [30e-6, -20e-6], rtol=1e-12
    )
    assert "σ33" in result.residual_stress_map.attrs["long_name"]
    assert_allclose(
        float(residual_map(ds, depth=65e-6).map_min), 0.0, atol=0, err_msg="σ11 is zero in this run"
    )
    assert_written(result, tmp_path, "residual-map")
    with pytest.raises(CompareError, match="component"):
        residual_map(ds, component="44")


# --------------------------------------------------------------------------- 8. campaign_summary
def campaign_runs(tmp_path: Path, case: Case) -> list[Path]:
    coords = make_coords(5, 5, 1e-6, [0.5e-6, 1.5e-6])
    paths = []
    for k, load in enumerate((0.10, 0.15, 0.19)):
        c = load_case(NANO, [*SMALL, f"load_path.0.to={load}", f"name=sweep-{k}"])
        x1, x2, x3 = mesh(coords)
        eps = load * 0.01 * np.exp(-(x1**2 + x2**2) / 1e-12) * (x3 > 1e-6)
        volume = {
            "equivalent_plastic_strain": eps,
            "residual_stress": tensor(coords, s11=-load * 1e9 * (x3 > 1e-6) + 1e6),
        }
        surface = {"residual_displacement": np.full((5, 5), load * 1e-7)}
        states = [
            state(
                0,
                load,
                max_pressure=load * 3e10,
                contact_iterations=10,
                plasticity_iterations=5 * (k + 1),
                volume=volume,
                surface=surface,
            ),
            state(1, 0.0, contact_iterations=3),
        ]
        write_run(tmp_path / f"{c.name}.nc", c, coords, states, wall_time=float(k + 1))
        paths.append(tmp_path / f"{c.name}.nc")
    return paths


def test_campaign_summary_parameters_from_attrs_and_manifest(tmp_path, nano_case):
    paths = campaign_runs(tmp_path, nano_case)
    result = campaign_summary(paths)
    assert result.attrs["parameters"] == "load_path_0_to", "the one swept key, CF-named"
    assert result.attrs["parameter_paths"] == "load_path.0.to"
    assert result["load_path_0_to"].attrs["parameter_path"] == "load_path.0.to"
    assert list(result.case.values) == ["sweep-0", "sweep-1", "sweep-2"]
    loads = np.array([0.10, 0.15, 0.19])
    assert_allclose(result["load_path_0_to"], loads)
    assert_allclose(result.max_plastic_strain, loads * 0.01, rtol=1e-12)
    assert_allclose(result.max_plastic_strain_depth, 1.5e-6)
    assert_allclose(result.max_plastic_strain_x1, 0.0, atol=0)
    assert_allclose(result.residual_stress_11_min, -loads * 1e9 + 1e6, rtol=1e-12)
    assert_allclose(result.residual_stress_11_max, 1e6, rtol=1e-12)
    assert_allclose(result.dent_depth, loads * 1e-7, rtol=1e-12)
    assert_allclose(result.peak_pressure, loads * 3e10, rtol=1e-12)
    assert_allclose(result.iterations_total, [18, 23, 28])
    assert_allclose(result.wall_time, [1.0, 2.0, 3.0])
    assert_written(result, tmp_path, "campaign")

    manifest = tmp_path / "sweep.manifest.json"
    manifest.write_text(
        json.dumps(
            {
                "campaign": "sweep",
                "cases": [
                    {
                        "index": k,
                        "name": p.stem,
                        "case_id": "x",
                        "path": p.name,
                        "status": "done",
                        "parameters": {"load": load, "label": f"L{k}"},
                        "wall_time": 10.0 + k,
                    }
                    for k, (p, load) in enumerate(zip(paths, loads, strict=True))
                ],
            }
        )
    )
    from_manifest = campaign_summary(manifest)  # the manifest alone lists the runs
    assert from_manifest.attrs["parameters"] == "load label"
    assert_allclose(from_manifest["load"], loads)
    assert list(from_manifest["label"].values) == ["L0", "L1", "L2"]
    assert_allclose(from_manifest.wall_time, [1.0, 2.0, 3.0], err_msg="run attrs come first")
    keys = campaign_summary(paths, parameters=["body.E", "load_path.0.to"])
    assert_allclose(keys["body_E"], 210e9)


# --------------------------------------------------------------------------- 9. case_vs_reference
def test_case_vs_reference_csv_and_netcdf(tmp_path, hertz_case):
    coords = make_coords(21, 5, 1e-6, [1e-6])
    x1, x2 = np.meshgrid(coords.x1, coords.x2, indexing="ij")
    pressure = 1e9 + 1e14 * x1 + 1e14 * x2  # linear: interpolation is exact
    ds = write_run(
        tmp_path / "run.nc",
        hertz_case,
        coords,
        [
            state(0, 1.0, surface={"pressure": 0.5 * pressure}),
            state(1, 1.0, surface={"pressure": pressure}),
        ],
    )
    points = np.array([-9.3e-6, -2.2e-6, 0.7e-6, 5.55e-6, 30e-6])  # the last is off the grid
    csv = tmp_path / "ref.csv"
    rows = "\n".join(f"{x * 1e6:.6g}, {(1e9 + 1e14 * x) * 1e-6 + 2.0:.12g}" for x in points)
    csv.write_text(f"# x1 [µm], pressure [MPa]\nx1, p\n{rows}\n")
    result = case_vs_reference(
        ds,
        csv,
        "pressure",
        select={"x2": 0.0},
        reference_variable="p",
        value_scale=1e6,
        coord_scale=1e-6,
    )
    assert_allclose(float(result.max_abs_difference), 2e6, rtol=1e-9, err_msg="2 MPa offset")
    assert_allclose(float(result.rms_difference), 2e6, rtol=1e-9)
    assert (int(result.points), int(result.points_outside)) == (4, 1)
    assert result.attrs["selected_step"] == 1 and result.attrs["selected_x2"] == 0.0
    assert result.run_value.attrs["units"] == "Pa"
    assert_written(result, tmp_path, "vs-ref")

    ref = xr.Dataset(
        {"pressure": (("x1", "x2"), pressure[::2, :] - 5.0)},
        coords={"x1": coords.x1[::2], "x2": coords.x2},
    )
    grid = case_vs_reference(ds, ref, "pressure", step="last")
    assert_allclose(float(grid.max_abs_difference), 5.0, rtol=1e-6)
    assert int(grid.points) == ref.pressure.size
    assert_written(grid, tmp_path, "vs-map")
    with pytest.raises(CompareError, match="x2"):
        case_vs_reference(ds, csv, "pressure", reference_variable="p")


# --------------------------------------------------------------------------- errors and metadata
def test_errors_name_the_problem(tmp_path, hertz_case):
    coords = make_coords(9, 9, 1e-6, [1e-6])
    path = tmp_path / "run.nc"
    with RunWriter(path, hertz_case, coords, fields=["load", "pressure"]) as writer:
        writer.append(state(0, 1.0, surface={"pressure": np.ones((9, 9))}))
    with pytest.raises(CompareError, match="residual_stress"):
        residual_map(path)
    with pytest.raises(CompareError, match="no such run file"):
        hertz_check(tmp_path / "missing.nc")
    text = tmp_path / "notes.nc"
    text.write_text("not netcdf")
    with pytest.raises(CompareError, match="notes.nc: not a netCDF file"):
        hertz_check(text)
    xr.Dataset({"a": ("x", [1.0])}).to_netcdf(tmp_path / "plain.nc")
    with pytest.raises(CompareError, match="not a sacflow run"):
        hertz_check(tmp_path / "plain.nc")
    only_surface = write_run(
        tmp_path / "s.nc",
        hertz_case,
        coords,
        [state(0, 1.0, surface={"pressure": np.ones((9, 9))})],
    )
    with pytest.raises(CompareError, match="stores no values of 'residual_stress'"):
        residual_map(only_surface)


def test_every_result_variable_has_metadata():
    for name, meta in RESULTS.items():
        assert meta.units and meta.long_name, name


# --------------------------------------------------------------------------- command line
def test_cli_compare(tmp_path, hertz_case, capsys):
    hertz_run(tmp_path / "hertz.nc", hertz_case)
    assert (
        main(["compare", "hertz-check", str(tmp_path / "hertz.nc"), "--out", str(tmp_path / "cmp")])
        == 0
    )
    out = capsys.readouterr().out
    assert "p0_error" in out and "hertz-hertz-check.nc" in out
    assert (tmp_path / "cmp" / "hertz-hertz-check.png").is_file()

    assert main(["compare", "hertz-check", str(tmp_path / "hertz.nc"), "--depth", "1e-6"]) == 2
    assert "--depth does not apply to hertz-check" in capsys.readouterr().err
    assert main(["compare", "elastic-vs-plastic", str(tmp_path / "hertz.nc")]) == 2
    assert "takes 2 run file(s)" in capsys.readouterr().err
    assert (
        main(
            ["compare", "residual-map", str(tmp_path / "hertz.nc"), "--out", str(tmp_path / "cmp")]
        )
        == 2
    )
    assert "error:" in capsys.readouterr().err
    assert main(["compare", "case-vs-reference", str(tmp_path / "hertz.nc")]) == 2
    assert "needs --reference, --variable" in capsys.readouterr().err


# --------------------------------------------------------------------------- a real run
def test_hertz_check_on_a_real_elastic_run(tmp_path):
    from sacflow.runner import run_case

    case = load_case(HERTZ, ["grid.nx=24", "grid.ny=24", "grid.nz=4"])
    summary_ = run_case(case, tmp_path, progress=False)
    result = hertz_check(summary_.path)
    assert abs(float(result.p0_error)) < 0.01, f"p0 error {float(result.p0_error):.4f}"
    assert abs(float(result.approach_max_error)) < 0.01
    assert abs(float(result.contact_radius_error)) < 0.03, "area counted in whole cells"
    assert abs(float(result.profile_error)) < 0.05, "edge cells of the contact"
    assert_written(result, tmp_path, "real-hertz")


def test_refined_peak_is_exact_for_a_separable_parabola():
    from sacflow.compare.fields import refined_peak

    x = np.arange(9) * 0.5
    y = np.arange(7) * 0.3
    z = np.arange(11) * 0.2
    X, Y, Z = np.meshgrid(x, y, z, indexing="ij")
    field = 3.0 - (X - 2.13) ** 2 - 2.0 * (Y - 0.97) ** 2 - 0.5 * (Z - 1.31) ** 2
    value, where = refined_peak(field, (x, y, z))
    assert abs(value - 3.0) < 1e-12
    np.testing.assert_allclose(where, [2.13, 0.97, 1.31], atol=1e-12)
    assert value > field.max(), "the refined peak lies between the cell centres"
