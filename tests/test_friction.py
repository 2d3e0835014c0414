"""Surface shear traction q = μ p (``[friction]``, issue #18): physics, storage, schema.

* the tensile surface stress at the trailing edge of a sliding Hertz contact against the closed
  form p0[(1 − 2ν)/3 + (4 + ν)πμ/8] (Hamilton & Goodman 1966; Johnson 1985 §7.2), with its
  fitted convergence rate under grid refinement;
* the solver's subsurface stress against quadrature of Boussinesq's and Cerruti's point-force
  stresses over the exact Hertz pressure;
* the largest von Mises stress: 0.62 p0 at 0.48 a without friction, towards the leading side and
  the surface with it;
* μ = 0 gives today's results bit for bit; the shear traction stored with its CF metadata;
  configuration mistakes named.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from sacflow.config.solver_inputs import simulation_for
from sacflow.errors import SacflowError
from sacflow.kernels.shear import cerruti_stress, rectangle_shear_stress
from sacflow.kernels.surface import boussinesq_stress, rectangle_stress
from sacflow.mechanics.hertz import first_yield
from sacflow.runner import run_case
from sacflow.storage.case_file import load_case

ROOT = Path(__file__).resolve().parents[1]
SLIDING = ROOT / "configs" / "sliding-hertz.toml"
NU = 0.3


# --------------------------------------------------------------------------- references
def trailing_edge_closed_form(mu: float, nu: float = NU) -> float:
    """σ11 / p0 at the surface, x1 = −a (Hamilton & Goodman 1966; Johnson 1985 §7.2)."""
    return (1.0 - 2.0 * nu) / 3.0 + (4.0 + nu) * np.pi * mu / 8.0


def surface_stress(x1: float, x2: float, n: int, mu: float) -> np.ndarray:
    """Surface stress / p0 at (x1, x2) of the Hertz pressure and traction μ p (a = p0 = 1).

    The load is piecewise constant on n × n cells of size 2/n centred on −1 + k·2/n (so that
    x1 = ±1 is a cell centre, where p = 0), each cell's value the pressure at its centre: the
    discretisation sacflow uses, summed with the closed-form rectangle kernels at x3 = 0.
    """
    h = 2.0 / n
    centres = -1.0 + h * np.arange(n + 1)
    c1, c2 = np.meshgrid(centres, centres, indexing="ij")
    p = np.sqrt(np.clip(1.0 - c1 * c1 - c2 * c2, 0.0, None))
    loaded = p > 0.0
    d1, d2, p = x1 - c1[loaded], x2 - c2[loaded], p[loaded]
    kernel = rectangle_stress(d1, d2, 0.0, h / 2, h / 2, NU)
    kernel += mu * rectangle_shear_stress(d1, d2, 0.0, h / 2, h / 2, NU)
    return np.einsum("i,ic->c", p, kernel)


def quadrature_stress(x1: float, x2: float, x3: float, mu: float, order: int = 64) -> np.ndarray:
    """Stress / p0 of the exact Hertz pressure and traction μ p (a = 1), by Gauss quadrature.

    Boussinesq's and Cerruti's point-force stresses integrated over the contact disc in polar
    coordinates, r = sin t (p = cos t: no square-root end point); independent of the rectangle
    kernels and of the FFT path.
    """
    t, wt = np.polynomial.legendre.leggauss(order)
    t, wt = (t + 1.0) * np.pi / 4.0, wt * np.pi / 4.0
    phi, wp = np.polynomial.legendre.leggauss(2 * order)
    phi, wp = (phi + 1.0) * np.pi, wp * np.pi
    T, P = np.meshgrid(t, phi, indexing="ij")
    r, pressure = np.sin(T), np.cos(T)
    weight = np.outer(wt, wp) * pressure * r * np.cos(T)  # p · r dr dφ
    d1, d2 = x1 - r * np.cos(P), x2 - r * np.sin(P)
    point = boussinesq_stress(d1, d2, x3, NU) + mu * cerruti_stress(d1, d2, x3, NU)
    return np.einsum("ij,ijc->c", weight, point)


# --------------------------------------------------------------------------- closed forms
def test_trailing_edge_tension_converges_to_the_closed_form():
    """σ11(−a, 0, 0) → p0[(1 − 2ν)/3 + (4 + ν)πμ/8], μ = 0.25, at a fitted rate of ½.

    The traction falls to zero as the square root of the distance to the edge, where the
    tangential kernel is singular: piecewise-constant cells converge as h^½ there. Measured
    when written: −10.1 %, −7.0 %, −4.9 %, −3.4 % at 64 ... 512 cells across the diameter
    (−2.4 % at 1024); the value extrapolated with the fitted rate is within 0.05 %.
    """
    mu = 0.25
    exact = trailing_edge_closed_form(mu)
    cells = np.array([64, 128, 256, 512])
    values = np.array([surface_stress(-1.0, 0.0, n, mu)[0] for n in cells])
    errors = exact - values
    assert np.all(errors > 0) and np.all(np.diff(errors) < 0), "monotone from below"
    rate = -np.polyfit(np.log(cells), np.log(errors), 1)[0]
    assert 0.4 < rate < 0.6
    ratio = 2.0**rate
    extrapolated = values[-1] + (values[-1] - values[-2]) / (ratio - 1.0)
    assert extrapolated == pytest.approx(exact, rel=0.01)
    # the trailing edge, not the leading one, is in tension
    assert surface_stress(1.0, 0.0, 128, mu)[0] < 0.0 < values[0]


def test_trailing_edge_without_friction_is_the_hertz_radial_stress():
    """μ = 0: σ11(−a) = (1 − 2ν)/3 p0 (Johnson eq. 3.43), the normal kernel converging at h¹."""
    exact = trailing_edge_closed_form(0.0)
    got = surface_stress(-1.0, 0.0, 256, 0.0)[0]
    assert got == pytest.approx(exact, rel=0.01)


def test_subsurface_stress_of_the_solver_matches_quadrature():
    """The solver's elastic sliding contact (μ = 0.3, 64 × 64 × 16) against quadrature.

    Every component at every cell between 0.2 a and 1.2 a deep under the contact, within 1 % of
    p0: the remaining difference is the solver's discretised contact pressure against the exact
    Hertz pressure of the quadrature.
    """
    mu = 0.3
    case = load_case(SLIDING, [f"friction.coefficient={mu}"])
    sim = simulation_for(case)
    state = list(sim.run())[-1]
    a, p0 = sim.hertz.a, sim.hertz.p0
    stress = state.volume["stress"] / p0
    c = sim.coords
    worst = 0.0
    for i in range(4, len(c.x1) - 4, 7):
        for k in range(len(c.x3)):
            z = c.x3[k] / a
            if not 0.2 < z < 1.2:
                continue
            j = len(c.x2) // 2
            ref = quadrature_stress(c.x1[i] / a, c.x2[j] / a, z, mu)
            worst = max(worst, float(np.abs(stress[i, j, k] - ref).max()))
    assert worst < 0.01


def run_elastic(mu: float, nz: int = 32):
    """Largest von Mises stress / p0 of the sliding contact and where (x1/a, depth/a)."""
    case = load_case(SLIDING, [f"friction.coefficient={mu}", f"grid.nz={nz}",
                               "grid.depth=0.1866e-3", "grid.half_width=1.25"])
    sim = simulation_for(case)
    vm = list(sim.run())[-1].volume["von_mises"] / sim.hertz.p0
    i, j, k = np.unravel_index(int(vm.argmax()), vm.shape)
    return float(vm.max()), sim.coords.x1[i] / sim.hertz.a, sim.coords.x3[k] / sim.hertz.a


def test_largest_von_mises_moves_forward_and_up_with_friction():
    """μ = 0: 0.62 p0 at 0.48 a on the axis; μ = 0.25: larger, ahead of the axis, shallower;
    μ = 0.5: in the first layer (the surface), behind the axis."""
    _, depth0, vm0 = first_yield(NU)
    vm, x1, z = run_elastic(0.0)
    assert vm == pytest.approx(vm0, rel=0.005)
    assert abs(x1) < 0.05 and z == pytest.approx(depth0, abs=0.04)
    vm25, x25, z25 = run_elastic(0.25)
    assert vm25 > vm and x25 > 0.15 and z25 < z
    vm50, x50, z50 = run_elastic(0.5)
    assert vm50 > vm25 and z50 < 0.05 and x50 < 0.0


# --------------------------------------------------------------------------- plasticity
TINY_PLASTIC = ["grid.nx=16", "grid.ny=16", "grid.nz=4", "load_path.1.steps=3",
                "load_path.0.increments=2"]
PLASTIC_GRID = ["grid.nx=16", "grid.ny=16", "grid.nz=8", "load_path.1.steps=6"]


def test_zero_friction_is_bit_identical_to_no_friction():
    base = load_case(ROOT / "configs" / "rolling-smooth.toml", TINY_PLASTIC)
    zero = load_case(ROOT / "configs" / "rolling-smooth-traction.toml",
                     [*TINY_PLASTIC, "friction.coefficient=0"])
    assert zero.friction is not None and base.friction is None
    a = list(simulation_for(base).run())
    b = list(simulation_for(zero).run())
    assert len(a) == len(b)
    for sa, sb in zip(a, b, strict=True):
        for group in ("surface", "volume"):
            for name, value in getattr(sa, group).items():
                assert np.array_equal(value, getattr(sb, group)[name], equal_nan=True), (
                    sa.step, name)
        assert not sb.surface["shear_traction"].any()


def test_plastic_zone_rises_with_traction():
    """Rolling-smooth (16 × 16 × 8 cells, 6 roll steps): the plastic zone rises with μ.

    Measured when written: the largest εp at 0.45 a for μ = 0 and 0.3, in the first layer
    (0.06 a) for μ = 0.4 and 0.5; the εp-weighted mean depth 0.48, 0.43, 0.30, 0.19 a for
    μ = 0, 0.3, 0.4, 0.5.
    """
    depth_of_max, mean_depth = [], []
    for mu in (0.0, 0.3, 0.5):
        case = load_case(ROOT / "configs" / "rolling-smooth-traction.toml",
                         [*PLASTIC_GRID, f"friction.coefficient={mu}"])
        sim = simulation_for(case)
        eqps = list(sim.run())[-1].volume["equivalent_plastic_strain"]
        z = sim.coords.x3 / sim.hertz.a
        depth_of_max.append(z[np.unravel_index(int(eqps.argmax()), eqps.shape)[2]])
        mean_depth.append(float((eqps.sum(axis=(0, 1)) * z).sum() / eqps.sum()))
    assert mean_depth[0] > mean_depth[1] > mean_depth[2]
    assert depth_of_max[2] == z[0] < depth_of_max[0]


# --------------------------------------------------------------------------- storage, schema
def test_shear_traction_is_stored_with_its_components(tmp_path):
    case = load_case(SLIDING, ["grid.nx=16", "grid.ny=16", "grid.nz=4",
                               "friction.direction=[0.6, 0.8]"])
    path = run_case(case, tmp_path, progress=False).path
    with xr.open_dataset(path) as ds:
        q = ds["shear_traction"].isel(step=-1)
        p = ds["pressure"].isel(step=-1)
        assert q.dims == ("x1", "x2", "direction")
        assert list(ds["direction"].values) == ["1", "2"]
        assert q.attrs["units"] == "Pa"
        np.testing.assert_allclose(q.sel(direction="1"), 0.25 * 0.6 * p, rtol=1e-12)
        np.testing.assert_allclose(q.sel(direction="2"), 0.25 * 0.8 * p, rtol=1e-12)


def test_no_traction_stored_without_friction(tmp_path):
    case = load_case(ROOT / "configs" / "hertz-elastic.toml",
                     ["grid.nx=16", "grid.ny=16", "grid.nz=4"])
    path = run_case(case, tmp_path, progress=False).path
    with xr.open_dataset(path) as ds:
        assert "shear_traction" not in ds and "direction" not in ds.dims


@pytest.mark.parametrize(
    ("override", "field"),
    [
        ("friction.coefficient=-0.1", "friction.coefficient"),
        ("friction.direction=[0, 0]", "friction.direction"),
    ],
)
def test_friction_mistakes_name_the_field(override, field):
    with pytest.raises(SacflowError, match=field.replace(".", r"\.")):
        load_case(SLIDING, [override])


def test_traction_field_needs_a_friction_table():
    with pytest.raises(SacflowError, match="shear_traction needs a \\[friction\\] table"):
        load_case(ROOT / "configs" / "hertz-elastic.toml",
                  ['output.fields=["load", "shear_traction"]'])


def test_direction_is_normalised_and_absent_friction_keeps_the_case_id():
    case = load_case(SLIDING, ["friction.direction=[3, 4]"])
    assert case.friction.direction == (0.6, 0.8)
    hertz = load_case(ROOT / "configs" / "hertz-elastic.toml")
    assert "friction" not in hertz.identity()


@pytest.mark.parametrize(
    ("campaign", "base"),
    [("campaign-friction", "sliding-hertz"),
     ("campaign-rolling-traction", "rolling-smooth-traction")],
)
def test_shipped_friction_campaigns_expand_to_valid_cases(campaign, base):
    from sacflow.campaign.expansion import expand_campaign, load_campaign

    path = ROOT / "configs" / f"{campaign}.toml"
    cases = expand_campaign(load_campaign(path), str(path))
    mus = [c.case.friction.coefficient for c in cases]
    assert mus == [0.0, 0.1, 0.2, 0.3, 0.4, 0.5]
    reference = load_case(ROOT / "configs" / f"{base}.toml")
    for c in cases:
        assert c.case.grid == reference.grid and c.case.load_path == reference.load_path
