"""Tests of the infinite-space cuboid eigenstrain kernel (sacflow.kernels.cuboid).

Independent checks: surface quadrature of Kelvin's point-force solution (equivalent tractions
C:ε*·n on the faces), the interface jump conditions of an eigenstrain, equilibrium by finite
differences, reflection/permutation symmetries, the point-eigenstrain far field, exact
superposition of cells into a larger block, and the thin-layer limit.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from sacflow.kernels.cuboid import (
    COMPONENTS,
    cuboid_stress,
    cuboid_stress_component,
    stiffness_matrix,
)
from sacflow.kernels.quadrature_reference import (
    eigenstrain_stress_by_quadrature,
    kelvin_displacement_gradient,
)

MU = 80.0e9  # Pa
UM = 1.0e-6  # m
SHAPES = {"cube": (1.0, 1.0, 1.0), "brick": (1.0, 0.6, 2.5)}


def _stress(x, half, nu, mu=MU):
    """``cuboid_stress`` at points ``x`` of shape (n, 3)."""
    x = np.asarray(x, dtype=float)
    return cuboid_stress(x[:, 0], x[:, 1], x[:, 2], *half, nu, mu)


def _tensor(v):
    """(..., 6) components -> (..., 3, 3) symmetric tensor."""
    t = np.empty((*v.shape[:-1], 3, 3))
    for c, (i, j) in enumerate(COMPONENTS):
        t[..., i, j] = t[..., j, i] = v[..., c]
    return t


def _vector(t):
    """(..., 3, 3) tensor -> (..., 6) components."""
    return np.stack([t[..., i, j] for i, j in COMPONENTS], axis=-1)


def _eigenstress(nu, mu, source):
    """C:ε* (3×3) for the unit eigenstrain component ``source`` (tensor shear)."""
    e = np.zeros(6)
    e[source] = 1.0
    return _tensor(stiffness_matrix(nu, mu) @ e)


def _kelvin(r, nu, mu):
    """Kelvin's Green function G_ij (independent of the module), r of shape (..., 3)."""
    rr = np.linalg.norm(r, axis=-1)[..., None, None]
    rirj = r[..., :, None] * r[..., None, :]
    return ((3 - 4 * nu) * np.eye(3) / rr + rirj / rr**3) / (16 * math.pi * mu * (1 - nu))


def _kelvin_second_gradient(r, nu, mu):
    """G_ij,kl of Kelvin's solution (closed form written out here), r of shape (..., 3)."""
    d = np.eye(3)
    rr = np.linalg.norm(r, axis=-1)[..., None, None, None, None]
    ri = r[..., :, None, None, None]
    rj = r[..., None, :, None, None]
    rk = r[..., None, None, :, None]
    rl = r[..., None, None, None, :]
    dij, dkl = d[:, :, None, None], d[None, None, :, :]
    dik, djl = d[:, None, :, None], d[None, :, None, :]
    djk, dil = d[None, :, :, None], d[:, None, None, :]
    g = (
        -(3 - 4 * nu) * dij * (dkl / rr**3 - 3 * rk * rl / rr**5)
        + dik * (djl / rr**3 - 3 * rj * rl / rr**5)
        + djk * (dil / rr**3 - 3 * ri * rl / rr**5)
        - 3 * (dil * rj * rk + djl * ri * rk + dkl * ri * rj) / rr**5
        + 15 * ri * rj * rk * rl / rr**7
    )
    return g / (16 * math.pi * mu * (1 - nu))


def _point_eigenstrain_stress(x, volume, nu, mu):
    """Stress (n, 6, 6) of a point eigenstrain V·ε* at the origin: u_i,k = −V (C:ε*)_jl G_ij,lk."""
    g2 = _kelvin_second_gradient(np.asarray(x, dtype=float), nu, mu)
    c = stiffness_matrix(nu, mu)
    out = np.empty((len(x), 6, 6))
    for d in range(6):
        grad = -volume * np.einsum("nijlk,jl->nik", g2, _eigenstress(nu, mu, d))
        strain = 0.5 * (grad + np.swapaxes(grad, -1, -2))
        out[:, :, d] = _vector(strain) @ c.T
    return out


