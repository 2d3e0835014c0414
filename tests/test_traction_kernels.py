"""Shear-traction kernels (sacflow.kernels.shear) against independent computations (issue #18).

* Cerruti's point-force stresses against central differences of Johnson's displacement field
  (written out here separately), equilibrium and the free surface;
* the rectangle's closed form against Gauss quadrature (graded panels; checked against scipy's
  adaptive dblquad to 1e-14 when written) of the point-force stresses, every
  component, inside, under edges and corners, outside, shallow and deep, three Poisson ratios;
* a uniform traction over a very large rectangle: the uniform shear state σ13 = −q at every depth;
* symmetry, and the x2 traction as the x1 one with the axes exchanged.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import integrate

from sacflow.kernels.shear import cerruti_stress, rectangle_shear_stress, traction_stress

#: Required agreement of the closed form with the quadrature, relative to the largest component.
REL_TOL = 1e-6


def cerruti_displacement(p: np.ndarray, nu: float) -> np.ndarray:
    """Johnson (1985) §2.2: displacement per unit tangential force along +x1, G = 1."""
    x, y, z = p
    r = np.sqrt(x * x + y * y + z * z)
    k, c = 1.0 - 2.0 * nu, 1.0 / (4.0 * np.pi)
    return c * np.array([
        1 / r + x * x / r**3 + k * (1 / (r + z) - x * x / (r * (r + z) ** 2)),
        x * y / r**3 - k * x * y / (r * (r + z) ** 2),
        x * z / r**3 + k * x / (r * (r + z)),
    ])


def stress_by_differences(p: np.ndarray, nu: float, step: float = 1e-5) -> np.ndarray:
    """Hooke's law on central differences of :func:`cerruti_displacement` (G = 1)."""
    grad = np.empty((3, 3))
    for j in range(3):
        e = np.zeros(3)
        e[j] = step
        grad[:, j] = (cerruti_displacement(p + e, nu) - cerruti_displacement(p - e, nu)) / (
            2 * step)
    eps = 0.5 * (grad + grad.T)
    s = 2 * nu / (1 - 2 * nu) * np.trace(eps) * np.eye(3) + 2 * eps
    return np.array([s[0, 0], s[1, 1], s[2, 2], s[0, 1], s[0, 2], s[1, 2]])


POINTS = [(0.3, -0.7, 0.45), (-1.2, 0.4, 0.2), (0.05, 0.02, 1.3), (2.0, 3.0, 0.1)]


@pytest.mark.parametrize("nu", [0.0, 0.3, 0.45])
@pytest.mark.parametrize("point", POINTS)
def test_point_force_matches_differences_of_the_displacements(point, nu):
    p = np.array(point)
    got = cerruti_stress(*p, nu)
    ref = stress_by_differences(p, nu)
    assert np.abs(got - ref).max() < 1e-8 * np.abs(ref).max()


def test_point_force_is_in_equilibrium_with_a_free_surface():
    nu, h = 0.3, 1e-5
    p = np.array([0.4, -0.3, 0.6])
    div = np.zeros(3)
    index = {(0, 0): 0, (1, 1): 1, (2, 2): 2, (0, 1): 3, (0, 2): 4, (1, 2): 5}
    for j in range(3):
        e = np.zeros(3)
        e[j] = h
        ds = (cerruti_stress(*(p + e), nu) - cerruti_stress(*(p - e), nu)) / (2 * h)
        for i in range(3):
            div[i] += ds[index[tuple(sorted((i, j)))]]
    assert np.abs(div).max() < 1e-7 * np.abs(cerruti_stress(*p, nu)).max() / 0.6
    # away from the load point the surface carries no traction: σ13, σ23, σ33 -> 0 as x3 -> 0
    s = cerruti_stress(0.7, -0.4, 1e-9, nu)
    assert np.abs(s[[2, 4, 5]]).max() < 1e-8


def test_point_force_balance_over_a_plane():
    """∫∫ σ13 dx1 dx2 = −1 (the force +x1 on the body), ∫∫ σ33 = ∫∫ σ23 = 0, at any depth."""
    nu, z = 0.3, 1.0
    # polar coordinates, radius to infinity through r = z tan(t)
    def integral(c):
        def f(t, phi):
            r = z * np.tan(t)
            jac = r * z / np.cos(t) ** 2
            return cerruti_stress(r * np.cos(phi), r * np.sin(phi), z, nu)[c] * jac
        return integrate.dblquad(f, 0, 2 * np.pi, 0, np.pi / 2, epsabs=1e-10)[0]

    assert integral(4) == pytest.approx(-1.0, abs=1e-8)
    assert integral(2) == pytest.approx(0.0, abs=1e-8)
    assert integral(5) == pytest.approx(0.0, abs=1e-8)


def quadrature(x, y, z, h1, h2, nu):
    """∫∫ over the rectangle of Cerruti's point stress: Gauss–Legendre on graded panels.

    The integrand peaks within a few depths ``z`` of the field point's projection: the panels
    double in length away from it (from z/8), 24 Gauss points each; all six components at once.
    """
    t, w = np.polynomial.legendre.leggauss(GAUSS_POINTS)
    nodes, weights = [], []
    for lo, hi, at in ((-h1, h1, x), (-h2, h2, y)):
        breaks = _graded_breaks(lo, hi, at, z)
        mid, half = 0.5 * (breaks[1:] + breaks[:-1]), 0.5 * np.diff(breaks)
        nodes.append((mid[:, None] + half[:, None] * t).ravel())
        weights.append((half[:, None] * w).ravel())
    xi, eta = np.meshgrid(*nodes, indexing="ij")
    weight = np.outer(*weights)
    return np.einsum("ij,ijc->c", weight, cerruti_stress(x - xi, y - eta, z, nu))


