"""Tests of the surface residual displacement kernel (sacflow.kernels.residual_displacement).

Independent checks: Duffy/Gauss quadrature of Boussinesq's point-force stress over the cuboid
(reciprocal theorem), the deviatoric form 2μ ∫ ε*:ε^B dV with ε^B from finite differences of
Boussinesq's displacement, the layer limits (ε33: −e t; ε11 = ε22: −(1 + 2ν) e t, decomposed
into the 1-D laterally constrained layer plus the edge-force term evaluated from Boussinesq's
lateral surface displacement), reflection and axis-swap symmetries, the point-source far
field with its convergence rate, exact superposition of cells, unit neutrality, and agreement
of the lattice (separable) and pointwise evaluation paths.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from sacflow.kernels.cuboid import SHEAR_WEIGHTS
from sacflow.kernels.quadrature_reference import surface_displacement_by_quadrature
from sacflow.kernels.residual_displacement import cuboid_surface_displacement
from sacflow.kernels.surface import boussinesq_displacement, boussinesq_stress

E = 210.0e9
I6 = np.eye(6)
SHAPES = {
    "cube": (1.0, 1.0, 1.0),
    "elongated": (2.5, 0.6, 0.25),  # deliberately unequal: catches swapped axes
}


def _points(h1, h2):
    """Surface points: above the centre, inside, on face planes and corner lines, beside,
    diagonal, far away."""
    return [
        (0.0, 0.0),
        (0.3 * h1, -0.55 * h2),
        (h1, 0.0),
        (h1, h2),
        (-h1, 0.4 * h2),
        (2.0 * h1, 0.0),
        (-2.0 * h1, 4.0 * h2),
        (3.3 * h1, -2.7 * h2),
        (12.0 * h1, 9.0 * h2),
    ]


def _compare(half, nu, depths, order=12):
    h1, h2, h3 = half
    got, ref = [], []
    for c3 in depths:
        for x1, x2 in _points(h1, h2):
            got.append(cuboid_surface_displacement(x1, x2, c3, h1, h2, h3, nu))
            ref.append(surface_displacement_by_quadrature(x1, x2, c3, half, nu, I6, order=order))
    return np.array(got), np.array(ref)


# --------------------------------------------------------------------------------------------
# closed form vs quadrature


@pytest.mark.parametrize("nu", [0.3, 0.2])
@pytest.mark.parametrize("name", list(SHAPES))
def test_matches_quadrature(name, nu):
    """Top layer (touching the surface) and deeper cuboids, all 6 columns."""
    half = SHAPES[name]
    h3 = half[2]
    got, ref = _compare(half, nu, depths=[h3, 3.0 * h3, 5.3 * h3])
    col = np.abs(ref).max(axis=0)
    # observed ≲ 1e-13; the quadrature itself converges to ≈ 1e-12 at order 12
    assert_allclose(
        got / col,
        ref / col,
        rtol=0.0,
        atol=1e-9,
        err_msg=f"closed form vs quadrature ({name}, nu={nu}), relative to column max",
    )


@pytest.mark.slow
def test_matches_quadrature_random_sweep():
    """Random aspect ratios, offsets (lattice, arbitrary, on face planes, far) and depths."""
    rng = np.random.default_rng(7)
    worst = 0.0
    for _ in range(120):
        half = np.exp(rng.uniform(np.log(0.1), np.log(3.0), 3))
        kind = rng.integers(3)
        if kind == 0:
            x1, x2 = rng.integers(-4, 5) * half[0], rng.integers(-4, 5) * half[1]
        elif kind == 1:
            x1, x2 = rng.uniform(-3.0, 3.0, 2) * half[:2]
        else:
            x1, x2 = rng.choice([-1.0, 1.0]) * half[0], rng.uniform(-3.0, 3.0) * half[1]
        c3 = half[2] * (1.0 + rng.choice([0.0, 0.0, 2.0 * rng.integers(1, 5), 0.02]))
        nu = float(rng.choice([0.2, 0.3, 0.45]))
        got = cuboid_surface_displacement(x1, x2, c3, *half, nu)
        ref = surface_displacement_by_quadrature(x1, x2, c3, half, nu, I6, order=16)
        worst = max(worst, float(np.abs(got - ref).max() / np.abs(ref).max()))
    assert worst < 1e-9, f"worst relative deviation from quadrature {worst:.3e}"


@pytest.mark.slow  # about 0.65-0.9 GB peak: above the default suite's 0.5 GB budget
def test_quadrature_reference_converges():
    """The reference is converged far below the test tolerances (singular top-layer case)."""
    half = SHAPES["elongated"]
    for x1, x2, c3 in [
        (0.0, 0.0, half[2]),
        (half[0], 0.5 * half[1], half[2]),
        (0.7, 0.1, 1.05 * half[2]),
    ]:
        a = surface_displacement_by_quadrature(x1, x2, c3, half, 0.3, I6, order=12)
        b = surface_displacement_by_quadrature(x1, x2, c3, half, 0.3, I6, order=16)
        assert_allclose(
            a,
            b,
            rtol=0.0,
            atol=1e-11 * np.abs(b).max(),
            err_msg=f"quadrature order 12 vs 16 at {(x1, x2, c3)}",
        )


# --------------------------------------------------------------------------------------------
# deviatoric form 2μ ∫ ε*:ε^B dV (Jacq et al. 2002 eq. 2.3)


def _fd_strain(X, Y, Z, nu):
    """Boussinesq strain (tensor components) by 4th-order finite differences of the
    displacement: central in x1, x2, one-sided (into the body) in x3."""
    h = 1e-3 * np.sqrt(X * X + Y * Y + Z * Z)
    c = np.array([1.0, -8.0, 8.0, -1.0]) / 12.0
    f = np.array([-25.0, 48.0, -36.0, 16.0, -3.0]) / 12.0
    grad = np.zeros((*X.shape, 3, 3))  # grad[..., i, j] = ∂u_j / ∂x_i
    for k, s in enumerate((-2.0, -1.0, 1.0, 2.0)):
        grad[..., 0, :] += c[k] * boussinesq_displacement(X + s * h, Y, Z, nu, E)
        grad[..., 1, :] += c[k] * boussinesq_displacement(X, Y + s * h, Z, nu, E)
    for k in range(5):
        grad[..., 2, :] += f[k] * boussinesq_displacement(X, Y, Z + k * h, nu, E)
    grad /= h[..., None, None]
    eps = 0.5 * (grad + np.swapaxes(grad, -1, -2))
    pairs = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
    return np.stack([eps[..., i, j] for i, j in pairs], axis=-1)


@pytest.mark.parametrize("nu", [0.3, 0.2])
def test_deviatoric_form(nu):
    """For trace-free ε*, u3 = 2μ ∫ ε*:ε^B dV with ε^B independent of the stress formulas."""
    mu = E / (2.0 * (1.0 + nu))
    source = np.array([0.8, -0.3, -0.5, 0.4, -0.25, 0.6])  # trace 0

    def integrand(X, Y, Z):
        return 2.0 * mu * _fd_strain(X, Y, Z, nu)

    half = SHAPES["elongated"]
    for x1, x2, c3 in [
        (0.0, 0.0, half[2]),
        (half[0], -half[1], half[2]),
        (3.0, 1.0, 3.0 * half[2]),
    ]:
        got = cuboid_surface_displacement(x1, x2, c3, *half, nu) @ source
        ref = surface_displacement_by_quadrature(
            x1, x2, c3, half, nu, source, order=10, integrand=integrand
        )
        assert_allclose(
            got, ref, rtol=1e-8, err_msg=f"2 mu eps*:eps^B form at {(x1, x2, c3)}, nu={nu}"
        )


# --------------------------------------------------------------------------------------------
# layer limits


def _block_sum(nu, n=201, dx=1.0, dz=0.01, nz=3):
    x = (np.arange(n) - n // 2) * dx
    c3 = (np.arange(nz) + 0.5) * dz
    k = cuboid_surface_displacement(
        x[:, None, None], x[None, :, None], c3[None, None, :], dx / 2, dx / 2, dz / 2, nu
    )
    return k.sum(axis=(0, 1, 2)), nz * dz, n * dx / 2


@pytest.mark.parametrize("nu", [0.3, 0.2])
def test_layer_limit_normal(nu):
    """ε33 = e in a wide layer lifts the surface by e t: u3 = −e t (the tail of the finite
    block is O((t/L)³), i.e. < 1e-11 here)."""
    s, t, _ = _block_sum(nu)
    assert_allclose(s[2], -t, rtol=1e-8, err_msg="eps33 layer: u3 = -e t")


@pytest.mark.parametrize("nu", [0.3, 0.2])
def test_layer_limit_in_plane(nu):
    """ε11 = ε22 = e in a wide block 0 < x3 < t, |x1|, |x2| < L: u3 → −(1 + 2ν) e t.

    Reciprocity: ∫∫ (σ^B_11 + σ^B_22) dA = −(1 + 2ν) on every plane.  Outside the square
    the integrand is ≈ −(1 + ν) x3 / (π r³), whose integral over the outside of the square,
    ∮ max(|cos|, |sin|) dθ / L = 4√2 / L, gives the finite-size tail
    +(1 + ν) 2√2 t² / (π L) (relative 2.4e-4 here); with it the agreement is ≈ 1e-7.

    The same number from elasticity: the laterally constrained layer (σ11 = σ22 =
    −E e / (1 − ν), thickening 2ν e t / (1 − ν)) plus the outward edge line force
    f = E e t / (1 − ν) whose normal surface displacement at the centre is, by reciprocity,
    ∮ f n·u^B dl with u^B Boussinesq's lateral surface displacement of a unit normal force at
    the centre, evaluated here by quadrature along the square.
    """
    s, t, L = _block_sum(nu)
    got = s[0] + s[1]
    tail = (1.0 + nu) * 2.0 * np.sqrt(2.0) * t * t / (np.pi * L)
    assert_allclose(
        got,
        -(1.0 + 2.0 * nu) * t + tail,
        rtol=1e-6,
        err_msg="in-plane block: -(1+2nu) e t + finite-size tail",
    )
    assert_allclose(
        got,
        -(1.0 + 2.0 * nu) * t,
        rtol=2.0 * tail / t,
        err_msg="in-plane block: -(1+2nu) e t within the tail bound",
    )
    # 1-D layer + edge force (Cerruti term via reciprocity), thin block: forces at x3 ≈ 0
    one_d = -2.0 * nu * t / (1.0 - nu)
    f = E * t / (1.0 - nu)
    g, w = np.polynomial.legendre.leggauss(200)
    s_edge = L * g  # one side x1 = L, −L < x2 < L, outward normal +x1; 4 equal sides
    u = boussinesq_displacement(L, s_edge, 0.0, nu, E)
    edge = 4.0 * f * np.sum(L * w * u[:, 0])
    assert_allclose(
        edge,
        -(1.0 - 2.0 * nu) * (1.0 + nu) * t / (1.0 - nu),
        rtol=1e-10,
        err_msg="edge force term is independent of the block size",
    )
    assert_allclose(
        got,
        one_d + edge + tail,
        rtol=1e-6,
        err_msg="block = 1-D constrained layer + edge-force (Cerruti) term",
    )


# --------------------------------------------------------------------------------------------
# invariants


def test_reflection_and_swap_symmetries():
    rng = np.random.default_rng(3)
    h1, h2, h3 = 1.3, 0.7, 0.4
    x1 = rng.uniform(-4.0, 4.0, 40)
    x2 = rng.uniform(-4.0, 4.0, 40)
    c3 = h3 + rng.choice([0.0, 0.8, 2.4], 40)
    k = cuboid_surface_displacement(x1, x2, c3, h1, h2, h3, 0.3)
    scale = np.abs(k).max()
    flip1 = np.array([1, 1, 1, -1, -1, 1])
    flip2 = np.array([1, 1, 1, -1, 1, -1])
    assert_allclose(
        cuboid_surface_displacement(-x1, x2, c3, h1, h2, h3, 0.3),
        k * flip1,
        rtol=0.0,
        atol=1e-13 * scale,
        err_msg="x1 -> -x1: 12, 13 odd",
    )
    assert_allclose(
        cuboid_surface_displacement(x1, -x2, c3, h1, h2, h3, 0.3),
        k * flip2,
        rtol=0.0,
        atol=1e-13 * scale,
        err_msg="x2 -> -x2: 12, 23 odd",
    )
    swapped = cuboid_surface_displacement(x2, x1, c3, h2, h1, h3, 0.3)
    assert_allclose(
        swapped[:, [1, 0, 2, 3, 5, 4]],
        k,
        rtol=0.0,
        atol=1e-13 * scale,
        err_msg="x1 <-> x2 swaps 11 <-> 22 and 13 <-> 23",
    )


def test_unit_neutrality():
    """K has the dimension of a length: scaling every length by λ scales K by λ."""
    lam = 3.7e-6
    pts = np.array([[0.0, 0.0, 0.5], [1.0, 0.6, 0.5], [2.0, -1.2, 1.5], [-7.0, 3.0, 2.5]])
    a = cuboid_surface_displacement(pts[:, 0], pts[:, 1], pts[:, 2], 1.0, 0.6, 0.5, 0.3)
    b = cuboid_surface_displacement(*(lam * pts.T), lam, lam * 0.6, lam * 0.5, 0.3)
    assert_allclose(b, lam * a, rtol=1e-12, atol=1e-14 * lam, err_msg="unit neutrality")


def test_superposition_of_cells_equals_block():
    """A 3 × 2 × 2 block of cells gives the same u3 as one cuboid of the block's size."""
    d1, d2, d3 = 1.0, 0.8, 0.3
    for x1, x2 in [(0.0, 0.0), (1.5, 0.8), (-4.0, 2.0)]:
        cells = sum(
            cuboid_surface_displacement(
                x1 - i * d1, x2 - j * d2, (k + 0.5) * d3, d1 / 2, d2 / 2, d3 / 2, 0.25
            )
            for i in (-1, 0, 1)
            for j in (0, 1)
            for k in (0, 1)
        )
        block = cuboid_surface_displacement(x1, x2 - d2 / 2, d3, 1.5 * d1, d2, d3, 0.25)
        assert_allclose(
            cells,
            block,
            rtol=0.0,
            atol=1e-13 * np.abs(block).max(),
            err_msg=f"superposition at {(x1, x2)}",
        )