# ------------------------------------------------------------------------------------------
# Kelvin helpers (the reference itself must be right)
# ------------------------------------------------------------------------------------------


def test_kelvin_gradients_match_finite_differences():
    nu, mu = 0.27, MU
    r = np.array([[1.0, -0.4, 0.7], [-0.3, 2.0, -1.1]]) * UM
    eta = 1e-4 * UM
    fd1 = np.empty((2, 3, 3, 3))
    fd2 = np.empty((2, 3, 3, 3, 3))
    for k in range(3):
        e = np.zeros(3)
        e[k] = eta
        fd1[..., k] = (_kelvin(r + e, nu, mu) - _kelvin(r - e, nu, mu)) / (2 * eta)
        gp = kelvin_displacement_gradient(*(r + e).T, nu, mu)
        gm = kelvin_displacement_gradient(*(r - e).T, nu, mu)
        fd2[..., k] = (gp - gm) / (2 * eta)
    g1 = kelvin_displacement_gradient(*r.T, nu, mu)
    assert_allclose(g1, fd1, rtol=0, atol=1e-7 * np.abs(g1).max(), err_msg="G_ij,k vs FD of G")
    g2 = _kelvin_second_gradient(r, nu, mu)
    assert_allclose(g2, fd2, rtol=0, atol=1e-7 * np.abs(g2).max(), err_msg="G_ij,kl vs FD")


# ------------------------------------------------------------------------------------------
# closed form vs brute-force quadrature of Kelvin's solution
# ------------------------------------------------------------------------------------------

# multiples of the half sizes: cell-centre offsets (incl. the planes x_i = 0) and generic points
OUTSIDE = np.array(
    [
        [2.0, 0.0, 0.0],
        [0.0, -2.0, 0.0],
        [0.0, 0.0, 2.0],
        [2.0, 2.0, 0.0],
        [-2.0, 4.0, -2.0],
        [6.0, 0.0, -4.0],
        [3.1, -1.7, 0.4],
        [-0.35, 0.2, -2.6],
        [8.0, -7.0, 5.0],
    ]
)
INSIDE = np.array([[0.0, 0.0, 0.0], [0.3, -0.45, 0.2], [-0.5, 0.1, 0.55]])


@pytest.mark.parametrize("nu", [0.3, 0.45])
@pytest.mark.parametrize("shape", sorted(SHAPES))
def test_matches_quadrature_outside(shape, nu):
    half = np.array(SHAPES[shape]) * UM
    x = OUTSIDE * half
    closed = _stress(x, half, nu)
    for d in range(6):
        ref = eigenstrain_stress_by_quadrature(x, half, nu, MU, d, order=12, panels=4)
        scale = np.abs(closed[:, :, d]).max()
        assert_allclose(
            closed[:, :, d],
            ref,
            rtol=0,
            atol=1e-6 * scale,
            err_msg=f"cuboid {shape}, nu={nu}, source {d}: closed form vs Kelvin quadrature",
        )


@pytest.mark.parametrize("shape", sorted(SHAPES))
def test_matches_quadrature_inside(shape):
    """Inside, the closed form (including −C:ε*) equals the surface quadrature of Kelvin."""
    nu = 0.3
    half = np.array(SHAPES[shape]) * UM
    x = INSIDE * half
    closed = _stress(x, half, nu)
    for d in range(6):
        ref = eigenstrain_stress_by_quadrature(x, half, nu, MU, d, order=12, panels=6)
        scale = np.abs(closed[:, :, d]).max()
        assert_allclose(
            closed[:, :, d],
            ref,
            rtol=0,
            atol=1e-6 * scale,
            err_msg=f"cuboid {shape}, source {d}: inside stress vs Kelvin quadrature",
        )


