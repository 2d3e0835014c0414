"""Tests of the Hertz reference solutions (sacflow.mechanics.hertz).

The subsurface field is checked against an independent superposition (quadrature) of Boussinesq
point-load stresses over the Hertz pressure, and against the rectangle kernel; the surface
displacement against the load–approach relation; yield onset against Johnson §6.2.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from sacflow.kernels.surface import boussinesq_stress, rectangle_stress
from sacflow.mechanics.hertz import (
    composite_modulus,
    effective_radius,
    first_yield,
    hertz_axis_stress,
    hertz_contact,
    hertz_pressure,
    hertz_subsurface_stress,
    hertz_surface_displacement,
)
from sacflow.mechanics.stress_measures import von_mises

NU = 0.3


def _graded_rule(lo, hi, c, h, n):
    """Composite Gauss-Legendre nodes/weights on [lo, hi], panels h·2^k graded toward c."""
    levels = int(np.ceil(np.log2(max(hi - lo, abs(c - lo), abs(c - hi)) / h))) + 2
    steps = h * 2.0 ** np.arange(levels)
    bps = np.unique(np.clip(np.concatenate(([lo, hi], c - steps, c + steps)), lo, hi))
    t, w = np.polynomial.legendre.leggauss(n)
    a, b = bps[:-1, None], bps[1:, None]
    return (0.5 * (a + b) + 0.5 * (b - a) * t).ravel(), (0.5 * (b - a) * w).ravel()


def hertz_by_quadrature(x1, x2, x3, a, p0, nu, n=16):
    """∫∫ p(ξ) σ_Boussinesq(x − ξ) dξ over the Hertz pressure, in polar coordinates (s, θ).

    s = a sin φ turns p s ds = p0 a² cos²φ sin φ dφ, which removes the square-root edge; both
    φ and θ panels are graded toward the projection of the field point.
    """
    r0 = np.hypot(x1, x2)
    th0 = np.arctan2(x2, x1)
    phi0 = np.arcsin(min(r0 / a, 1.0))
    phi, wphi = _graded_rule(0.0, 0.5 * np.pi, phi0, 0.25 * x3 / a, n)
    hth = 0.25 * x3 / r0 if r0 > 0 else 1.0
    th, wth = _graded_rule(th0 - np.pi, th0 + np.pi, th0, min(hth, 1.0), n)
    s = a * np.sin(phi)[:, None]
    xi1 = s * np.cos(th)[None, :]
    xi2 = s * np.sin(th)[None, :]
    weight = (p0 * a * a * np.cos(phi) ** 2 * np.sin(phi) * wphi)[:, None] * wth[None, :]
    vals = boussinesq_stress(x1 - xi1, x2 - xi2, x3, nu)
    return np.einsum("ij,ij...->...", weight, vals)


HERTZ_POINTS = [
    (0.0, 0.0, 0.5),
    (0.3, 0.0, 0.2),
    (0.5, 0.4, 0.3),
    (-0.8, 0.5, 0.1),
    (1.0, 0.0, 0.15),  # under the contact edge
    (0.0, -1.3, 0.4),
    (1.5, 1.0, 0.8),
    (0.2, -0.1, 2.5),
    (-3.0, 0.5, 1.0),
]


@pytest.mark.parametrize(("x1", "x2", "x3"), HERTZ_POINTS)
@pytest.mark.parametrize("nu", [0.3, 0.0, 0.45])
def test_hertz_subsurface_matches_boussinesq_quadrature(x1, x2, x3, nu):
    a, p0 = 1.0, 1.0
    exact = hertz_subsurface_stress(x1, x2, x3, a, p0, nu)
    numeric = hertz_by_quadrature(x1, x2, x3, a, p0, nu)
    assert_allclose(
        exact,
        numeric,
        rtol=0,
        atol=1e-9 * p0,
        err_msg=f"Hertz σ vs quadrature at ({x1}, {x2}, {x3}), ν = {nu}",
    )


def test_hertz_subsurface_matches_rectangle_superposition():
    """Cross-check with the rectangle kernel: Hertz pressure sampled on a fine cell grid."""
    a, p0 = 1.0, 1.0
    n = 128
    dx = 2.0 * a / n
    c = -a + dx * (np.arange(n) + 0.5)
    X1, X2 = np.meshgrid(c, c, indexing="ij")
    p = hertz_pressure(np.hypot(X1, X2), a, p0)
    for x in [(0.0, 0.0, 0.5), (0.4, 0.3, 0.3), (1.2, 0.0, 0.6)]:
        s = rectangle_stress(x[0] - X1, x[1] - X2, x[2], dx / 2, dx / 2, NU)
        grid = np.einsum("ij,ij...->...", p, s)
        assert_allclose(
            grid,
            hertz_subsurface_stress(*x, a, p0, NU),
            rtol=0,
            atol=3e-4 * p0,
            err_msg=f"rectangle superposition of the Hertz pressure at {x}",
        )


def test_hertz_on_axis_matches_axis_formulas():
    a, p0 = 2e-4, 3e9
    z = np.linspace(0.0, 5 * a, 41)
    s = hertz_subsurface_stress(0.0, 0.0, z, a, p0, NU)
    sr, sz = hertz_axis_stress(z, a, p0, NU)
    assert_allclose(s[..., 0], sr, rtol=1e-12, atol=1e-12 * p0, err_msg="σ11 = σ_r on axis")
    assert_allclose(s[..., 1], sr, rtol=1e-12, atol=1e-12 * p0, err_msg="σ22 = σ_θ on axis")
    assert_allclose(s[..., 2], sz, rtol=1e-12, atol=1e-12 * p0, err_msg="σ33 on axis")
    assert_allclose(s[..., 3:], 0.0, atol=1e-12 * p0, err_msg="no shear on the axis")
    # surface centre: σr = σθ = −(1+2ν)/2 p0, σz = −p0 (Johnson eq. 3.43 at r = 0)
    assert_allclose(sr[0], -(1 + 2 * NU) / 2 * p0, rtol=1e-14, err_msg="σ_r at the centre")
    assert_allclose(sz[0], -p0, rtol=1e-14, err_msg="σ_z at the centre")
    # near the axis the field is continuous (no 0/0 cancellation)
    near = hertz_subsurface_stress(1e-9 * a, 1e-9 * a, z, a, p0, NU)
    assert_allclose(near, s, rtol=0, atol=1e-9 * p0, err_msg="continuity at r -> 0")


def test_hertz_surface_stresses_johnson_3_43():
    a, p0 = 1.0, 1.0
    r = np.concatenate([np.linspace(0.01, 0.99, 20), np.linspace(1.01, 3, 10)])
    s = hertz_subsurface_stress(r, 0.0, 0.0, a, p0, NU)
    k = (1 - 2 * NU) / 3
    inside = r < a
    ri = r[inside]
    q = np.sqrt(1 - ri**2)
    assert_allclose(
        s[inside, 0],
        k / ri**2 * (1 - q**3) - q,
        rtol=1e-12,
        atol=1e-14,
        err_msg="surface σ_r inside",
    )
    assert_allclose(
        s[inside, 1],
        -k / ri**2 * (1 - q**3) - 2 * NU * q,
        rtol=1e-12,
        atol=1e-14,
        err_msg="surface σ_θ inside",
    )
    assert_allclose(s[inside, 2], -q, rtol=1e-12, err_msg="σ_z = −p inside")
    ro = r[~inside]
    assert_allclose(s[~inside, 0], k / ro**2, rtol=1e-12, err_msg="surface σ_r outside")
    assert_allclose(s[~inside, 1], -k / ro**2, rtol=1e-12, err_msg="surface σ_θ outside")
    assert_allclose(s[..., 2], -hertz_pressure(r, a, p0), atol=1e-14, err_msg="σ33 = −p")
    assert_allclose(s[..., 3:], 0.0, atol=1e-14, err_msg="no shear traction on the surface")


def test_hertz_no_nan_at_singular_points():
    a, p0 = 1.0, 1.0
    x1 = np.array([0.0, 1.0, 0.0, 1.0, -1.0, 0.0, 1e-300])
    x2 = np.array([0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0])
    x3 = np.array([0.0, 0.0, 0.0, 1e-300, 0.0, 1e-300, 0.0])
    s = hertz_subsurface_stress(x1, x2, x3, a, p0, NU)
    assert np.all(np.isfinite(s)), "Hertz field must be finite at r = 0, z = 0 and r = a"
    assert_allclose(
        s[1, :3],
        [(1 - 2 * NU) / 3, -(1 - 2 * NU) / 3, 0.0],
        atol=1e-12,
        err_msg="values at the contact edge",
    )
    with pytest.raises(ValueError, match="x3"):
        hertz_subsurface_stress(0.0, 0.0, -1.0, a, p0, NU)


def test_hertz_symmetries_and_rotation():
    rng = np.random.default_rng(4)
    x1, x2 = rng.uniform(-2, 2, (2, 40))
    z = rng.uniform(0, 2, 40)
    s = hertz_subsurface_stress(x1, x2, z, 1.0, 1.0, NU)
    # rotating the field point by 90° about the axis: (11, 22, 33, 12, 13, 23) -> (22, 11, 33,
    # -12, -23, 13)
    rot = hertz_subsurface_stress(-x2, x1, z, 1.0, 1.0, NU)
    expected = np.stack([s[:, 1], s[:, 0], s[:, 2], -s[:, 3], -s[:, 5], s[:, 4]], axis=-1)
    assert_allclose(rot, expected, rtol=1e-12, atol=1e-14, err_msg="axisymmetry")


def test_hertz_equilibrium():
    rng = np.random.default_rng(5)
    pts = np.column_stack([rng.uniform(-2, 2, 20), rng.uniform(-2, 2, 20), rng.uniform(0.1, 2, 20)])
    h = 1e-4
    rows = [(0, 3, 4), (3, 1, 5), (4, 5, 2)]
    div = np.zeros((len(pts), 3))
    for j in range(3):
        dx = np.zeros(3)
        dx[j] = h
        ds = (
            hertz_subsurface_stress(*(pts + dx).T, 1.0, 1.0, NU)
            - hertz_subsurface_stress(*(pts - dx).T, 1.0, 1.0, NU)
        ) / (2 * h)
        for i in range(3):
            div[:, i] += ds[:, rows[i][j]]
    assert_allclose(div, 0.0, atol=1e-6, err_msg="div σ = 0 in the Hertz field")


def test_first_yield_nu_03():
    p0_over_sy, depth, vm = first_yield(0.3)
    assert_allclose(vm, 0.620, rtol=5e-3, err_msg="max von Mises / p0 (Johnson §6.2)")
    assert_allclose(depth, 0.48, rtol=5e-3, err_msg="depth of first yield / a")
    assert_allclose(p0_over_sy, 1.60, rtol=1e-2, err_msg="p0 / σ_Y at first yield")
    assert_allclose(p0_over_sy * vm, 1.0, rtol=1e-14, err_msg="p0/σY = 1/(σvM/p0)")


def test_von_mises_maximum_is_on_axis():
    """The global maximum of σvM of the full field (ν = 0.3) is the on-axis one of first_yield."""
    a = 1.0
    r = np.linspace(0.0, 1.5, 61)
    z = np.linspace(0.0, 1.5, 301)
    R, Z = np.meshgrid(r, z, indexing="ij")
    vm = von_mises(hertz_subsurface_stress(R, 0.0, Z, a, 1.0, NU))
    i, j = np.unravel_index(np.argmax(vm), vm.shape)
    _, depth, vm_max = first_yield(NU)
    assert r[i] == 0.0, f"max von Mises off axis at r = {r[i]}"
    assert_allclose(vm[i, j], vm_max, rtol=1e-4, err_msg="grid maximum of σvM")
    assert_allclose(z[j], depth, atol=0.006, err_msg="depth of the grid maximum")


def test_von_mises_basic():
    assert_allclose(von_mises([1.0, 0, 0, 0, 0, 0]), 1.0, rtol=1e-15, err_msg="uniaxial")
    assert_allclose(von_mises([0, 0, 0, 1.0, 0, 0]), np.sqrt(3), rtol=1e-15, err_msg="shear")
    assert_allclose(
        von_mises(np.full((3, 2, 6), 0.0) + [5, 5, 5, 0, 0, 0]),
        0.0,
        atol=1e-15,
        err_msg="hydrostatic",
    )
    with pytest.raises(ValueError, match="6"):
        von_mises(np.zeros(5))


def test_surface_displacement_load_approach():
    W, R1, E1 = 4200.0, 20e-3, 210e9
    e_star = composite_modulus(E1, NU, E1, NU)
    hc = hertz_contact(W, effective_radius(R1), e_star)
    u0 = hertz_surface_displacement(0.0, hc.a, hc.p0, e_star)
    assert_allclose(u0, hc.a**2 / hc.radius, rtol=1e-13, err_msg="δ = a²/R")
    assert_allclose(u0, hc.approach, rtol=1e-13, err_msg="δ consistent with hertz_contact")
    r = np.linspace(0.0, hc.a, 11)
    u = hertz_surface_displacement(r, hc.a, hc.p0, e_star)
    assert_allclose(
        u,
        hc.approach - r**2 / (2 * hc.radius),
        rtol=1e-12,
        err_msg="surfaces conform inside the contact",
    )
    ro = np.linspace(hc.a, 4 * hc.a, 30)
    uo = hertz_surface_displacement(ro, hc.a, hc.p0, e_star)
    gap = ro**2 / (2 * hc.radius) - hc.approach + uo
    assert np.all(gap[1:] > 0), "positive gap outside the contact"
    assert_allclose(gap[0], 0.0, atol=1e-12 * hc.approach, err_msg="gap closes at r = a")
    assert np.all(np.diff(uo) < 0), "displacement decreases outside"
    # far field: point load W/(π E* r)
    far = hertz_surface_displacement(1e3 * hc.a, hc.a, hc.p0, e_star)
    assert_allclose(far, W / (np.pi * e_star * 1e3 * hc.a), rtol=1e-6, err_msg="far field")


def test_surface_displacement_against_quadrature():
    """Outside formula = ∫ p(ξ) / (π E* |x − ξ|) dξ (polar quadrature, s = a sin φ)."""
    a, p0, e_star = 1.0, 1.0, 1.0
    for r0 in (0.0, 0.5, 1.5, 3.0):
        phi, wphi = _graded_rule(0.0, 0.5 * np.pi, np.arcsin(min(r0, 1.0)), 1e-12, 12)
        th, wth = _graded_rule(-np.pi, np.pi, 0.0, 1e-12 if r0 <= 1 else 1.0, 12)
        s = a * np.sin(phi)[:, None]
        dist = np.hypot(r0 - s * np.cos(th), s * np.sin(th))
        w = (p0 * a * a * np.cos(phi) ** 2 * np.sin(phi) * wphi)[:, None] * wth
        numeric = np.sum(w / dist) / (np.pi * e_star)
        assert_allclose(
            hertz_surface_displacement(r0, a, p0, e_star),
            numeric,
            rtol=1e-6,
            err_msg=f"surface displacement at r = {r0}",
        )


def test_hertz_pressure_load():
    hc = hertz_contact(10.0, 1e-3, 1e11)
    # W = ∫ p dA = 2π a² p0 / 3
    t, w = np.polynomial.legendre.leggauss(40)
    phi = 0.25 * np.pi * (t + 1)
    s = hc.a * np.sin(phi)
    load = np.sum(
        0.25 * np.pi * w * 2 * np.pi * hertz_pressure(s, hc.a, hc.p0) * s * hc.a * np.cos(phi)
    )
    assert_allclose(load, 10.0, rtol=1e-12, err_msg="pressure integrates to the load")
    assert hertz_pressure(2 * hc.a, hc.a, hc.p0) == 0.0


@settings(max_examples=25, deadline=None)
@given(
    st.floats(1e-7, 1e-1), st.floats(1e6, 1e10), st.floats(-3, 3), st.floats(-3, 3), st.floats(0, 3)
)
def test_hertz_field_unit_neutral(a, p0, x1, x2, x3):
    s = hertz_subsurface_stress(a * x1, a * x2, a * x3, a, p0, NU) / p0
    ref = hertz_subsurface_stress(x1, x2, x3, 1.0, 1.0, NU)
    assert_allclose(s, ref, rtol=1e-9, atol=1e-12, err_msg="σ/p0 depends on x/a only")
