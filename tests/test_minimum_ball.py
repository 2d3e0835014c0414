"""Tests of the exact, certified minimum enclosing ball (sacflow.mechanics.minimum_ball, #30).

Independent checks: the pure-Python Welzl implementation ``miniball`` (PyPI 1.2.0) on random
sets of every shape (degenerate ones, and smooth curves in or near a 3-D subspace, the paths of
points on a symmetry plane of the load); an optimality certificate of our own making (centre in
the convex hull of the boundary points, by scipy's NNLS) with Jung's bounds; scipy's SLSQP;
closed forms (a regular simplex, points on a sphere or a circle, collinear, repeated, single
points). The three deviatoric paths of issue #30 on which the former pivoting routine cycled to
its step cap and returned a ball up to 11 % too large (Hertz line contact at 0.5 a and 0.425 a,
a sphere's track centre at 0.35 a), with the line contact's minimum, 0.25 p0, checked from the
field itself. The certificate is tested too: it accepts every result, rejects an enlarged,
shifted or suboptimal ball and invalid weights.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from scipy.optimize import minimize, minimize_scalar, nnls

from sacflow.errors import SacflowError
from sacflow.mechanics.ball_exact import exact_ball
from sacflow.mechanics.deviatoric_space import deviatoric_vector
from sacflow.mechanics.hertz import hertz_subsurface_stress, line_contact_stress
from sacflow.mechanics.minimum_ball import (
    CERTIFICATE_TOLERANCE,
    FALLBACK,
    FAST_PATH,
    UNCERTIFIED,
    BallCertificateError,
    certificate_gap,
    min_enclosing_ball,
    raise_uncertified,
)

try:
    import miniball
except ImportError:  # pragma: no cover - depends on the test environment
    miniball = None

needs_miniball = pytest.mark.skipif(
    miniball is None, reason="the test-time oracle `miniball` (PyPI, 1.2.0) is not installed: "
    "pip install miniball==1.2.0")

MPA = 1.0e6
RTOL = 1e-12
NU = 0.3


def _ball(pts):
    """Centre and radius, after checking the certificate the result carries."""
    ball = min_enclosing_ball(pts)
    assert np.all(ball.gap <= CERTIFICATE_TOLERANCE)
    assert np.all((ball.status == FAST_PATH) | (ball.status == FALLBACK))
    flat = np.asarray(pts, dtype=float).reshape(-1, *np.shape(pts)[-2:])
    for j, p in enumerate(flat):
        gap = certificate_gap(p, ball.centre.reshape(len(flat), -1)[j],
                              ball.radius.reshape(-1)[j], ball.support.reshape(len(flat), -1)[j],
                              ball.weights.reshape(len(flat), -1)[j])
        assert gap <= CERTIFICATE_TOLERANCE
    return ball.centre, ball.radius


def _oracle(pts: np.ndarray, seed: int = 0) -> tuple[np.ndarray, float]:
    """``miniball``'s ball (on the distinct points: 1.2.0 raises on repeated ones)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        centre, r2 = miniball.get_bounding_ball(np.unique(pts, axis=0),
                                                rng=np.random.default_rng(seed))
    return centre, math.sqrt(r2)


#: Set sizes for the oracle draws (the pure-Python oracle takes 0.1–0.2 s per 100–200-point
#: set, so those sizes get fewer oracle draws; all sizes get the optimality certificate).
SMALL_SETS = (1, 2, 3, 4, 5, 6, 7, 10, 20, 40)
LARGE_SETS = (100, 200)


