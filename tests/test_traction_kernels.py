"""Shear-traction kernels (sacflow.kernels.shear) against references built independently of them.

* Cerruti's point force: Johnson's textbook Cartesian stresses (written out here term by term,
  a different grouping from the module's potentials), equilibrium and Beltrami–Michell
  compatibility by finite differences, the free surface, and the force *and moment* balance of
  the slab above a horizontal plane;
* the rectangle: every component against tensor Gauss–Legendre quadrature of the point force
  (panels split at the field point's projection and graded geometrically from it), vectorised
  over points inside, under edges and corners, outside, shallow (z = 0.05 h) and deep (z = 5 h),
  for square and elongated rectangles and ν = 0, 0.3, 0.45; continuity across the planes
  through the edges (no branch cut of the arctangent or the logarithms);
* a uniform traction on a very large rectangle: the exact uniform shear state σ13 = −q;
* parities of an x1 traction, and the x2 traction as the x1 one rotated by 90°.
"""

from __future__ import annotations

import numpy as np
import pytest

from sacflow.kernels.shear import cerruti_stress, rectangle_shear_stress, traction_stress

#: Required agreement of the closed form with the quadrature, relative to the largest
#: |component| at the field point.
REL_TOL = 1e-6

#: (11, 22, 33, 12, 13, 23) -> index pair, and back.
PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
VOIGT = {**{p: c for c, p in enumerate(PAIRS)}, **{p[::-1]: c for c, p in enumerate(PAIRS)}}


def johnson_cerruti(x, y, z, nu):
    """Cerruti's stresses per unit force Q along +x1 (Johnson, *Contact Mechanics*, 1985).

    Tension positive, z the depth, ρ = |x|; written as in the textbook (not from the module's
    potentials A, C, D).
    """
    r = np.sqrt(x * x + y * y + z * z)
    rz = r + z
    k, c = 1.0 - 2.0 * nu, 1.0 / (2.0 * np.pi)
    s11 = -3 * x**3 / r**5 + k * (
        x / r**3 - 3 * x / (r * rz**2) + x**3 / (r**3 * rz**2) + 2 * x**3 / (r**2 * rz**3))
    s22 = -3 * x * y * y / r**5 + k * (
        x / r**3 - x / (r * rz**2) + x * y * y / (r**3 * rz**2) + 2 * x * y * y / (r**2 * rz**3))
    s12 = -3 * x * x * y / r**5 + k * (
        -y / (r * rz**2) + x * x * y / (r**3 * rz**2) + 2 * x * x * y / (r**2 * rz**3))
    s33 = -3 * x * z * z / r**5
    s13 = -3 * x * x * z / r**5
    s23 = -3 * x * y * z / r**5
    return c * np.stack([s11, s22, s33, s12, s13, s23], axis=-1)


def random_points(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 3))
    p[:, 2] = np.abs(p[:, 2]) + 0.05
    return p


# --------------------------------------------------------------------------------------------
# Cerruti's point force


@pytest.mark.parametrize("nu", [0.0, 0.3, 0.45, 0.5])
def test_point_force_is_johnsons_cerruti_solution(nu):
    p = random_points(500, 1)
    got = cerruti_stress(*p.T, nu)
    ref = johnson_cerruti(*p.T, nu)
    assert np.all(np.abs(got - ref).max(-1) < 1e-12 * np.abs(ref).max(-1))


def _derivative(f, p: np.ndarray, j: int, step: float) -> np.ndarray:
    """Fourth-order central difference of f along axis j at the points p (n, 3)."""
    e = np.zeros(3)
    e[j] = step
    return (8 * (f(p + e) - f(p - e)) - (f(p + 2 * e) - f(p - 2 * e))) / (12 * step)