def test_quadrature_reference_converges():
    """The reference itself: refining the rule changes the result by < 1e-9 (relative)."""
    half = np.array(SHAPES["brick"]) * UM
    x = np.vstack([OUTSIDE[:3], INSIDE[:1]]) * half
    for d in (0, 3):
        a = eigenstrain_stress_by_quadrature(x, half, 0.3, MU, d, order=12, panels=4)
        b = eigenstrain_stress_by_quadrature(x, half, 0.3, MU, d, order=16, panels=6)
        assert_allclose(a, b, rtol=0, atol=1e-9 * np.abs(b).max(), err_msg=f"source {d}")


# ------------------------------------------------------------------------------------------
# interface conditions and equilibrium
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("nu", [0.25, 0.4])
def test_face_jump_conditions(nu):
    """Across a face: σ·n continuous; the jump is C:(sym(g⊗n) + ε*) with (n·C·n) g = −(C:ε*)n."""
    half = np.array(SHAPES["brick"]) * UM
    lam = 2 * MU * nu / (1 - 2 * nu)
    delta = 1e-7
    for axis in range(3):
        n = np.zeros(3)
        n[axis] = 1.0
        base = np.array([0.3, -0.2, 0.25])
        base[axis] = 1.0
        x_in = (base - delta * n) * half
        x_out = (base + delta * n) * half
        a_in = _stress(x_in[None], half, nu)[0]
        a_out = _stress(x_out[None], half, nu)[0]
        acoustic = MU * np.eye(3) + (lam + MU) * np.outer(n, n)
        c = stiffness_matrix(nu, MU)
        for d in range(6):
            s = _eigenstress(nu, MU, d)
            g = -np.linalg.solve(acoustic, s @ n)
            e_star = np.zeros(6)
            e_star[d] = 1.0
            expected = c @ (_vector(0.5 * (np.outer(g, n) + np.outer(n, g))) + e_star)
            jump = a_out[:, d] - a_in[:, d]
            scale = np.abs(a_in[:, d]).max()
            assert_allclose(
                _tensor(jump) @ n,
                0.0,
                rtol=0,
                atol=1e-5 * scale,
                err_msg=f"traction jump across face {axis}, source {d}",
            )
            assert_allclose(
                jump,
                expected,
                rtol=0,
                atol=1e-5 * scale,
                err_msg=f"stress jump across face {axis}, source {d}",
            )


@pytest.mark.parametrize("where", ["outside", "inside"])
def test_equilibrium_finite_differences(where):
    """div σ = 0 off the faces (fourth-order central differences)."""
    nu = 0.3
    half = np.array(SHAPES["brick"]) * UM
    pts = (OUTSIDE[[0, 4, 6, 7]] if where == "outside" else INSIDE) * half
    eta = 2e-3 * half.min()
    div = np.zeros((len(pts), 3, 6))
    for k in range(3):
        e = np.zeros(3)
        e[k] = eta
        f = {
            m: _tensor(np.moveaxis(_stress(pts + m * e, half, nu), -1, -2)) for m in (-2, -1, 1, 2)
        }
        # f[m]: (n, source, 3, 3); derivative along k of σ_ik
        deriv = (f[-2] - 8 * f[-1] + 8 * f[1] - f[2]) / (12 * eta)
        div += np.moveaxis(deriv[..., :, k], 1, -1)
    scale = np.abs(_stress(pts, half, nu)).max() / half.min()
    assert_allclose(div, 0.0, rtol=0, atol=1e-7 * scale, err_msg=f"div σ ≠ 0 ({where})")


# ------------------------------------------------------------------------------------------
# symmetries and invariances
# ------------------------------------------------------------------------------------------


def _parity(axis):
    """s_c = (−1)^(number of times ``axis`` appears in component c)."""
    return np.array([(-1.0) ** COMPONENTS[c].count(axis) for c in range(6)])


def test_reflection_symmetry():
    """A_cd(R_i x) = s_c s_d A_cd(x); e.g. for x1 → −x1, s = −1 for 12, 13 and +1 otherwise."""
    half = np.array(SHAPES["brick"]) * UM
    x = np.vstack([OUTSIDE, INSIDE[1:]]) * half
    a = _stress(x, half, 0.3)
    assert_allclose(_parity(0), [1, 1, 1, -1, -1, 1], err_msg="parity rule of axis 1")
    for axis in range(3):
        xr = x.copy()
        xr[:, axis] *= -1
        s = _parity(axis)
        assert_allclose(
            _stress(xr, half, 0.3),
            a * s[:, None] * s[None, :],
            rtol=1e-12,
            atol=1e-13 * np.abs(a).max(),
            err_msg=f"reflection of axis {axis + 1}",
        )