#: Gauss points per panel of :func:`quadrature`.
GAUSS_POINTS = 24


def _graded_breaks(lo: float, hi: float, at: float, z: float) -> np.ndarray:
    """Panel ends on [lo, hi], doubling in length away from ``at`` (clipped to the interval)."""
    steps = z / 8 * 2.0 ** np.arange(60)
    offsets = np.concatenate([[0.0], np.cumsum(steps)])
    points = np.concatenate([at - offsets, at + offsets, [lo, hi]])
    return np.unique(np.clip(points, lo, hi))


FIELD = [
    (0.2, 0.1, 0.3),    # inside
    (1.0, 0.6, 0.2),    # under a corner
    (1.0, 0.0, 0.05),   # under an edge, shallow
    (0.0, 0.6, 0.1),    # under the other edge
    (2.5, -1.0, 0.5),   # outside
    (-0.9, 0.3, 0.05),  # inside, shallow
    (0.3, -0.2, 5.0),   # deep
    (-4.0, 3.0, 0.2),   # far outside
]


@pytest.mark.parametrize("nu", [0.0, 0.3, 0.45])
@pytest.mark.parametrize("point", FIELD)
def test_rectangle_matches_quadrature_of_the_point_force(point, nu):
    h1, h2 = 1.0, 0.6
    got = rectangle_shear_stress(*point, h1, h2, nu)
    ref = quadrature(*point, h1, h2, nu)
    assert np.abs(got - ref).max() < REL_TOL * np.abs(ref).max()


def test_uniform_traction_gives_uniform_shear_at_every_depth():
    """Traction q on the whole surface: σ13 = −q and every other component 0 (exact)."""
    half = 1e6
    z = np.array([0.0, 0.01, 0.5, 3.0, 20.0])
    s = rectangle_shear_stress(0.3, -0.2, z, half, half, 0.3)
    assert np.allclose(s[:, 4], -1.0, atol=1e-4)
    assert np.abs(s[:, [0, 1, 2, 3, 5]]).max() < 1e-4


def test_surface_limit_inside_and_outside():
    s_in = rectangle_shear_stress(0.2, 0.1, 0.0, 1.0, 0.6, 0.3)
    s_out = rectangle_shear_stress(2.0, 0.1, 0.0, 1.0, 0.6, 0.3)
    assert s_in[4] == pytest.approx(-1.0, abs=1e-12)
    assert s_out[4] == pytest.approx(0.0, abs=1e-12)
    assert s_in[2] == pytest.approx(0.0, abs=1e-12) and s_in[5] == pytest.approx(0.0, abs=1e-12)
    # the surface value is the limit from below
    below = rectangle_shear_stress(0.2, 0.1, 1e-9, 1.0, 0.6, 0.3)
    assert np.allclose(below, s_in, atol=1e-7)


def test_parities_of_an_x1_traction():
    """Mirror images: x1 -> -x1 reverses the traction, x2 -> -x2 keeps it."""
    x1, x2, z = 0.37, 0.21, 0.3
    s = rectangle_shear_stress(x1, x2, z, 1.0, 0.6, 0.3)
    mirror1 = rectangle_shear_stress(-x1, x2, z, 1.0, 0.6, 0.3)
    mirror2 = rectangle_shear_stress(x1, -x2, z, 1.0, 0.6, 0.3)
    # reflection x1 -> -x1 reverses the traction: components with an even number of 1-indices
    # change sign (11, 22, 33, 23), those with one 1-index keep it (12, 13)
    assert np.allclose(mirror1, s * np.array([-1, -1, -1, 1, 1, -1]), atol=1e-14)
    # reflection x2 -> -x2 keeps the traction: components with one 2-index change sign
    assert np.allclose(mirror2, s * np.array([1, 1, 1, -1, 1, -1]), atol=1e-14)


def test_x2_traction_is_the_x1_one_with_axes_exchanged():
    x1, x2, z = np.array([0.3, -1.2]), np.array([0.9, 0.1]), np.array([0.2, 0.7])
    along2 = traction_stress(x1, x2, z, 1.0, 0.6, 0.3, (0.0, 1.0))
    # the mirror image in the diagonal x1 = x2 turns an x1 traction into an x2 traction
    ref = rectangle_shear_stress(x2, x1, z, 0.6, 1.0, 0.3)
    assert np.allclose(along2[:, [1, 0, 2, 3, 5, 4]], ref, atol=1e-15)
    # and the sum over both directions is linear
    both = traction_stress(x1, x2, z, 1.0, 0.6, 0.3, (0.6, 0.8))
    one = traction_stress(x1, x2, z, 1.0, 0.6, 0.3, (1.0, 0.0))
    assert np.allclose(both, 0.6 * one + 0.8 * along2, atol=1e-15)