@pytest.mark.parametrize("nu", [0.0, 0.3, 0.45])
def test_point_force_equilibrium_and_compatibility(nu):
    """div σ = 0 and (1 + ν)∇²σ_ij + ∂i∂j σ_kk = 0 (Beltrami–Michell), by differences."""
    p = random_points(40, 2)
    p = p / np.linalg.norm(p, axis=1)[:, None]  # unit distance: one step size suits all
    p[:, 2] = np.maximum(p[:, 2], 0.3)

    def f(q):
        return cerruti_stress(*q.T, nu)

    scale = np.abs(f(p)).max(-1)  # |σ| ~ 1/ρ², its derivatives ~ |σ|/ρ, |σ|/ρ²
    step = 2e-3
    grad = np.stack([_derivative(f, p, j, step) for j in range(3)], axis=-1)  # (n, 6, 3)
    for i in range(3):
        div = sum(grad[:, VOIGT[i, j], j] for j in range(3))
        assert np.all(np.abs(div) < 1e-8 * scale)

    def g(q):  # first derivatives, differentiated once more
        return np.stack([_derivative(f, q, j, step) for j in range(3)], axis=-1)

    hess = np.stack([_derivative(g, p, j, step) for j in range(3)], axis=-1)  # (n, 6, 3, 3)
    trace = hess[:, 0] + hess[:, 1] + hess[:, 2]
    for c, (i, j) in enumerate(PAIRS):
        lap = hess[:, c, 0, 0] + hess[:, c, 1, 1] + hess[:, c, 2, 2]
        bm = (1 + nu) * lap + trace[:, i, j]
        assert np.all(np.abs(bm) < 1e-6 * scale), (i, j)


def test_point_force_free_surface():
    """σ13, σ23, σ33 vanish as x3 -> 0 away from the load point (like x3 or x3²)."""
    rng = np.random.default_rng(3)
    x, y = rng.uniform(-3, 3, (2, 200))
    for z in (1e-4, 1e-7):
        s = cerruti_stress(x, y, z, 0.3)
        r = np.hypot(x, y)
        assert np.all(np.abs(s[:, [2, 4, 5]]).max(-1) < 2 * z / r**3)
    # the in-plane components stay finite and continuous up to the surface
    at, below = cerruti_stress(x, y, 0.0, 0.3), cerruti_stress(x, y, 1e-9, 0.3)
    assert np.all(np.abs(at - below).max(-1) < 1e-6 * np.abs(at).max(-1))


@pytest.mark.parametrize("z", [0.2, 1.0, 7.0])
def test_point_force_balance_of_the_slab_above_a_plane(z):
    """The slab 0 <= x3 <= z carries the unit force +x1 at the origin and σ_i3 on its base.

    Forces: ∫∫ σ13 = −1, ∫∫ σ23 = ∫∫ σ33 = 0. Moments about the origin: ∫∫ x1 σ33 = z ∫∫ σ13
    = −z (about x2), ∫∫ x2 σ33 = z ∫∫ σ23 = 0 (about x1), ∫∫ (x1 σ23 − x2 σ13) = 0 (about x3).
    Polar coordinates with r = z tan t (t in [0, π/2)), Gauss in t, trapezoid in φ (periodic).
    """
    t, wt = np.polynomial.legendre.leggauss(200)
    t, wt = np.pi / 4 * (t + 1), np.pi / 4 * wt
    n_phi = 64
    phi = 2 * np.pi * np.arange(n_phi) / n_phi
    T, PHI = np.meshgrid(t, phi, indexing="ij")
    r = z * np.tan(T)
    w = (wt * z * np.tan(t) * z / np.cos(t) ** 2)[:, None] * (2 * np.pi / n_phi)
    x1, x2 = r * np.cos(PHI), r * np.sin(PHI)
    s = cerruti_stress(x1, x2, z, 0.3)

    def integral(f):
        return float(np.sum(w * f))

    assert integral(s[..., 4]) == pytest.approx(-1.0, abs=1e-10)
    assert integral(s[..., 5]) == pytest.approx(0.0, abs=1e-10)
    assert integral(s[..., 2]) == pytest.approx(0.0, abs=1e-10)
    assert integral(x1 * s[..., 2]) == pytest.approx(-z, abs=1e-10 * z)
    assert integral(x2 * s[..., 2]) == pytest.approx(0.0, abs=1e-10 * z)
    assert integral(x1 * s[..., 5] - x2 * s[..., 4]) == pytest.approx(0.0, abs=1e-10 * z)


# --------------------------------------------------------------------------------------------
# the rectangle against quadrature of the point force

#: Gauss–Legendre points per panel of :func:`gauss_rule`.
GAUSS_POINTS = 20