@pytest.mark.parametrize("perm", [(1, 0, 2), (1, 2, 0)])
def test_axis_permutation(perm):
    """Relabelling the axes (cuboid sizes and points) permutes the components accordingly."""
    half = np.array(SHAPES["brick"]) * UM
    x = np.vstack([OUTSIDE, INSIDE[1:]]) * half
    p = np.array(perm)  # new axis a is old axis p[a]
    a = _stress(x, half, 0.3)
    b = _stress(x[:, p], half[p], 0.3)
    # component (i, j) in the new labels is old component (p[i], p[j])
    index = {frozenset(ij) if ij[0] != ij[1] else (ij[0],): c for c, ij in enumerate(COMPONENTS)}

    def old(c):
        i, j = COMPONENTS[c]
        key = (p[i],) if i == j else frozenset((p[i], p[j]))
        return index[key]

    mapping = np.array([old(c) for c in range(6)])
    assert_allclose(
        b,
        a[:, mapping][:, :, mapping],
        rtol=1e-12,
        atol=1e-13 * np.abs(a).max(),
        err_msg=f"axis permutation {perm}",
    )


def test_unit_neutrality_and_linearity_in_mu():
    """Scaling all lengths leaves A unchanged; A is proportional to μ."""
    half = np.array(SHAPES["brick"]) * UM
    x = OUTSIDE * half
    a = _stress(x, half, 0.3)
    b = _stress(x * 3.7e3, half * 3.7e3, 0.3, mu=2.5 * MU)
    assert_allclose(b, 2.5 * a, rtol=1e-12, atol=1e-13 * np.abs(a).max(), err_msg="scaling")


def test_component_matches_full_and_separable_grid():
    """cuboid_stress_component == column of cuboid_stress; sparse-grid fast path == points."""
    half = (1.0 * UM, 0.8 * UM, 0.5 * UM)
    k1, k2, k3 = np.arange(-5, 6), np.arange(-4, 5), np.arange(-3, 7)
    g = np.meshgrid(
        2 * half[0] * k1, 2 * half[1] * k2, 2 * half[2] * k3, indexing="ij", sparse=True
    )
    full = np.broadcast_arrays(*g)
    flat = cuboid_stress(*(f.ravel() for f in full), *half, 0.3, MU).reshape(*full[0].shape, 6, 6)
    assert np.all(np.isfinite(flat)), "NaN/inf at cell-centre offsets"
    sep = cuboid_stress(*g, *half, 0.3, MU)
    scale = np.abs(flat).max()
    assert_allclose(sep, flat, rtol=0, atol=1e-14 * scale, err_msg="separable fast path")
    for d in range(6):
        col = cuboid_stress_component(*g, *half, 0.3, MU, d)
        assert_allclose(col, flat[..., d], rtol=0, atol=1e-14 * scale, err_msg=f"source {d}")
    assert_allclose(
        flat[5, 4, 3, :, :3],
        _stress([[0.0, 0.0, 0.0]], half, 0.3)[0, :, :3],
        rtol=1e-12,
        err_msg="centre offset indexing",
    )


def test_rejects_bad_input():
    with pytest.raises(ValueError, match="source"):
        cuboid_stress_component(0.0, 0.0, 2.0, 1.0, 1.0, 1.0, 0.3, 1.0, 6)
    with pytest.raises(ValueError, match="half sizes"):
        cuboid_stress(0.0, 0.0, 2.0, 1.0, -1.0, 1.0, 0.3, 1.0)
    with pytest.raises(ValueError, match="Poisson"):
        cuboid_stress(0.0, 0.0, 2.0, 1.0, 1.0, 1.0, 0.5, 1.0)


# ------------------------------------------------------------------------------------------
# far field and superposition limits
# ------------------------------------------------------------------------------------------


