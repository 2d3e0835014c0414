"""Tests of the closed-form rectangle and point-load kernels (sacflow.kernels.surface).

The rectangle formulas are checked against brute-force quadrature of the Boussinesq point-load
solution, the point-load stresses against finite differences of the point-load displacements and
Hooke's law, and both against invariants: symmetries, additivity, unit neutrality, equilibrium,
surface tractions and far-field limits.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from sacflow.kernels.surface import (
    boussinesq_displacement,
    boussinesq_stress,
    rectangle_displacement,
    rectangle_stress,
)

NU = 0.3
E = 210e9

# --------------------------------------------------------------------------------------------
# brute-force quadrature: composite Gauss-Legendre, panels graded geometrically toward the
# projection of the field point (where the point-load kernel is near-singular at scale x3)


def _graded_rule(lo: float, hi: float, c: float, h: float, n: int) -> tuple[np.ndarray, ...]:
    """Nodes and weights on [lo, hi], panels of size h·2^k around c (clipped to [lo, hi])."""
    levels = int(np.ceil(np.log2(max(hi - lo, abs(c - lo), abs(c - hi)) / h))) + 2
    steps = h * 2.0 ** np.arange(levels)
    bps = np.concatenate(([lo, hi], c - steps, c + steps))
    bps = np.unique(np.clip(bps, lo, hi))
    t, w = np.polynomial.legendre.leggauss(n)
    a, b = bps[:-1, None], bps[1:, None]
    nodes = 0.5 * (a + b) + 0.5 * (b - a) * t
    weights = 0.5 * (b - a) * w
    return nodes.ravel(), weights.ravel()


def quad_rectangle(kernel, x1, x2, x3, h1, h2, h, n=16):
    """∫∫ kernel(x1 - ξ1, x2 - ξ2, x3) over |ξ1| <= h1, |ξ2| <= h2 by graded Gauss rules."""
    n1, w1 = _graded_rule(-h1, h1, x1, h, n)
    n2, w2 = _graded_rule(-h2, h2, x2, h, n)
    vals = kernel(x1 - n1[:, None], x2 - n2[None, :], x3)
    return np.einsum("i,j,ij...->...", w1, w2, vals)


# --------------------------------------------------------------------------------------------
# rectangle_displacement


H1, H2 = 1.0, 0.6  # deliberately unequal half-widths: catches swapped axes

DISP_POINTS = [
    (0.0, 0.0),
    (0.3, -0.2),
    (0.9, 0.55),
    (-0.999999, 0.1),  # just inside an edge
    (1.000001, 0.1),  # just outside an edge
    (1.0 + 1e-9, 0.6 - 1e-9),  # next to a corner, outside
    (1.5, 0.0),
    (-2.0, 1.7),
    (0.2, 3.0),
]


@pytest.mark.parametrize(("x1", "x2"), DISP_POINTS)
def test_rectangle_displacement_matches_quadrature(x1, x2):
    exact = rectangle_displacement(x1, x2, H1, H2)

    def kernel(X, Y, z):
        return 1.0 / np.hypot(X, Y)

    numeric = quad_rectangle(kernel, x1, x2, 0.0, H1, H2, h=1e-13, n=12)
    assert_allclose(exact, numeric, rtol=1e-8, err_msg=f"Love's f at ({x1}, {x2})")


def test_rectangle_displacement_against_point_load_solution_units():
    """u3 = (1-ν²)/(πE) p f equals the quadrature of Boussinesq u3 = (1-ν²)/(πE r)."""
    p = 1.3e9
    x1, x2 = 0.4e-3, 0.1e-3
    h1, h2 = 0.5e-3, 0.25e-3
    u = (1 - NU**2) / (np.pi * E) * p * rectangle_displacement(x1, x2, h1, h2)

    def kernel(X, Y, z):
        return p * boussinesq_displacement(X, Y, z, NU, E)[..., 2]

    numeric = quad_rectangle(kernel, x1, x2, 0.0, h1, h2, h=1e-16, n=12)
    assert_allclose(u, numeric, rtol=1e-8, err_msg="rectangle u3 vs quadrature of Boussinesq")


def test_rectangle_displacement_finite_and_continuous_on_edges_and_corners():
    xs = np.array([-1.0, 1.0, 0.0, 1.0, -1.0])
    ys = np.array([0.0, 0.6, 0.6, -0.6, 0.3])
    f = rectangle_displacement(xs, ys, H1, H2)
    assert np.all(np.isfinite(f)), "f must be finite on edges and corners"
    for eps in (1e-10, -1e-10):
        near = rectangle_displacement(xs + eps, ys + eps, H1, H2)
        assert_allclose(near, f, rtol=1e-8, err_msg="f is continuous across edges and corners")


def test_rectangle_displacement_far_field_tends_to_point_load():
    dist = np.array([10.0, 20.0, 40.0, 80.0])
    f = rectangle_displacement(dist * 0.6, dist * 0.8, H1, H2)
    point = 4 * H1 * H2 / dist
    rel = np.abs(f / point - 1.0)
    assert_allclose(f, point, rtol=5e-3, err_msg="far field of the rectangle = point load")
    slope = np.polyfit(np.log(dist), np.log(rel), 1)[0]
    assert_allclose(slope, -2.0, atol=0.05, err_msg="far-field error decays like distance^-2")


def test_rectangle_displacement_centre_value():
    # centre of a square of side 2a: f = 8 a asinh(1) (Love 1929, x = y = 0)
    assert_allclose(
        rectangle_displacement(0.0, 0.0, 1.0, 1.0),
        8.0 * np.arcsinh(1.0),
        rtol=1e-14,
        err_msg="centre of a square",
    )


@settings(max_examples=30, deadline=None)
@given(
    st.floats(-3, 3),
    st.floats(-3, 3),
    st.floats(0.1, 2),
    st.floats(0.1, 2),
    st.floats(1e-6, 1e3),
)
def test_rectangle_displacement_scales_with_length(x1, x2, h1, h2, scale):
    f = rectangle_displacement(x1, x2, h1, h2)
    fs = rectangle_displacement(scale * x1, scale * x2, scale * h1, scale * h2)
    assert_allclose(fs, scale * f, rtol=1e-10, atol=1e-12 * scale, err_msg="f is homogeneous")


# --------------------------------------------------------------------------------------------
# boussinesq point load


def _hooke(strain, nu, E):
    G = E / (2 * (1 + nu))
    lam = 2 * G * nu / (1 - 2 * nu)
    tr = strain[..., 0] + strain[..., 1] + strain[..., 2]
    out = 2 * G * strain
    out[..., :3] += lam * tr[..., None]
    return out


def _fd_stress_from_displacement(x, nu, E, step):
    """σ from central differences of boussinesq_displacement (tensor order 11 22 33 12 13 23)."""
    grad = np.zeros((3, 3))  # grad[i, j] = ∂u_i/∂x_j
    for j in range(3):
        dx = np.zeros(3)
        dx[j] = step
        up = boussinesq_displacement(*(x + dx), nu, E)
        um = boussinesq_displacement(*(x - dx), nu, E)
        grad[:, j] = (up - um) / (2 * step)
    eps = 0.5 * (grad + grad.T)
    strain = np.array([eps[0, 0], eps[1, 1], eps[2, 2], eps[0, 1], eps[0, 2], eps[1, 2]])
    return _hooke(strain, nu, E)


@pytest.mark.parametrize(
    "x", [(0.3, -0.2, 0.5), (1.0, 0.0, 0.1), (-0.4, 0.7, 2.0), (0.0, 0.0, 1.0), (2.0, 1.5, 0.3)]
)
@pytest.mark.parametrize("nu", [0.0, 0.3, 0.49])
def test_boussinesq_stress_matches_displacement_gradient(x, nu):
    x = np.array(x)
    fd = _fd_stress_from_displacement(x, nu, E, step=1e-5)
    exact = boussinesq_stress(*x, nu)
    scale = np.abs(exact).max()
    assert_allclose(exact, fd, rtol=0, atol=1e-7 * scale, err_msg=f"Boussinesq σ at {x}")


def test_boussinesq_known_values():
    r = np.array([0.5, 1.0, 2.0])
    u = boussinesq_displacement(r, 0.0, 0.0, NU, E)
    assert_allclose(u[..., 2], (1 - NU**2) / (np.pi * E * r), rtol=1e-14, err_msg="surface u3")
    assert_allclose(
        u[..., 0],
        -(1 - 2 * NU) * (1 + NU) / (2 * np.pi * E * r),
        rtol=1e-14,
        err_msg="surface radial displacement (Johnson eq. 3.19)",
    )
    s = boussinesq_stress(r, 0.0, 0.0, NU)
    # surface, r > 0: σ_r = (1-2ν)/(2π r²) = -σ_θ, σ33 = σ13 = 0 (Johnson eq. 3.20)
    assert_allclose(s[..., 0], (1 - 2 * NU) / (2 * np.pi * r**2), rtol=1e-14, err_msg="σ_r")
    assert_allclose(s[..., 1], -(1 - 2 * NU) / (2 * np.pi * r**2), rtol=1e-14, err_msg="σ_θ")
    assert_allclose(s[..., [2, 4, 5]], 0.0, atol=1e-15, err_msg="traction-free surface")


def test_boussinesq_force_balance_on_a_plane():
    """∫∫ σ33 dA over any plane x3 = c equals -1 (the unit compressive force)."""
    c = 0.7
    # polar quadrature: σ33 = -3 c³ / (2π R⁵) is radial; substitute r = c tan t
    t, w = np.polynomial.legendre.leggauss(80)
    t = 0.25 * np.pi * (t + 1)
    w = 0.25 * np.pi * w
    r = c * np.tan(t)
    s33 = boussinesq_stress(r, 0.0, c, NU)[..., 2]
    total = np.sum(w * 2 * np.pi * r * s33 * c / np.cos(t) ** 2)
    assert_allclose(total, -1.0, rtol=1e-12, err_msg="force balance of the point load")


def test_boussinesq_equilibrium():
    x = np.array([0.4, -0.3, 0.6])
    h = 1e-5
    div = np.zeros(3)
    rows = [(0, 3, 4), (3, 1, 5), (4, 5, 2)]  # σ_i1, σ_i2, σ_i3 in the 6-vector
    for j in range(3):
        dx = np.zeros(3)
        dx[j] = h
        ds = (boussinesq_stress(*(x + dx), NU) - boussinesq_stress(*(x - dx), NU)) / (2 * h)
        for i in range(3):
            div[i] += ds[rows[i][j]]
    scale = np.abs(boussinesq_stress(*x, NU)).max() / np.linalg.norm(x)
    assert_allclose(div, 0.0, atol=1e-7 * scale, err_msg="div σ = 0 for the point load")


# --------------------------------------------------------------------------------------------
# rectangle_stress

FAST_STRESS_POINTS = [
    (0.0, 0.0, 0.05),
    (0.3, -0.2, 0.3),
    (1.0, 0.2, 0.05),  # under an edge, shallow
    (1.0, 0.6, 0.2),  # under a corner
    (-0.99, 0.59, 0.1),
    (1.7, -0.3, 0.5),
    (-2.5, 1.2, 1.0),
    (0.0, 0.0, 5.0),
    (0.0, -0.6, 1.3),
]


def _check_rectangle_stress(x1, x2, x3, nu=NU):
    exact = rectangle_stress(x1, x2, x3, H1, H2, nu)

    def kernel(X, Y, z):
        return boussinesq_stress(X, Y, z, nu)

    numeric = quad_rectangle(kernel, x1, x2, x3, H1, H2, h=0.5 * x3, n=16)
    scale = np.abs(numeric).max()
    assert_allclose(
        exact,
        numeric,
        rtol=0,
        atol=1e-7 * scale,
        err_msg=f"rectangle σ vs quadrature at ({x1}, {x2}, {x3})",
    )


@pytest.mark.parametrize(("x1", "x2", "x3"), FAST_STRESS_POINTS)
def test_rectangle_stress_matches_quadrature(x1, x2, x3):
    _check_rectangle_stress(x1, x2, x3)


@pytest.mark.parametrize("nu", [0.0, 0.25, 0.5])
def test_rectangle_stress_matches_quadrature_other_nu(nu):
    _check_rectangle_stress(0.8, -0.5, 0.15, nu)


@pytest.mark.parametrize("x3", [0.05, 0.2, 0.7, 2.0, 5.0])
def test_rectangle_stress_matches_quadrature_sweep(x3):
    for x1 in (0.0, 0.5, 0.97, 1.0, 1.03, 1.6, -3.0):
        for x2 in (0.0, -0.3, 0.6, 0.62, 2.0):
            _check_rectangle_stress(x1, x2, x3)


def test_rectangle_stress_symmetries():
    rng = np.random.default_rng(1)
    x1, x2 = rng.uniform(-2, 2, (2, 50))
    x3 = rng.uniform(0.01, 3, 50)
    s = rectangle_stress(x1, x2, x3, H1, H2, NU)
    flip1 = np.array([1, 1, 1, -1, -1, 1])
    flip2 = np.array([1, 1, 1, -1, 1, -1])
    assert_allclose(
        rectangle_stress(-x1, x2, x3, H1, H2, NU),
        s * flip1,
        rtol=1e-12,
        atol=1e-14,
        err_msg="x1 -> -x1 flips σ12 and σ13",
    )
    assert_allclose(
        rectangle_stress(x1, -x2, x3, H1, H2, NU),
        s * flip2,
        rtol=1e-12,
        atol=1e-14,
        err_msg="x2 -> -x2 flips σ12 and σ23",
    )
    swapped = rectangle_stress(x2, x1, x3, H2, H1, NU)[..., [1, 0, 2, 3, 5, 4]]
    assert_allclose(swapped, s, rtol=1e-12, atol=1e-14, err_msg="x1 <-> x2 exchange")


def test_rectangle_stress_additivity():
    """Two adjacent half rectangles add up to the whole one (also across their shared edge)."""
    rng = np.random.default_rng(2)
    x1 = np.concatenate([rng.uniform(-2, 2, 40), [0.0, 0.0, 0.5, -0.5]])
    x2 = np.concatenate([rng.uniform(-2, 2, 40), [0.0, 0.3, 0.6, -0.6]])
    x3 = np.concatenate([rng.uniform(0.01, 2, 40), [0.02, 0.3, 0.05, 1.0]])
    whole = rectangle_stress(x1, x2, x3, H1, H2, NU)
    halves = rectangle_stress(x1 + H1 / 2, x2, x3, H1 / 2, H2, NU) + rectangle_stress(
        x1 - H1 / 2, x2, x3, H1 / 2, H2, NU
    )
    assert_allclose(halves, whole, rtol=0, atol=1e-13, err_msg="superposition of rectangles")
    fw = rectangle_displacement(x1, x2, H1, H2)
    fh = rectangle_displacement(x1, x2 + H2 / 2, H1, H2 / 2) + rectangle_displacement(
        x1, x2 - H2 / 2, H1, H2 / 2
    )
    assert_allclose(fh, fw, rtol=1e-13, err_msg="superposition of rectangle displacements")


@settings(max_examples=30, deadline=None)
@given(
    st.floats(-3, 3),
    st.floats(-3, 3),
    st.floats(0.01, 3),
    st.floats(0.1, 2),
    st.floats(1e-6, 1e3),
)
def test_rectangle_stress_unit_neutral(x1, x2, x3, h1, scale):
    s = rectangle_stress(x1, x2, x3, h1, 0.7, NU)
    ss = rectangle_stress(scale * x1, scale * x2, scale * x3, scale * h1, scale * 0.7, NU)
    assert_allclose(ss, s, rtol=1e-9, atol=1e-12, err_msg="stress per unit pressure is scale-free")


def test_rectangle_stress_surface_limit():
    z = 1e-10
    inside = rectangle_stress([0.0, 0.5, -0.9, 0.99], [0.0, -0.3, 0.5, 0.59], z, H1, H2, NU)
    outside = rectangle_stress([1.2, 0.0, -3.0, 1.01], [0.0, 0.8, 2.0, 0.61], z, H1, H2, NU)
    assert_allclose(inside[..., 2], -1.0, atol=1e-8, err_msg="σ33 = -p under the load")
    assert_allclose(outside[..., 2], 0.0, atol=1e-8, err_msg="σ33 = 0 outside the load")
    assert_allclose(inside[..., 4:], 0.0, atol=1e-8, err_msg="σ13, σ23 -> 0 inside")
    assert_allclose(outside[..., 4:], 0.0, atol=1e-8, err_msg="σ13, σ23 -> 0 outside")
    # at the surface the lateral stresses are continuous with x3 = 0 exactly
    on = rectangle_stress([0.0, 1.2], [0.0, 0.0], 0.0, H1, H2, NU)
    assert np.all(np.isfinite(on)), "surface values away from the edges are finite"
    assert_allclose(on[..., 2], [-1.0, 0.0], atol=1e-14, err_msg="σ33 at x3 = 0")
    assert_allclose(
        on,
        rectangle_stress([0.0, 1.2], [0.0, 0.0], z, H1, H2, NU),
        atol=1e-8,
        err_msg="x3 = 0 is the limit x3 -> 0+",
    )


def test_rectangle_stress_equilibrium():
    rng = np.random.default_rng(3)
    pts = np.column_stack(
        [rng.uniform(-2, 2, 30), rng.uniform(-2, 2, 30), rng.uniform(0.05, 2, 30)]
    )
    h = 1e-4
    rows = [(0, 3, 4), (3, 1, 5), (4, 5, 2)]
    div = np.zeros((len(pts), 3))
    for j in range(3):
        dx = np.zeros(3)
        dx[j] = h
        sp = rectangle_stress(*(pts + dx).T, H1, H2, NU)
        sm = rectangle_stress(*(pts - dx).T, H1, H2, NU)
        ds = (sp - sm) / (2 * h)
        for i in range(3):
            div[:, i] += ds[:, rows[i][j]]
    # FD truncation ~ h² |∂³σ| ~ h² / x3³
    atol = 10 * h**2 / pts[:, 2:3] ** 3
    assert np.all(np.abs(div) < atol), f"div σ too large: {np.abs(div).max()}"


def test_rectangle_stress_far_field_tends_to_point_load():
    dist = np.array([10.0, 20.0, 40.0, 80.0])
    d = np.array([0.3, 0.5, 0.6]) / np.linalg.norm([0.3, 0.5, 0.6])
    x = dist[:, None] * d
    s = rectangle_stress(*x.T, H1, H2, NU)
    point = 4 * H1 * H2 * boussinesq_stress(*x.T, NU)
    rel = np.abs(s - point).max(axis=-1) / np.abs(point).max(axis=-1)
    assert np.all(rel < 1e-2), f"far field not point-like: {rel}"
    slope = np.polyfit(np.log(dist), np.log(rel), 1)[0]
    assert_allclose(slope, -2.0, atol=0.1, err_msg="far-field error decays like distance^-2")


def test_rectangle_stress_broadcasting_and_validation():
    x1 = np.linspace(-2, 2, 5)[:, None, None]
    x2 = np.linspace(-2, 2, 4)[None, :, None]
    x3 = np.array([0.1, 0.5, 1.0])
    out = rectangle_stress(x1, x2, x3, H1, H2, NU)
    assert out.shape == (5, 4, 3, 6)
    assert out.dtype == np.float64
    assert np.all(np.isfinite(out))
    with pytest.raises(ValueError, match="x3"):
        rectangle_stress(0.0, 0.0, -1.0, H1, H2, NU)