def test_far_field_point_source_and_rate():
    """Far away u3 → V w σ^B(x_c − A); the error decays like (size/distance)²."""
    half = np.array([1.0, 0.6, 0.4])
    c3 = half[2]  # top layer; at depth c3 the asymptote needs distance >> c3 as well
    vol = 8.0 * np.prod(half)
    dists = np.array([25.0, 50.0, 100.0, 200.0])
    errs = []
    for d in dists:
        x1, x2 = 0.8 * d, -0.6 * d
        k = cuboid_surface_displacement(x1, x2, c3, *half, 0.3)
        point = vol * SHEAR_WEIGHTS * boussinesq_stress(-x1, -x2, c3, 0.3)
        errs.append(np.abs(k - point).max() / np.abs(point).max())
        assert_allclose(
            k,
            point,
            rtol=0.0,
            atol=0.02 * (25.0 / d) ** 2 * np.abs(point).max(),
            err_msg=f"point-source far field at distance {d}",
        )
    slope = np.polyfit(np.log(dists), np.log(errs), 1)[0]
    assert abs(slope + 2.0) < 0.15, f"far-field error slope {slope:.3f}, expected -2"


def test_lattice_path_matches_pointwise():
    """Separable inputs (lattice evaluation, parity folding) equal the 8-corner loop."""
    rng = np.random.default_rng(5)
    h = (0.5, 0.35, 0.1)
    x1 = np.concatenate([np.arange(-6, 7) * 2 * h[0], rng.uniform(-5.0, 5.0, 5)])
    x2 = np.arange(-4, 9) * 2 * h[1]  # not symmetric
    c3 = (np.arange(4) + 0.5) * 2 * h[2]
    # unusual axis order: depth first, then x2, then x1
    lat = cuboid_surface_displacement(
        x1[None, None, :], x2[None, :, None], c3[:, None, None], *h, 0.3
    )
    X1, X2, C3 = np.broadcast_arrays(x1[None, None, :], x2[None, :, None], c3[:, None, None])
    pw = cuboid_surface_displacement(X1.copy(), X2.copy(), C3.copy(), *h, 0.3)
    assert lat.shape == pw.shape == (4, x2.size, x1.size, 6)
    assert_allclose(
        lat, pw, rtol=0.0, atol=1e-11 * np.abs(pw).max(), err_msg="lattice vs pointwise evaluation"
    )
    # 2-D lattice with a scalar depth (top layer)
    x = np.arange(-20, 21) * 2 * h[0]
    lat2 = cuboid_surface_displacement(x[:, None], x[None, :], h[2], *h, 0.3)
    Y1, Y2 = np.broadcast_arrays(x[:, None], x[None, :])
    pw2 = cuboid_surface_displacement(Y1.copy(), Y2.copy(), np.full(Y1.shape, h[2]), *h, 0.3)
    assert lat2.shape == (x.size, x.size, 6)
    assert_allclose(
        lat2, pw2, rtol=0.0, atol=1e-11 * np.abs(pw2).max(), err_msg="2-D lattice, scalar depth"
    )