def test_far_field_point_eigenstrain():
    """A → V × point-eigenstrain field with an O((size/r)²) error (slope −2 in log-log)."""
    nu = 0.3
    half = np.array(SHAPES["brick"]) * UM
    volume = 8 * half.prod()
    directions = np.array([[1.0, 0.3, -0.5], [-0.2, 1.0, 0.7], [0.4, -0.6, -1.0]])
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    distances = np.array([10.0, 20.0, 40.0]) * half.max()
    errors = []
    for r in distances:
        x = r * directions
        ref = _point_eigenstrain_stress(x, volume, nu, MU)
        err = np.abs(_stress(x, half, nu) - ref).max() / np.abs(ref).max()
        errors.append(err)
    slope = np.polyfit(np.log(distances), np.log(errors), 1)[0]
    assert_allclose(slope, -2.0, atol=0.15, err_msg=f"far-field error slope (errors {errors})")
    assert errors[-1] < 5e-3, f"far-field relative error at 40 sizes: {errors[-1]:.2e}"


def _block_sum(counts, half, point, nu, source):
    """Σ over a block of cells (counts per axis, centred) of the cell kernel at ``point``."""
    centres = [2 * h * (np.arange(n) - (n - 1) / 2) for n, h in zip(counts, half, strict=True)]
    g = np.meshgrid(*(point[i] - centres[i] for i in range(3)), indexing="ij", sparse=True)
    return cuboid_stress_component(*g, *half, nu, MU, source).sum(axis=(0, 1, 2))


def test_superposition_of_cells_equals_block():
    """Cells of a block sum exactly to the closed form of the block itself (inside and outside)."""
    nu = 0.3
    half = np.array([1.0, 0.7, 0.4]) * UM
    counts = (3, 5, 3)  # cell faces at x1 = ±1, ±3; x2 = ±0.7, ±2.1, ±3.5; x3 = ±0.4, ±1.2 µm
    big = half * np.array(counts)
    points = np.array([[0.3, 0.5, -0.1], [3.9, -1.0, 0.7], [0.0, 0.0, 0.0], [-1.7, 4.4, -2.3]])
    points = points * UM
    for d in range(6):
        summed = np.array([_block_sum(counts, half, p, nu, d) for p in points])
        direct = _stress(points, big, nu)[:, :, d]
        assert_allclose(
            summed,
            direct,
            rtol=0,
            atol=1e-11 * np.abs(direct).max(),
            err_msg=f"superposition of {counts} cells, source {d}",
        )


def test_thin_layer_limit():
    """A wide, thin slab of cells: ε11 = ε22 = 1 gives σ11 = σ22 = −2μ(1+ν)/(1−ν), σ33 ≈ 0 inside.

    201 × 201 × 5 cells of 2 × 2 × 0.1 (thickness t = 0.5, width L = 402): the finite width
    perturbs the centre stress by O(t/L) ≈ 1.2e-3 of the layer stress; tolerance 5e-3. A uniform
    ε33 = 1 in the same slab leaves (almost) no stress: |σ| < 5e-3 · 2μ.
    """
    nu = 0.3
    half = np.array([1.0, 1.0, 0.05]) * UM
    counts = (201, 201, 5)
    centre = np.zeros(3)
    sig = _block_sum(counts, half, centre, nu, 0) + _block_sum(counts, half, centre, nu, 1)
    layer = -2 * MU * (1 + nu) / (1 - nu)
    expected = np.array([layer, layer, 0.0, 0.0, 0.0, 0.0])
    assert_allclose(sig, expected, rtol=0, atol=5e-3 * abs(layer), err_msg="in-plane layer")
    sig33 = _block_sum(counts, half, centre, nu, 2)
    assert_allclose(sig33, 0.0, rtol=0, atol=5e-3 * 2 * MU, err_msg="ε33 layer: no stress")
    above = _block_sum(counts, half, np.array([0.0, 0.0, 20 * half[2]]), nu, 0)
    assert_allclose(above, 0.0, rtol=0, atol=5e-3 * abs(layer), err_msg="stress outside layer")