def _draw(rng: np.random.Generator, i: int, sizes: tuple[int, ...] = SMALL_SETS) -> np.ndarray:
    """Point sets of varied sizes and shapes, degenerate ones included."""
    d = 5
    kind = i % 12
    n = int(rng.choice(sizes))
    if kind == 0:
        pts = rng.normal(size=(n, d))
    elif kind == 1:  # strongly anisotropic
        pts = rng.normal(size=(n, d)) * [1e3, 1.0, 1e-2, 10.0, 0.3]
    elif kind == 2:  # all on a sphere (every point may support the ball)
        pts = rng.normal(size=(n, d))
        pts /= np.linalg.norm(pts, axis=1, keepdims=True)
    elif kind == 3:  # on a line
        pts = rng.normal(size=(n, 1)) * rng.normal(size=(1, d)) + rng.normal(size=d)
    elif kind == 4:  # repeated points
        base = rng.normal(size=(max(n // 4, 1), d))
        pts = base[rng.integers(0, len(base), size=n)]
    elif kind == 5:  # a single point repeated, or one point
        pts = np.repeat(rng.normal(size=(1, d)), n, axis=0)
    elif kind == 6:  # two points (repeated)
        pts = rng.normal(size=(2, d))[rng.integers(0, 2, size=max(n, 2))]
    elif kind == 7:  # in a 2-plane of R^5
        pts = rng.normal(size=(n, 2)) @ rng.normal(size=(2, d))
    elif kind == 8:  # uniform in a cube, stress-like magnitude and offset
        pts = rng.uniform(-1, 1, size=(n, d)) * 400 * MPA + 2000 * MPA
    elif kind == 9:  # a closed curve (a sampled 90° out-of-phase loading)
        ph = np.linspace(0, 2 * np.pi, n, endpoint=False)
        pts = np.outer(np.sin(ph), rng.normal(size=d)) + np.outer(np.cos(ph), rng.normal(size=d))
    elif kind == 10:  # a smooth open curve in a 3-D subspace (a path on a symmetry plane)
        ph = np.linspace(-1.0, 1.0, n)[:, None]
        pts = (np.exp(-4 * ph**2) * [1.0, 0.3, 0, 0.2, 0] + ph * np.exp(-3 * ph**2)
               * [0, 0.1, 0, 1.0, 0] + ph**2 * [0.2, -0.5, 0, 0, 0])
    else:  # the same curve lifted off its subspace by 1e-6 (a path near a symmetry plane)
        ph = np.linspace(-1.0, 1.0, n)[:, None]
        pts = (np.exp(-4 * ph**2) * [1.0, 0.3, 1e-6, 0.2, 0] + ph * np.exp(-3 * ph**2)
               * [0, 0.1, 0, 1.0, 1e-6] + ph**2 * [0.2, -0.5, 0, 0, 0])
    return pts


def _check_ball(pts: np.ndarray, centre: np.ndarray, radius: float) -> None:
    """Enclosure, optimality certificate and Jung's bounds of one ball."""
    dist = np.linalg.norm(pts - centre, axis=1)
    assert dist.max() <= radius * (1 + 1e-12) + 1e-300
    if np.ptp(pts, axis=0).max() == 0.0:
        assert radius == 0.0
        assert_array_equal(centre, pts[0])
        return
    assert _is_optimal(pts, centre, radius)
    # Jung's bounds with the diameter D: D/2 ≤ R ≤ D √(d / (2 (d + 1))).
    diam = np.max(np.linalg.norm(pts[:, None] - pts[None], axis=-1))
    d = pts.shape[1]
    assert diam / 2 * (1 - 1e-12) <= radius <= diam * math.sqrt(d / (2 * (d + 1))) * (1 + 1e-12)


def _is_optimal(pts: np.ndarray, centre: np.ndarray, radius: float) -> bool:
    """KKT certificate: the centre is a convex combination of the points on the sphere."""
    dist = np.linalg.norm(pts - centre, axis=1)
    on = pts[dist >= radius * (1 - 1e-9)]
    # min |Σ λ_i p_i − c|² + w² (Σ λ_i − 1)² over λ ≥ 0 must vanish.
    w = 10.0
    a = np.vstack([(on - centre).T / radius, w * np.ones(len(on))])
    b = np.concatenate([np.zeros(pts.shape[1]), [w]])
    _, res = nnls(a, b)
    return res < 1e-8


@needs_miniball
def test_ball_against_miniball_and_optimality_certificate():
    rng = np.random.default_rng(2024)
    n_small, n_large = 1100, 10
    err_c = err_r = 0.0
    for i in range(n_small + n_large):
        pts = _draw(rng, i, SMALL_SETS if i < n_small else LARGE_SETS)
        centre, radius = _ball(pts)
        _check_ball(pts, centre, radius)
        if radius == 0.0:
            continue
        scale = radius
        oracle_c, oracle_r = _oracle(pts, i)
        err_c = max(err_c, np.linalg.norm(centre - oracle_c) / scale)
        err_r = max(err_r, abs(radius - oracle_r) / scale)
    print(f"\nminimum ball vs miniball, {n_small + n_large} draws: max |Δc|/R = {err_c:.2e}, "
          f"max |ΔR|/R = {err_r:.2e}")
    assert err_c < 1e-8
    assert err_r < 1e-10


def test_ball_certificate_on_large_sets():
    """100–200 points (the size of a load-cycle history), every shape: certificate and Jung."""
    rng = np.random.default_rng(5)
    for i in range(300):
        pts = _draw(rng, i, LARGE_SETS)
        _check_ball(pts, *_ball(pts))


def test_ball_against_scipy_qp():
    """min r² s.t. |p_i − c|² ≤ r² by SLSQP (an approximate but independent oracle)."""
    rng = np.random.default_rng(99)
    for i in range(60):
        pts = _draw(rng, i)
        if np.ptp(pts, axis=0).max() == 0.0:
            continue
        centre, radius = _ball(pts)
        scale = np.abs(pts).max()
        q = pts / scale
        x0 = np.concatenate([q.mean(axis=0), [np.max(np.sum((q - q.mean(axis=0)) ** 2, 1))]])
        res = minimize(lambda x: x[-1], x0, method="SLSQP",
                       constraints={"type": "ineq",
                                    "fun": lambda x, q=q: x[-1] - np.sum((q - x[:-1]) ** 2, 1)},
                       options={"ftol": 1e-15, "maxiter": 500})
        # SLSQP may stop on "positive directional derivative" at a degenerate optimum: any
        # feasible point still bounds the minimum radius from above.
        r_qp = math.sqrt(np.max(np.sum((q - res.x[:-1]) ** 2, axis=1))) * scale
        assert radius <= r_qp * (1 + 1e-12)
        if res.success:
            assert radius == pytest.approx(r_qp, rel=1e-6)


def test_ball_certificate_and_jung_on_many_sets_without_oracle():
    """Same draws processed in one vectorised call per size (exercises the batched path)."""
    rng = np.random.default_rng(7)
    for n in (1, 2, 6, 50):
        pts = rng.normal(size=(40, n, 5)) * rng.uniform(0.1, 10, size=(40, 1, 5))
        centres, radii = _ball(pts)
        assert centres.shape == (40, 5) and radii.shape == (40,)
        for j in range(40):
            if n == 1:
                assert radii[j] == 0.0
                continue
            assert _is_optimal(pts[j], centres[j], radii[j])
            one_c, one_r = _ball(pts[j])
            assert_array_equal(one_c, centres[j])
            assert one_r == radii[j]


def test_ball_exact_small_cases():
    c, r = _ball([[0.0, 0.0], [2.0, 0.0]])
    assert_allclose(c, [1.0, 0.0], atol=1e-15)
    assert r == pytest.approx(1.0, rel=RTOL)
    # Obtuse triangle: the ball is the one on the long side, not the circumcircle.
    c, r = _ball([[0.0, 0.0], [4.0, 0.0], [2.0, 0.5]])
    assert_allclose(c, [2.0, 0.0], atol=1e-14)
    assert r == pytest.approx(2.0, rel=RTOL)
    # Regular simplex in R^5 (6 support points): R = D √(d / (2 (d + 1))), Jung's equality.
    simplex = np.eye(6)[:, :]  # 6 points in R^6 lying in a 5-plane
    c, r = _ball(simplex)
    assert_allclose(c, np.full(6, 1 / 6), atol=1e-14)
    assert r == pytest.approx(math.sqrt(2) * math.sqrt(5 / 12), rel=RTOL)




# ------------------------------------------------------- the reproducers of issue #30
def _line_path(depth: float, n: int) -> np.ndarray:
    """Deviatoric path of a point at ``depth`` (units of a) under a rolling Hertz line contact."""
    x = np.linspace(-5.0, 5.0, n)
    return deviatoric_vector(line_contact_stress(x, depth, 1.0, 1.0, NU))


def _sphere_path(depth: float, n: int, x2: float) -> np.ndarray:
    """The same under a Hertz point contact rolled over ±4 a, at ``x2`` across the track."""
    x = np.linspace(-4.0, 4.0, n)
    return deviatoric_vector(hertz_subsurface_stress(x, x2, depth, 1.0, 1.0, NU))


def test_line_contact_orthogonal_shear_amplitude_is_a_quarter_of_p0():
    """The exact minimum of the issue's first reproducer, from the closed-form field alone.

    At 0.5 a the orthogonal shear σ13 of a line contact peaks at ±0.25 p0 (x = ±√3/2 a,
    Johnson §4.2; found here by a scalar search): the two peaks are 0.5 p0 apart in the
    5-vector space, so the minimum ball of the continuous path has R ≥ 0.25 p0. Sampled 100
    times finer than the reproducer (peaks missed by < 1e-9), the path's certified ball has
    R = 0.25 p0 to 1e-9: the bound is attained, the ball is that of the two peaks.
    """
    def neg_shear(x: float) -> float:
        return -abs(float(line_contact_stress(x, 0.5, 1.0, 1.0, NU)[4]))

    best = minimize_scalar(neg_shear, bounds=(0.2, 2.0), method="bounded",
                           options={"xatol": 1e-10})
    assert -best.fun == pytest.approx(0.25, rel=1e-12)
    assert best.x == pytest.approx(math.sqrt(3) / 2, rel=1e-6)
    _, fine = _ball(_line_path(0.5, 200_001))
    assert 0.25 - 1e-9 < fine <= 0.25 * (1 + RTOL)
    # The reproducer's 2001 samples miss the peaks by at most 0.0025 a: R ≤ 0.25, within 1e-5.
    _, radius = _ball(_line_path(0.5, 2001))
    assert 0.25 - 1e-5 < radius <= fine * (1 + RTOL)


@needs_miniball
@pytest.mark.parametrize(("path", "former"), [
    (lambda: _line_path(0.5, 2001), 0.2782),
    (lambda: _line_path(0.425, 1001), 0.2741),
    (lambda: _sphere_path(0.35, 1601, 1e-6), 0.2147),
])
def test_reproducers_of_issue_30(path, former):
    """Paths on or near a symmetry plane: the former routine's ball was 0.4–11 % too large.

    ``former``: the radius the former pivoting routine returned (after its 10 000-step cap).
    """
    pts = path()
    ball = min_enclosing_ball(pts)
    assert ball.status == FALLBACK  # the fast path does not certify these
    oracle_c, oracle_r = _oracle(pts)
    assert ball.radius == pytest.approx(oracle_r, rel=RTOL)
    assert np.linalg.norm(ball.centre - oracle_c) <= 1e-8 * oracle_r
    assert ball.radius < former / 1.003


def test_symmetry_plane_paths_are_certified():
    """Every depth of both contacts on (and 1e-6 a off) the symmetry plane, in one batch."""
    depths = np.linspace(0.02, 1.5, 75)
    x = np.linspace(-5.0, 5.0, 801)
    for field in (lambda z: line_contact_stress(x[:, None], z, 1.0, 1.0, NU),
                  lambda z: hertz_subsurface_stress(x[:, None], 0.0, z, 1.0, 1.0, NU),
                  lambda z: hertz_subsurface_stress(x[:, None], 1e-6, z, 1.0, 1.0, NU)):
        pts = np.moveaxis(deviatoric_vector(field(depths[None, :])), 1, 0)  # (depth, x, 5)
        ball = min_enclosing_ball(pts)
        assert np.all(ball.gap <= CERTIFICATE_TOLERANCE)
        # Jung's lower bound D/2 from the σ13 component alone (the path is symmetric in x1).
        assert np.all(ball.radius >= np.abs(pts[..., 3]).max(axis=1) * (1 - RTOL))


# ------------------------------------------------------------------- closed forms
def test_degenerate_sets_in_five_dimensions():
    rng = np.random.default_rng(3)
    origin, u, v = rng.normal(size=(3, 5))
    u /= np.linalg.norm(u)
    v -= (v @ u) * u
    v /= np.linalg.norm(v)
    # Collinear (unevenly spaced, with repeats): the midpoint of the extremes.
    t = np.array([0.3, -1.2, 2.0, 2.0, 0.0, 1.1, -1.2])
    c, r = _ball(origin + t[:, None] * u)
    assert r == pytest.approx(1.6, rel=RTOL)
    assert_allclose(c, origin + 0.4 * u, atol=1e-14)
    # Coplanar: 7 points of a circle of radius 2 in the plane (u, v), and the centre itself.
    ph = 2 * np.pi * np.arange(7) / 7
    circle = origin + 2 * (np.cos(ph)[:, None] * u + np.sin(ph)[:, None] * v)
    c, r = _ball(np.vstack([circle, origin]))
    assert r == pytest.approx(2.0, rel=RTOL)
    assert_allclose(c, origin, atol=1e-14)
    # A densely sampled circle (2001 points, nearly cospherical neighbours).
    ph = np.linspace(0, 2 * np.pi, 2001)
    c, r = _ball(origin + 0.7 * (np.cos(ph)[:, None] * u + np.sin(ph)[:, None] * v))
    assert r == pytest.approx(0.7, rel=RTOL)
    assert_allclose(c, origin, atol=1e-14)
    # Repeated points, a single point, two points.
    c, r = _ball(np.repeat(circle[:3], 5, axis=0))
    c3, r3 = _ball(circle[:3])
    assert r == pytest.approx(r3, rel=RTOL)
    assert_allclose(c, c3, atol=1e-14)
    c, r = _ball(origin[None])
    assert r == 0.0
    assert_array_equal(c, origin)
    c, r = _ball(np.repeat(origin[None], 4, axis=0))
    assert r == 0.0
    assert_array_equal(c, origin)
    c, r = _ball(np.array([origin, origin + 3 * u]))
    assert r == pytest.approx(1.5, rel=RTOL)
    assert_allclose(c, origin + 1.5 * u, atol=1e-14)


def test_points_on_a_sphere():
    """±e_i and ±(e_i ± e_j)/√2 in R⁵: all on the unit sphere, centred at the origin."""
    eye = np.eye(5)
    pts = [eye, -eye]
    for i in range(5):
        for j in range(i + 1, 5):
            for si in (1, -1):
                for sj in (1, -1):
                    pts.append(((si * eye[i] + sj * eye[j]) / math.sqrt(2))[None])
    c, r = _ball(np.vstack(pts) * 3.0 + 10.0)
    assert r == pytest.approx(3.0, rel=RTOL)
    assert_allclose(c, 10.0, atol=1e-13)
    # Only the positive half-axes: a regular simplex's vertices with the origin inside the
    # sphere; the ball is that of the simplex (centre 1/5 on each axis).
    c, r = _ball(np.vstack([eye, np.zeros((1, 5))]))
    assert r == pytest.approx(math.sqrt(4 / 5), rel=RTOL)
    assert_allclose(c, 0.2, atol=1e-14)


# ------------------------------------------------------------------ the certificate
def test_certificate_rejects_enlarged_shifted_or_suboptimal_balls():
    rng = np.random.default_rng(17)
    pts = rng.normal(size=(60, 5))
    ball = min_enclosing_ball(pts)
    args = (ball.support, ball.weights)
    assert certificate_gap(pts, ball.centre, ball.radius, *args) <= CERTIFICATE_TOLERANCE
    # Enlarged by 1e-8 (relative): still encloses, no longer optimal.
    enlarged = certificate_gap(pts, ball.centre, ball.radius * (1 + 1e-8), *args)
    assert enlarged == pytest.approx(2e-8, rel=1e-3) and enlarged > CERTIFICATE_TOLERANCE
    # Shifted: a support point falls outside.
    shift = ball.centre + 1e-6 * ball.radius * rng.normal(size=5)
    assert certificate_gap(pts, shift, ball.radius, *args) == math.inf
    # Shifted and grown to enclose again: a valid ball, but not the minimum.
    r_shift = np.linalg.norm(pts - shift, axis=1).max()
    assert certificate_gap(pts, shift, r_shift, *args) > CERTIFICATE_TOLERANCE
    # The ball about the centroid: far from optimal whatever the weights.
    centroid = pts.mean(axis=0)
    r_centroid = np.linalg.norm(pts - centroid, axis=1).max()
    assert certificate_gap(pts, centroid, r_centroid, *args) > 1e-3
    # Invalid weights: negative, or not summing to 1.
    bad = ball.weights.copy()
    bad[0] = -bad[0]
    assert certificate_gap(pts, ball.centre, ball.radius, ball.support, bad) == math.inf
    assert certificate_gap(pts, ball.centre, ball.radius, ball.support,
                           0.5 * ball.weights) == math.inf
    # Weights on points that are not on the sphere do not certify the (true) ball.
    inner = np.argsort(np.linalg.norm(pts - ball.centre, axis=1))[:3]
    assert certificate_gap(pts, ball.centre, ball.radius, inner, np.full(3, 1 / 3)) > 0.1


@needs_miniball
def test_exact_fallback_alone_against_miniball():
    """The fallback from no starting support, on every shape of set (scaled coordinates)."""
    rng = np.random.default_rng(31)
    for i in range(240):
        pts = _draw(rng, i)
        q = pts - pts[0]
        scale = np.abs(q).max()
        if scale == 0.0:
            continue
        q = np.ascontiguousarray(q / scale)
        centre, support, weights = np.empty(5), np.full(6, -1), np.empty(6)
        m = exact_ball(q, centre, support, weights, 0)
        assert m > 0
        radius = np.linalg.norm(q - centre, axis=1).max()
        oracle_c, oracle_r = _oracle(q, i)
        assert radius == pytest.approx(oracle_r, rel=1e-11)
        assert np.linalg.norm(centre - oracle_c) <= 1e-8 * oracle_r
        assert np.all(weights[:m] >= -1e-12)
        assert_allclose(weights[:m] @ q[support[:m]], centre, atol=1e-12)


def test_uncertified_balls_raise_a_named_error():
    status = np.array([FAST_PATH, UNCERTIFIED, FALLBACK, UNCERTIFIED], dtype=np.int8)
    gap = np.array([0.0, 3e-9, 1e-16, math.inf])
    with pytest.raises(BallCertificateError, match="2 point set") as info:
        raise_uncertified(status, gap)
    assert isinstance(info.value, SacflowError)
    assert info.value.count == 2 and info.value.first == 1 and info.value.gap == math.inf
    raise_uncertified(status[[0, 2]], gap[[0, 2]])


def test_input_errors():
    with pytest.raises(ValueError, match="shape"):
        min_enclosing_ball(np.zeros((4, 0, 5)))
    with pytest.raises(ValueError, match="finite"):
        min_enclosing_ball(np.array([[np.inf, 0.0]]))