def test_finite_on_every_face_plane_and_corner_line():
    """Offsets at every multiple of the half sizes (face planes, corner lines, centre)."""
    h = (0.5, 0.5, 0.5)
    x = np.arange(-6, 7) * 0.5
    c3 = np.array([0.5, 1.5, 2.5])
    k = cuboid_surface_displacement(x[:, None, None], x[None, :, None], c3, *h, 0.3)
    assert np.all(np.isfinite(k)), "NaN/inf on face planes or corner lines"
    i0 = np.flatnonzero(x == 0.0)[0]
    assert np.all(np.abs(k[i0, i0, :, 3:]) < 1e-15), "shear columns vanish above the centre"
    # above the centre of the top cell the normal column is an outward lift (u3 < 0)
    assert k[i0, i0, 0, 2] < 0.0, "eps33 cell lifts the surface above it"


def test_rejects_bad_input():
    with pytest.raises(ValueError, match="half-space"):
        cuboid_surface_displacement(0.0, 0.0, 0.4, 1.0, 1.0, 0.5, 0.3)
    with pytest.raises(ValueError, match="half sizes"):
        cuboid_surface_displacement(0.0, 0.0, 1.0, -1.0, 1.0, 0.5, 0.3)
    with pytest.raises(ValueError, match="half-space"):
        surface_displacement_by_quadrature(0.0, 0.0, 0.4, (1.0, 1.0, 0.5), 0.3, I6)
