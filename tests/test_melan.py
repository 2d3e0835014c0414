"""Melan's static theorem for steady rolling (sacflow.mechanics.shakedown) and the line-contact
field it uses.

The line contact is the check with a known answer: a steady residual field of a plane-strain
body has no ρ13 (equilibrium with ∂/∂x1 = 0 and a free surface), so σ_vM ≥ √3 |σ13| and no
field does better than p0 = k / max|σ̂13| = 4.0 k (Johnson & Jefferis 1963; Johnson, Contact
Mechanics, 1985, §9.3). The optimiser must reach that ceiling, and never pass it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.integrate import quad

from sacflow.mechanics.hertz import line_contact_stress
from sacflow.mechanics.shakedown import SHARPNESS_STAGES, melan_bound, rolling_shakedown_bound
from sacflow.mechanics.steady_residual import SteadyResidualField
from sacflow.mechanics.stress_measures import von_mises

SQRT3 = np.sqrt(3.0)
ROOT = Path(__file__).resolve().parents[1]


def _flamant_quadrature(x1: float, x3: float, a: float, p0: float) -> list[float]:
    """σ11, σ33, σ13 of the Hertz line pressure as a sum of Flamant line loads (quadrature).

    A normal line load P at x1 = s gives σ_rr = −2P cosθ/(π r), θ from the x3 axis, so
    σ11 = −2P X² x3/(π r⁴), σ33 = −2P x3³/(π r⁴), σ13 = −2P X x3²/(π r⁴), X = x1 − s.
    """
    def integrand(s: float, row: int) -> float:
        X = x1 - s
        r4 = (X * X + x3 * x3) ** 2
        load = p0 * np.sqrt(max(0.0, 1.0 - (s / a) ** 2))
        return -2.0 * load / np.pi * (X * X * x3, x3 ** 3, X * x3 * x3)[row] / r4

    return [quad(integrand, -a, a, args=(row,), limit=400, epsabs=1e-11 * p0, epsrel=1e-10)[0]
            for row in range(3)]


@pytest.mark.parametrize("x1, x3", [(0.0, 0.5), (0.87, 0.5), (-0.87, 0.5), (1.5, 0.3),
                                    (0.3, 1.2), (-2.0, 0.05)])
def test_line_contact_stress_is_a_sum_of_flamant_loads(x1, x3):
    a, p0, nu = 1.3e-4, 2.0e9, 0.3
    s = line_contact_stress(x1 * a, x3 * a, a, p0, nu)
    expected = _flamant_quadrature(x1 * a, x3 * a, a, p0)
    assert_allclose(s[[0, 2, 4]], expected, rtol=1e-7, atol=1e-9 * p0,
                    err_msg=f"McEwen's field against quadrature at x1={x1} a, x3={x3} a")
    assert_allclose(s[1], nu * (s[0] + s[2]), rtol=1e-14, err_msg="plane strain σ22")
    assert s[3] == 0.0 and s[5] == 0.0


def test_line_contact_known_values():
    """On the axis σ33 = −p0 (1 + z²/a²)^-½; the orthogonal shear peaks at 0.25 p0, z = a/2."""
    z = np.linspace(0.0, 3.0, 31)
    s = line_contact_stress(0.0, z, 1.0, 1.0, 0.3)
    assert_allclose(s[:, 2], -1.0 / np.sqrt(1.0 + z * z), rtol=1e-13, err_msg="axis σ33")
    x1, x3 = np.meshgrid(np.linspace(0.0, 2.0, 801), np.linspace(0.01, 1.5, 597), indexing="ij")
    tau = np.abs(line_contact_stress(x1, x3, 1.0, 1.0, 0.3)[..., 4])
    i = np.unravel_index(np.argmax(tau), tau.shape)
    assert_allclose(tau[i], 0.25, rtol=1e-4, err_msg="largest orthogonal shear")
    assert_allclose([x1[i], x3[i]], [np.sqrt(3.0) / 2.0, 0.5], atol=5e-3, err_msg="where")


def _field(kind: str = "full", x2=None, x3=None) -> tuple[SteadyResidualField, np.ndarray,
                                                          np.ndarray]:
    x2 = np.linspace(-1.6, 1.6, 321) if x2 is None else x2
    x3 = np.linspace(0.0, 1.3, 261) if x3 is None else x3
    return SteadyResidualField(x2, x3, 1.5, 1.2, (9, 7), kind), x2, x3


def test_residual_field_is_self_equilibrated_in_the_box():
    """div ρ = 0 (∂1 = 0) by central differences of step 1e-5 at random points of the box."""
    rng = np.random.default_rng(7)
    y = np.sort(rng.uniform(-1.49, 1.49, 23))
    z = np.sort(rng.uniform(0.01, 1.19, 17))
    c = rng.standard_normal(_field()[0].size)
    h = 1e-5

    def rho(dy: float, dz: float) -> np.ndarray:
        return _field("full", y + dy, z + dz)[0].stress(c)

    d2 = (rho(h, 0.0) - rho(-h, 0.0)) / (2 * h)
    d3 = (rho(0.0, h) - rho(0.0, -h)) / (2 * h)
    scale = np.abs(rho(0.0, 0.0)).max()
    # rows of div ρ = ∂2 ρ_i2 + ∂3 ρ_i3, components (11, 22, 33, 12, 13, 23)
    for row, (c2, c3) in enumerate([(3, 4), (1, 5), (5, 2)]):
        assert_allclose(d2[..., c2] + d3[..., c3], 0.0, atol=1e-6 * scale,
                        err_msg=f"equilibrium along x{row + 1}")


def test_residual_field_is_traction_free_on_the_surface_and_the_box_faces():
    """Zero traction on x3 = 0, and the box part's on the box's far faces: that part extended
    by zero outside the box is self-equilibrated in the whole half-space (ρ11 carries no
    traction there). The depth-only part ρ11(x3), ρ22(x3) is the same at every x2."""
    field, x2, x3 = _field()
    rng = np.random.default_rng(5)
    c = rng.standard_normal(field.size)
    depth_part = field.sizes[0] + field.sizes[1]
    rho = field.stress(c)
    scale = np.abs(rho).max()
    zero = 1e-12 * scale
    assert_allclose(rho[:, 0][:, [2, 4, 5]], 0.0, atol=zero, err_msg="surface x3 = 0")
    boxed = c.copy()
    boxed[:depth_part] = 0.0
    box = field.stress(boxed)
    face_y = np.isclose(np.abs(x2), 1.5)
    assert face_y.sum() == 2
    assert_allclose(box[face_y][..., [3, 1, 5]], 0.0, atol=zero, err_msg="faces |x2| = L")
    face_z = np.isclose(x3, 1.2)
    assert face_z.sum() == 1
    assert_allclose(box[:, face_z][..., [4, 5, 2]], 0.0, atol=zero, err_msg="face x3 = D")
    outside = (np.abs(x2) > 1.5)[:, None] | (x3 > 1.2)[None, :]
    assert_allclose(box[outside], 0.0, atol=zero, err_msg="nothing outside the box")
    layered = field.stress(c - boxed)
    assert_allclose(layered, np.broadcast_to(layered[:1], layered.shape), rtol=0, atol=zero,
                    err_msg="the depth-only part does not depend on x2")
    assert_allclose(layered[..., 2:], 0.0, atol=0, err_msg="the depth-only part: ρ11, ρ22")


def test_whole_class_contains_the_depth_only_class():
    x2, x3 = np.linspace(-1.5, 1.5, 31), np.linspace(0.05, 1.2, 24)
    depth = SteadyResidualField(x2, x3, 1.5, 1.2, (9, 7), "depth")
    full = SteadyResidualField(x2, x3, 1.5, 1.2, (9, 7), "full")
    c = np.random.default_rng(3).standard_normal(depth.size)
    assert_allclose(full.stress(full.extend(c)), depth.stress(c), rtol=0, atol=0)


def test_adjoint_is_the_transpose_of_the_field():
    for kind in ("full", "depth"):
        field, x2, x3 = _field(kind)
        rng = np.random.default_rng(11)
        c = rng.standard_normal(field.size)
        g = rng.standard_normal((x2.size, x3.size, 6))
        assert_allclose(np.sum(g * field.stress(c)), field.adjoint(g) @ c, rtol=1e-12,
                        err_msg=f"⟨g, ρ(c)⟩ = ⟨ρᵀ g, c⟩, {kind}")


def test_line_contact_limit_is_four_k_and_never_above_its_ceiling():
    bound = rolling_shakedown_bound("line", kind="depth", depth=2.0, sample_step=1.0 / 24,
                                    knot_step=1.0 / 8)
    x1 = np.arange(-3.0, 3.0 + 1e-9, 1.0 / 24)
    x3 = np.arange(0.5 / 24, 2.0, 1.0 / 24)
    elastic = line_contact_stress(x1[:, None], x3[None, :], 1.0, 1.0, 0.3)
    ceiling = 1.0 / np.abs(elastic[..., 4]).max()  # σ_vM ≥ √3|σ13|, in units of k
    assert SQRT3 * bound.load_factor <= ceiling * (1 + 1e-12)
    assert_allclose(SQRT3 * bound.load_factor, 4.0, rtol=2e-3,
                    err_msg="line-contact shakedown limit of free rolling, 4.0 k")
    assert_allclose(SQRT3 * bound.elastic_limit, 3.1, rtol=5e-3, err_msg="first yield, 3.1 k")


def test_bound_is_the_largest_von_mises_stress_of_its_own_field():
    """The load factor is re-derived from the returned field, the unloaded state included
    (one sharpness stage: the check is of consistency, not of the optimum)."""
    x1 = np.linspace(-2.5, 2.5, 41)
    x2 = np.linspace(-1.5, 1.5, 25)
    x3 = np.linspace(0.05, 1.5, 24)
    from sacflow.mechanics.hertz import hertz_subsurface_stress

    elastic = hertz_subsurface_stress(*np.meshgrid(x1, x2, x3, indexing="ij"), 1.0, 1.0, 0.3)
    field = SteadyResidualField(x2, x3, 1.5, 1.5, (6, 4), "full")
    bound = melan_bound(elastic, field, stages=SHARPNESS_STAGES[:1])
    loaded = von_mises(elastic + bound.residual[None]).max()
    unloaded = von_mises(bound.residual).max()
    assert_allclose(bound.load_factor, 1.0 / max(loaded, unloaded), rtol=1e-12)
    assert_allclose(bound.residual, field.stress(bound.coefficients), rtol=1e-13, atol=1e-15)
    assert bound.load_factor > 1.25 * bound.elastic_limit, "a residual field raises the limit"
    assert_allclose(SQRT3 * bound.elastic_limit, 2.79, rtol=1e-2, err_msg="first yield")


def _hertz_cells(n: int) -> tuple[np.ndarray, float]:
    """Hertz pressure (p0 = 1, a = 1) at the centres of cells of a/n, one cell beyond a."""
    d = 1.0 / n
    c = (np.arange(2 * n + 2) - (2 * n + 1) / 2) * d
    return np.sqrt(np.clip(1.0 - c[:, None] ** 2 - c[None, :] ** 2, 0.0, None)), d


def test_pressure_stress_converges_to_hubers_field():
    """Love's rectangles summed over the cells of a Hertz pressure tend to the closed form
    (Huber) at second order in the cell size (the pressure sampled at cell centres)."""
    from sacflow.mechanics.hertz import hertz_subsurface_stress
    from sacflow.mechanics.shakedown import pressure_stress

    z = np.array([0.25, 0.5, 1.0])
    errors = []
    for n in (16, 32, 64):
        pressure, d = _hertz_cells(n)
        stress = pressure_stress(pressure, (d, d), z, 0.3, (4, 4))
        c = (np.arange(pressure.shape[0] + 8) - (pressure.shape[0] + 7) / 2) * d
        exact = hertz_subsurface_stress(c[:, None, None], c[None, :, None], z, 1.0, 1.0, 0.3)
        errors.append(np.abs(stress - exact).max())
    rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(rates > 1.7), f"convergence rates {rates} (errors {errors})"
    assert errors[-1] < 5e-4


def test_moving_pressure_bound_scales_with_the_pressure():
    """Twice the pressure, half the factor: the bound is homogeneous of degree −1."""
    from sacflow.mechanics.shakedown import moving_pressure_bound

    pressure, d = _hertz_cells(4)
    settings = {"a": 1.0, "track": 2.0, "half_width": 1.5, "depth": 1.5, "depth_step": 0.25,
                "knot_step": 0.5}
    one = moving_pressure_bound(pressure, (d, d), 0.3, **settings)
    two = moving_pressure_bound(2.0 * pressure, (d, d), 0.3, **settings)
    assert_allclose(two.load_factor, one.load_factor / 2.0, rtol=1e-14)
    assert_allclose(two.residual, 2.0 * one.residual, rtol=1e-14, atol=0)
    assert one.load_factor > one.elastic_limit


def test_melan_stage_on_a_repeated_rolling_run(tmp_path, capsys):
    """``sacflow compare melan``: the default step is the middle full-load rolling step of the
    last pass; the verdict follows the factor; the files are written."""
    import xarray as xr

    from sacflow.cli import main
    from sacflow.compare.melan_bound import melan
    from sacflow.config.solver_inputs import case_steps
    from sacflow.runner import run_case
    from sacflow.storage.case_file import load_case

    config = ROOT / "configs" / "rolling-cycles-shakedown.toml"
    case = load_case(config, ["grid.nx=12", "grid.ny=12", "grid.nz=6", "load_path.1.steps=4",
                              "load_path.1.passes=2"])
    path = run_case(case, tmp_path / "run", progress=False).path
    plan = case_steps(case)
    last_pass = [i for i, s in enumerate(plan) if s.pass_index == 1
                 and case.load_path[s.segment].kind == "roll" and s.load == case.max_load]
    result = melan(path)
    assert int(result["step"]) == last_pass[len(last_pass) // 2]
    factor, ceiling = float(result["load_factor"]), float(result["ceiling_factor"])
    assert float(result["first_yield_factor"]) < factor
    # the ceiling on the same samples bounds every factor Melan proves on them
    assert factor <= ceiling * (1 + 1e-12)
    assert_allclose(float(result["gap"]), ceiling / factor - 1, rtol=1e-14)
    expected = ("shakes down" if factor >= 1 else "does not shake down" if ceiling < 1
                else "not proven safe")
    assert result.attrs["verdict"] == expected
    with xr.open_dataset(path) as ds:
        peak = float(ds["pressure"].sel(step=int(result["step"])).max())
    assert_allclose(float(result["peak_pressure"]), peak, rtol=1e-14)
    envelope = result["envelope"].values
    assert_allclose(envelope.max(), 1.0, rtol=1e-12, err_msg="the bound touches yield")
    assert main(["compare", "melan", str(path), "--out", str(tmp_path / "cmp")]) == 0
    assert "load_factor" in capsys.readouterr().out
    assert len(list((tmp_path / "cmp").glob("*-melan.*"))) == 2


def test_melan_stage_refuses_what_it_does_not_cover():
    from sacflow.compare.core import CompareError
    from sacflow.compare.melan_bound import check_melan_case
    from sacflow.storage.case_file import load_case

    with pytest.raises(CompareError, match="perfectly plastic"):
        check_melan_case(load_case(ROOT / "configs" / "rolling-smooth.toml"))
    with pytest.raises(CompareError, match="friction"):
        check_melan_case(load_case(ROOT / "configs" / "rolling-cycles-shakedown.toml",
                              ["friction.coefficient=0.2"]))
    with pytest.raises(CompareError, match="along x1"):
        check_melan_case(load_case(ROOT / "configs" / "rolling-cycles-shakedown.toml",
                              ["load_path.1.direction=[0.0, 1.0]"]))


@pytest.mark.slow
def test_shakedown_bounds_pipeline_quick(tmp_path, capsys):
    """``pipelines/shakedown_bounds.py --quick``: three JSON lines, the files, each bracket
    ordered (first yield < certified lower bound ≤ ceiling), the line contact's around 4.0 k
    even at the coarse settings."""
    import json
    import sys

    sys.path.insert(0, str(ROOT / "pipelines"))
    try:
        import shakedown_bounds
    finally:
        sys.path.remove(str(ROOT / "pipelines"))
    assert shakedown_bounds.main(["--quick", "--out", str(tmp_path)]) == 0
    rows = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [(r["contact"], r["residual_class"]) for r in rows] == [
        ("line", "depth"), ("point", "depth"), ("point", "full")]
    assert rows[0]["lower_p0_over_k"] <= 4.0 <= rows[0]["ceiling_p0_over_k"]
    assert_allclose(rows[0]["lower_p0_over_k"], 4.0, rtol=0.02)
    for row in rows:
        assert row["first_yield_p0_over_k"] < row["lower_p0_over_k"] <= row["ceiling_p0_over_k"]
        assert_allclose(row["gap"], row["ceiling_p0_over_k"] / row["lower_p0_over_k"] - 1,
                        rtol=1e-12)
    assert (tmp_path / "shakedown_bounds.json").is_file()
    assert (tmp_path / "shakedown_bounds.png").is_file()


# --- the certified bracket: residual-field bounds, far field, balls, certificate, ceiling ---

def test_residual_field_derivative_bounds_hold_inside_every_knot_cell():
    """|∂ρ| from the B-spline coefficients bounds the field's own derivatives (differences of
    step 1e-4 at random points away from the knots), inside and beyond the box, and is tight
    (reached to within 20 % somewhere: the convex hull bound is nearly attained)."""
    from sacflow.mechanics.steady_residual import DERIVATIVES

    rng = np.random.default_rng(1)
    knots_y, knots_z = np.linspace(-1.5, 1.5, 7), np.linspace(0.0, 1.2, 5)
    h = 1e-4
    for kind in ("full", "depth"):
        field = SteadyResidualField(np.zeros(1), np.zeros(1), 1.5, 1.2, (6, 4), kind)
        c = rng.standard_normal(field.size)
        y, z = rng.uniform(-1.99, 1.99, 20000), rng.uniform(0.001, 1.59, 20000)
        away = ((np.abs(y[:, None] - knots_y).min(axis=1) > 3 * h)
                & (np.abs(z[:, None] - knots_z).min(axis=1) > 3 * h))
        y, z = y[away], z[away]

        def rho(dy, dz, y=y, z=z, field=field, c=c):
            return field.stress_at(c, y + dy, z + dz)

        values = {(0, 0): rho(0, 0), (1, 0): (rho(h, 0) - rho(-h, 0)) / (2 * h),
                  (2, 0): (rho(h, 0) - 2 * rho(0, 0) + rho(-h, 0)) / h ** 2,
                  (0, 1): (rho(0, h) - rho(0, -h)) / (2 * h),
                  (0, 2): (rho(0, h) - 2 * rho(0, 0) + rho(0, -h)) / h ** 2}
        bounds = field.derivative_bounds(c, y, z)
        for k, orders in enumerate(DERIVATIVES):
            slack = 1e-5 * (1 + bounds[:, k])
            assert np.all(np.abs(values[orders]) <= bounds[:, k] + slack), (kind, orders)
        assert np.max(np.abs(values[(0, 0)]) / np.maximum(bounds[:, 0], 1e-300)) > 0.8


def test_scattered_residual_field_is_the_sampled_one():
    field, x2, x3 = _field()
    c = np.random.default_rng(2).standard_normal(field.size)
    X2, X3 = np.meshgrid(x2, x3, indexing="ij")
    assert_allclose(field.stress_at(c, X2.ravel(), X3.ravel()).reshape(*X2.shape, 6),
                    field.stress(c), rtol=0, atol=1e-12)


def test_von_mises_of_bounds_is_the_largest_over_the_box():
    from sacflow.mechanics.shakedown_certificate import von_mises_of_bounds

    rng = np.random.default_rng(4)
    b = rng.uniform(0.0, 2.0, (200, 6))
    signs = rng.choice([-1.0, 1.0], (200, 6))
    inside = von_mises(b * rng.uniform(-1, 1, (200, 6)))
    corner = von_mises(b * signs)
    bound = von_mises_of_bounds(b)
    assert np.all(inside <= bound + 1e-12) and np.all(corner <= bound + 1e-12)
    best = np.max([von_mises(b * np.array(s + (1, 1, 1))) for s in
                   [(1, 1, 1), (1, 1, -1), (1, -1, 1), (-1, 1, 1)]], axis=0)
    assert_allclose(bound, best, rtol=1e-14)


@pytest.mark.parametrize("nu", [0.0, 0.25, 0.3, 0.5])
def test_boussinesq_von_mises_peaks_on_the_axis(nu):
    """The far-field constant: σ_vM R²/P of Boussinesq's field is largest on the load's axis,
    (3 + (1 − 2ν)/2)/(2π) (a scan of the polar angle)."""
    theta = np.linspace(1e-6, np.pi / 2, 200001)
    r, z = np.sin(theta), np.cos(theta)
    q = (1 - 2 * nu) / (2 * np.pi)
    radial = q / r ** 2 * (1 - z) - 3 * z * r ** 2 / (2 * np.pi)
    hoop = -q * (1 / r ** 2 * (1 - z) - z)
    stress = np.stack([radial, hoop, -3 * z ** 3 / (2 * np.pi), 0 * z,
                       -3 * r * z ** 2 / (2 * np.pi), 0 * z], axis=-1)
    assert_allclose(von_mises(stress).max(), (3 + (1 - 2 * nu) / 2) / (2 * np.pi), rtol=1e-9)


@pytest.mark.parametrize("contact", ["point", "line"])
def test_far_field_bound_holds(contact):
    from sacflow.mechanics.hertz import hertz_subsurface_stress
    from sacflow.mechanics.shakedown_certificate import far_field_bound

    rng = np.random.default_rng(6)
    for distance in (2.0, 5.0, 20.0):
        theta = rng.uniform(0, np.pi / 2, 400)
        phi = rng.uniform(0, 2 * np.pi, 400)
        x1 = distance * np.sin(theta) * np.cos(phi)
        x3 = distance * np.cos(theta)
        if contact == "line":
            x1, x3 = distance * np.sin(theta), distance * np.cos(theta)
            s = line_contact_stress(x1, x3 + 1e-12, 1.0, 1.0, 0.3)
        else:
            s = hertz_subsurface_stress(x1, distance * np.sin(theta) * np.sin(phi), x3,
                                        1.0, 1.0, 0.3)
        assert von_mises(s).max() <= far_field_bound(contact, 0.3, distance)


def test_ball_radius_bounds_bracket_the_exact_minimum_ball():
    """Against the independent ``miniball`` package: lower ≤ exact ≤ upper, both tight."""
    miniball = pytest.importorskip("miniball")
    from sacflow.mechanics.shakedown_ceiling import ball_radius_bounds

    rng = np.random.default_rng(0)
    points = rng.standard_normal((40, 30, 6)) * rng.uniform(0.1, 2.0, (40, 1, 6))
    lower, upper = ball_radius_bounds(points)
    exact = np.sqrt([miniball.get_bounding_ball(p, rng=np.random.default_rng(0))[1]
                     for p in points])
    assert np.all(lower <= exact * (1 + 1e-12)) and np.all(upper >= exact * (1 - 1e-9))
    assert_allclose(lower, exact, rtol=1e-6)
    assert_allclose(upper, exact, rtol=1e-6)


def test_kinematic_ceiling_of_one_point_is_its_ball():
    """One point, a path and the unloaded state: the ceiling is 1/R of their smallest ball, in
    von Mises units (two loads ± τ of pure shear: R = √3 τ)."""
    from sacflow.mechanics.shakedown_ceiling import kinematic_ceiling

    tau = 0.3
    elastic = np.zeros((2, 1, 1, 6))
    elastic[0, ..., 4], elastic[1, ..., 4] = tau, -tau
    assert_allclose(kinematic_ceiling(elastic).load_factor, 1 / (SQRT3 * tau), rtol=1e-9)


def test_certificate_refutes_the_coarse_optimum_between_its_samples():
    """At samples a/6 the optimiser's factor is too large: a point between them, found on a
    grid 20 times finer, is above yield. The certified bound covers that point (and every
    other), and the certified factor lies below the true limit 4.0 k."""
    from sacflow.mechanics.shakedown import knot_intervals
    from sacflow.mechanics.shakedown_bracket import certify

    bound = rolling_shakedown_bound("line", kind="depth", depth=2.0, sample_step=1 / 6,
                                    knot_step=1 / 2)
    field = SteadyResidualField(np.zeros(1), np.zeros(1), 3.0, 2.0,
                                knot_intervals(3.0, 2.0, 0.5), "depth")
    t, z = np.meshgrid(np.linspace(-3, 3, 721), np.linspace(0.0, 2.0, 241), indexing="ij")
    g = von_mises(line_contact_stress(t.ravel(), z.ravel() + 1e-9, 1.0, 1.0, 0.3)
                  + field.stress_at(bound.coefficients, 0 * z.ravel(), z.ravel()))
    assert g.max() > 1.001 / bound.load_factor, "the samples miss a higher value"
    certified = certify("line", 0.3, field, bound.coefficients, 1 / bound.load_factor)[0]
    assert certified >= g.max()
    assert SQRT3 / certified < 4.0 < SQRT3 * bound.load_factor


def test_line_contact_bracket_holds_four_k():
    """Certified lower bound ≤ 4.0 k ≤ kinematic ceiling, the gap under 0.5 %."""
    from sacflow.mechanics.shakedown_bracket import rolling_bracket

    b = rolling_bracket("line", kind="depth", depth=2.0, sample_step=1 / 24, knot_step=1 / 8)
    assert SQRT3 * b.lower <= 4.0 <= SQRT3 * b.ceiling
    assert b.gap < 5e-3 and b.inside.unresolved == 0
    assert b.lower <= b.sampled and b.ceiling_low <= b.ceiling
    assert SQRT3 * b.lower > 3.98


@pytest.mark.slow
def test_point_contact_bracket_holds_the_kinematic_limit():
    """The sphere, whole steady class on ±3 a × 3 a: the certified floor sits within 1 % of
    the kinematic ceiling, about 4.675 k."""
    from sacflow.mechanics.shakedown_bracket import rolling_bracket

    b = rolling_bracket("point", kind="full", ceiling_step=1 / 24)
    assert 4.62 < SQRT3 * b.lower <= SQRT3 * b.ceiling < 4.70
    assert SQRT3 * b.ceiling >= 4.67


def test_kinematic_ceiling_takes_an_exact_minimum_ball():
    """The ball routine is a parameter: an exact one (here ``miniball``'s centre with the
    radius that holds every point) gives the same ceiling as the certified dual bounds, and
    never a higher one (our radius is a lower bound of the smallest)."""
    miniball = pytest.importorskip("miniball")
    from sacflow.mechanics.shakedown import rolling_samples
    from sacflow.mechanics.shakedown_ceiling import kinematic_ceiling

    def exact(points, iterations):
        """Exact radii; each set in coordinates of its own span, without repeats (paths span
        at most the 5 deviatoric dimensions of 6: ``miniball``'s solves would be singular)."""
        radii = []
        for p in points:
            _, singular, basis = np.linalg.svd(p - p.mean(axis=0))
            span = basis[singular > 1e-12 * singular[0]]
            q = np.unique(p @ span.T, axis=0)  # repeated points: singular too
            centre, _ = miniball.get_bounding_ball(q, rng=np.random.default_rng(0))
            radii.append(np.linalg.norm(q - centre, axis=1).max())  # a ball that holds all
        r = np.array(radii)
        return r, r

    elastic, _, _ = rolling_samples("point", 0.3, 1.0, 1.0, 1 / 4, 2.0)
    ours, theirs = kinematic_ceiling(elastic), kinematic_ceiling(elastic, exact)
    assert_allclose(ours.load_factor, theirs.load_factor, rtol=1e-6)
    assert ours.load_factor >= theirs.load_factor * (1 - 1e-12)