def gauss_rule(
    lo: float, hi: float, at: float, z: float, order: int = GAUSS_POINTS
) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights on [lo, hi]: panels split at ``at``, length z/4 · 2^k away from it.

    The point-force kernel varies on the scale of the depth z around the field point's
    projection ``at`` and smoothly (relative to the distance) elsewhere, so every panel is at
    most as long as its distance from ``at`` plus z/4.
    """
    steps = z / 4 * 2.0 ** np.arange(64)
    offsets = np.concatenate([[0.0], np.cumsum(steps)])
    offsets = offsets[: np.searchsorted(offsets, 2 * (hi - lo) + abs(at) + 1) + 1]
    ends = np.unique(np.clip(np.concatenate([at - offsets, at + offsets, [lo, hi]]), lo, hi))
    t, w = np.polynomial.legendre.leggauss(order)
    mid, half = 0.5 * (ends[1:] + ends[:-1]), 0.5 * np.diff(ends)
    return (mid[:, None] + half[:, None] * t).ravel(), (half[:, None] * w).ravel()


def quadrature(x, y, z, h1, h2, nu, point=johnson_cerruti, order=GAUSS_POINTS) -> np.ndarray:
    """∫∫ over |ξ1| <= h1, |ξ2| <= h2 of the point-force stresses at (x − ξ1, y − ξ2, z)."""
    (n1, w1) = gauss_rule(-h1, h1, x, z, order)
    (n2, w2) = gauss_rule(-h2, h2, y, z, order)
    s = point(x - n1[:, None], y - n2[None, :], z, nu)
    return np.einsum("i,j,ijc->c", w1, w2, s)


def field_points(h1: float, h2: float) -> list[tuple[float, float, float]]:
    """Inside, under edges and corners, outside; depths 0.05 h, 0.3 h, 5 h (h = min half)."""
    h = min(h1, h2)
    lateral = [
        (0.0, 0.0), (0.3, 0.2), (-0.7, 0.55),  # inside
        (1.0, 0.0), (-1.0, 0.4), (0.2, 1.0), (-0.5, -1.0),  # under the edges
        (1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0),  # under the corners
        (1.0, 2.0), (3.0, -1.0),  # under an edge's extension
        (1.02, 0.3), (0.4, -0.97),  # close to an edge
        (1.6, 0.3), (-2.5, -1.7), (0.2, 6.0), (-8.0, 4.0),  # outside
    ]
    return [(a * h1, b * h2, f * h) for a, b in lateral for f in (0.05, 0.3, 5.0)]


RECTANGLES = [(1.0, 1.0), (1.0, 0.6), (0.25, 2.0), (3.0, 0.15)]


@pytest.mark.parametrize("nu", [0.0, 0.3, 0.45])
@pytest.mark.parametrize("half", RECTANGLES)
def test_rectangle_matches_quadrature_of_the_point_force(half, nu):
    h1, h2 = half
    pts = np.array(field_points(h1, h2))
    got = rectangle_shear_stress(pts[:, 0], pts[:, 1], pts[:, 2], h1, h2, nu)
    ref = np.array([quadrature(*p, h1, h2, nu) for p in pts])
    err = np.abs(got - ref) / np.abs(ref).max(-1)[:, None]
    worst = np.unravel_index(err.argmax(), err.shape)
    assert err.max() < REL_TOL, (pts[worst[0]], worst[1], got[worst[0]], ref[worst[0]])


VERY_SHALLOW = [
    (1.0, 0.0), (1.0, 0.6), (0.3, 0.6), (0.999, 0.2), (0.2, 0.1),  # edges, corner, inside
    (1.0, -1.5), (1.0, -3.0), (3.0, 0.6), (-2.0, -0.6),  # on the edge lines, outside
]


@pytest.mark.parametrize("nu", [0.0, 0.45])
def test_rectangle_matches_quadrature_just_below_the_surface(nu):
    """z = 1e-5: the logarithms of the corner functions must not cancel (ln(Y + ρ), Y < 0)."""
    h1, h2, z = 1.0, 0.6, 1e-5
    for x, y in VERY_SHALLOW:
        got = rectangle_shear_stress(x, y, z, h1, h2, nu)
        ref = quadrature(x, y, z, h1, h2, nu)
        assert np.abs(got - ref).max() < REL_TOL * np.abs(ref).max(), (x, y)


def test_quadrature_rule_is_converged():
    """The reference itself: doubling the Gauss order changes it by < 1e-11 (relative)."""
    pts = [(1.0, 0.6, 0.03), (0.3, 0.1, 0.03), (1.6, -0.2, 0.03), (0.0, 0.0, 5.0),
           (0.999, 0.2, 1e-5)]
    base = [quadrature(*p, 1.0, 0.6, 0.3) for p in pts]
    fine = [quadrature(*p, 1.0, 0.6, 0.3, order=2 * GAUSS_POINTS) for p in pts]
    for a, b in zip(base, fine, strict=True):
        assert np.abs(a - b).max() < 1e-11 * np.abs(b).max()


def test_rectangle_is_continuous_across_the_edge_planes():
    """No branch cut: the field is smooth across x1 = ±h1 and x2 = ±h2 at any depth z > 0."""
    h1, h2, nu, d = 1.0, 0.6, 0.3, 1e-9
    rng = np.random.default_rng(4)
    z = 10.0 ** rng.uniform(-3, 1, 400)
    along1 = rng.uniform(-3 * h2, 3 * h2, 400)
    along2 = rng.uniform(-3 * h1, 3 * h1, 400)
    for edge in (h1, -h1):
        a = rectangle_shear_stress(edge - d, along1, z, h1, h2, nu)
        b = rectangle_shear_stress(edge + d, along1, z, h1, h2, nu)
        assert np.all(np.abs(a - b).max(-1) < 1e-6 * np.maximum(np.abs(a).max(-1), 1.0))
    for edge in (h2, -h2):
        a = rectangle_shear_stress(along2, edge - d, z, h1, h2, nu)
        b = rectangle_shear_stress(along2, edge + d, z, h1, h2, nu)
        assert np.all(np.abs(a - b).max(-1) < 1e-6 * np.maximum(np.abs(a).max(-1), 1.0))


def test_uniform_traction_gives_the_uniform_shear_state():
    """q on a square of half-width L: σ13 = −q and all else 0, up to O((|x| + z)/L).

    The load missing outside the square changes σ13 by about 3z/(2L) (the same integral outside
    a disc of radius L: 3z/(2π) ∫ x²/r⁵ dA = 3z/(2L)); the other components are O(|x|/L, z/L).
    """
    z = np.array([0.0, 1e-3, 0.1, 1.0, 10.0])
    for half in (1e5, 1e6):
        s = rectangle_shear_stress(0.3, -0.2, z, half, half, 0.3)
        bound = 2.0 * (z + 0.5) / half
        assert np.all(np.abs(s[:, 4] + 1.0) < bound)
        assert np.all(np.abs(s[:, [0, 1, 2, 3, 5]]).max(-1) < bound)
    assert np.abs(s[0, 4] + 1.0) < 1e-15  # at the surface exactly


def test_surface_limit_away_from_the_edge_lines():
    """x3 = 0 returns the limit from below: σ13 = −1 inside, 0 outside; σ33 = σ23 = 0."""
    h1, h2, nu = 1.0, 0.6, 0.3
    rng = np.random.default_rng(5)
    x, y = rng.uniform(-3, 3, 2000), rng.uniform(-2, 2, 2000)
    keep = (np.abs(np.abs(x) - h1) > 0.05) & (np.abs(np.abs(y) - h2) > 0.05)
    x, y = x[keep], y[keep]
    s0 = rectangle_shear_stress(x, y, 0.0, h1, h2, nu)
    below = rectangle_shear_stress(x, y, 1e-10, h1, h2, nu)
    inside = (np.abs(x) < h1) & (np.abs(y) < h2)
    assert np.all(np.isfinite(s0))
    assert np.abs(s0[:, 4] - np.where(inside, -1.0, 0.0)).max() < 1e-15
    assert np.abs(s0[:, [2, 5]]).max() < 1e-14
    assert np.abs(s0 - below).max() < 1e-7


def test_surface_limit_on_the_edge_lines_outside_the_rectangle():
    """Outside the loaded rectangle the surface stress is continuous across its edge lines.

    (Found by this test: the kernel once set asinh(Y/(X²+z²)^½) to 0 at X = z = 0 and dropped
    the finite remainder sign(Y) ln 2|Y| there.)
    """
    h1, h2, nu = 1.0, 0.6, 0.3
    points = [(h1, 2 * h2), (-h1, -5 * h2), (3 * h1, h2), (-2 * h1, -h2)]
    for x, y in points:
        at = rectangle_shear_stress(x, y, 0.0, h1, h2, nu)
        near = rectangle_shear_stress(x + 1e-9, y + 1e-9, 1e-9, h1, h2, nu)
        assert np.abs(at - near).max() < 1e-6


# --------------------------------------------------------------------------------------------
# symmetries and the x2 traction


def test_parities_of_an_x1_traction():
    """Mirror x1 -> −x1 reverses the traction: σ11, σ22, σ33, σ23 odd in x1, σ12, σ13 even.

    Mirror x2 -> −x2 keeps it: σ12, σ23 odd in x2, the others even.
    """
    h1, h2, nu = 1.0, 0.6, 0.3
    p = random_points(200, 6) * [1.5, 1.0, 0.5]
    x, y, z = p.T
    s = rectangle_shear_stress(x, y, z, h1, h2, nu)
    odd_in_1 = np.array([-1, -1, -1, 1, 1, -1])
    odd_in_2 = np.array([1, 1, 1, -1, 1, -1])
    tol = 1e-13 * np.abs(s).max()
    assert np.abs(rectangle_shear_stress(-x, y, z, h1, h2, nu) - odd_in_1 * s).max() < tol
    assert np.abs(rectangle_shear_stress(x, -y, z, h1, h2, nu) - odd_in_2 * s).max() < tol
    # the point force has the same parities
    c = cerruti_stress(x, y, z, nu)
    assert np.allclose(cerruti_stress(-x, y, z, nu), odd_in_1 * c, rtol=1e-13, atol=0)
    assert np.allclose(cerruti_stress(x, -y, z, nu), odd_in_2 * c, rtol=1e-13, atol=0)


def rotate_quarter_turn(s: np.ndarray) -> np.ndarray:
    """Components of σ' = R σ Rᵀ, R the rotation by +90° about x3 (e1 -> e2, e2 -> −e1)."""
    s11, s22, s33, s12, s13, s23 = np.moveaxis(s, -1, 0)
    return np.stack([s22, s11, s33, -s12, -s23, s13], axis=-1)


def test_x2_traction_is_the_x1_traction_turned_a_quarter():
    """A traction along +x2 on |x1| <= h1, |x2| <= h2 is the +x1 traction on the rectangle of
    half-widths (h2, h1) turned by +90°: σ(x) = R σ1(Rᵀx) Rᵀ with Rᵀx = (x2, −x1, x3).
    """
    h1, h2, nu = 1.0, 0.4, 0.3
    p = random_points(100, 7) * [1.5, 1.0, 0.5]
    x, y, z = p.T
    along2 = traction_stress(x, y, z, h1, h2, nu, (0.0, 1.0))
    ref = rotate_quarter_turn(rectangle_shear_stress(y, -x, z, h2, h1, nu))
    assert np.abs(along2 - ref).max() < 1e-13 * np.abs(ref).max()
    # the x1 part alone, and the superposition of both
    assert np.array_equal(traction_stress(x, y, z, h1, h2, nu, (1.0, 0.0)),
                          rectangle_shear_stress(x, y, z, h1, h2, nu))
    both = traction_stress(x, y, z, h1, h2, nu, (0.6, -0.8))
    expect = 0.6 * rectangle_shear_stress(x, y, z, h1, h2, nu) - 0.8 * along2
    assert np.abs(both - expect).max() < 1e-13 * np.abs(expect).max()


@pytest.mark.parametrize("point", [(0.3, 0.35, 0.1), (1.0, 0.4, 0.02), (-2.0, 1.1, 0.5)])
def test_x2_traction_matches_quadrature_of_the_turned_point_force(point):
    """Independently of the axis exchange: quadrature of Cerruti's force turned along +x2."""
    h1, h2, nu = 1.0, 0.4, 0.3

    def point_along_2(x, y, z, nu):
        return rotate_quarter_turn(johnson_cerruti(y, -x, z, nu))

    got = traction_stress(*point, h1, h2, nu, (0.0, 1.0))
    ref = quadrature(*point, h1, h2, nu, point=point_along_2)
    assert np.abs(got - ref).max() < REL_TOL * np.abs(ref).max()
    # on the surface under the load the traction is t2 = −σ23 = +1
    assert traction_stress(0.2, -0.1, 0.0, h1, h2, nu, (0.0, 1.0))[5] == pytest.approx(-1.0)
