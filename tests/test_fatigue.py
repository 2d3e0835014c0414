"""Tests of the multiaxial fatigue core (sacflow.mechanics.fatigue_criteria, issue #16).

Independent checks: the 5-vector identity |S| = √J2 on random tensors (the minimum ball has its
own tests, test_minimum_ball.py); Dang Van and Crossland against closed forms (uniaxial,
torsion, in-phase and 90° out-of-phase bending–torsion, mean stress), against a numpy
recomputation with eigvalsh, at the endurance limits themselves (index 1), under a constant
added deviator or hydrostatic stress; chunked processing against one pass.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from scipy.optimize import minimize_scalar

from sacflow.mechanics.deviatoric_space import deviator_from_vector, deviatoric_vector
from sacflow.mechanics.fatigue_criteria import EnduranceLimits, crossland, dang_van
from sacflow.mechanics.hertz import line_contact_stress
from sacflow.mechanics.minimum_ball import FALLBACK, min_enclosing_ball

MPA = 1.0e6
#: Plausible hard-steel ratios t₋₁/f₋₁ (both criteria are calibrated for any ratio).
LIMITS = [EnduranceLimits(bending=700 * MPA, torsion=430 * MPA),
          EnduranceLimits(bending=800 * MPA, torsion=560 * MPA),
          EnduranceLimits(bending=600 * MPA, torsion=480 * MPA)]
LIM = LIMITS[0]
N_STEPS = 400  # a multiple of 4: the samples include sin = ±1 and cos = ±1
PHASE = 2.0 * np.pi * np.arange(N_STEPS) / N_STEPS
RTOL = 1e-12

COMPONENTS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


def tensor(v: np.ndarray) -> np.ndarray:
    """(..., 6) components -> (..., 3, 3) symmetric tensors."""
    t = np.empty((*v.shape[:-1], 3, 3))
    for c, (i, j) in enumerate(COMPONENTS):
        t[..., i, j] = t[..., j, i] = v[..., c]
    return t


def deviator(t: np.ndarray) -> np.ndarray:
    return t - np.trace(t, axis1=-2, axis2=-1)[..., None, None] / 3.0 * np.eye(3)


def history(**components: np.ndarray) -> np.ndarray:
    """One material point's history (n_times, 6) from named components s11 … s23."""
    names = ("s11", "s22", "s33", "s12", "s13", "s23")
    out = np.zeros((N_STEPS, 6))
    for name, values in components.items():
        out[:, names.index(name)] = values
    return out


def both(h: np.ndarray, limits: EnduranceLimits = LIM):
    """Dang Van and Crossland of a single history (n_times, 6) as scalars."""
    dv = dang_van(h[None], limits, time_axis=1)
    cr = crossland(h[None], limits, time_axis=1)
    return dv, cr


# ------------------------------------------------------------------------ 5-vector map
def test_deviatoric_vector_norm_is_sqrt_j2_and_map_inverts():
    rng = np.random.default_rng(1)
    sig = rng.normal(size=(1000, 6)) * 300 * MPA + rng.normal(size=(1000, 1)) * MPA * [1, 1, 1,
                                                                                      0, 0, 0]
    s = deviator(tensor(sig))
    j2 = 0.5 * np.einsum("...ij,...ij->...", s, s)
    vec = deviatoric_vector(sig)
    assert vec.shape == (1000, 5)
    assert_allclose(np.linalg.norm(vec, axis=-1), np.sqrt(j2), rtol=RTOL)
    # Isometry of differences too (what the ball needs).
    ds = s[1:] - s[:-1]
    assert_allclose(np.linalg.norm(vec[1:] - vec[:-1], axis=-1),
                    np.sqrt(0.5 * np.einsum("...ij,...ij->...", ds, ds)), rtol=1e-11)
    assert_allclose(tensor(deviator_from_vector(vec)), s, atol=1e-12 * np.abs(s).max())
    assert_allclose(deviatoric_vector(sig + 123 * MPA * np.array([1, 1, 1, 0, 0, 0])), vec,
                    atol=1e-6)


# ---------------------------------------------------------------- closed-form paths
@pytest.mark.parametrize("limits", LIMITS)
def test_uniaxial_alternating(limits):
    sa = 500 * MPA
    dv, cr = both(history(s11=sa * np.sin(PHASE)), limits)
    assert cr.sqrt_j2a[0] == pytest.approx(sa / math.sqrt(3), rel=RTOL)
    assert cr.p_max[0] == pytest.approx(sa / 3, rel=RTOL)
    assert_allclose(dv.centre[0], 0.0, atol=1e-12 * sa)
    # τ = |σ|/2, p = σ/3: max at σ = +σa (a > 0): DV = σa (1/2 + a/3) / t₋₁ = σa / f₋₁.
    assert dv.tau[0] == pytest.approx(sa / 2, rel=RTOL)
    assert dv.pressure[0] == pytest.approx(sa / 3, rel=RTOL)
    assert dv.time_index[0] == N_STEPS // 4
    assert dv.index[0] == pytest.approx(sa / limits.bending, rel=RTOL)
    assert cr.index[0] == pytest.approx(sa / limits.bending, rel=RTOL)


@pytest.mark.parametrize("limits", LIMITS)
def test_pure_alternating_torsion(limits):
    ta = 300 * MPA
    dv, cr = both(history(s12=ta * np.sin(PHASE)), limits)
    assert cr.sqrt_j2a[0] == pytest.approx(ta, rel=RTOL)
    assert cr.p_max[0] == 0.0
    assert dv.tau[0] == pytest.approx(ta, rel=RTOL)
    assert dv.index[0] == pytest.approx(ta / limits.torsion, rel=RTOL)
    assert cr.index[0] == pytest.approx(ta / limits.torsion, rel=RTOL)


@pytest.mark.parametrize("limits", LIMITS)
def test_indices_equal_one_at_the_endurance_limits(limits):
    for h in (history(s11=limits.bending * np.sin(PHASE)),
              history(s11=limits.bending * np.cos(PHASE)),  # starts at the peak
              history(s22=-limits.bending * np.sin(PHASE)),  # other axis, other sign
              history(s12=limits.torsion * np.sin(PHASE)),
              history(s23=limits.torsion * np.cos(PHASE))):
        dv, cr = both(h, limits)
        assert dv.index[0] == pytest.approx(1.0, rel=RTOL)
        assert cr.index[0] == pytest.approx(1.0, rel=RTOL)


def test_constants():
    lim = EnduranceLimits(bending=700 * MPA, torsion=430 * MPA)
    assert lim.dang_van_a == pytest.approx(3 * (430 / 700 - 0.5), rel=RTOL)
    assert lim.dang_van_b == 430 * MPA
    assert lim.crossland_alpha == pytest.approx(3 * 430 / 700 - math.sqrt(3), rel=RTOL)
    assert lim.crossland_beta == 430 * MPA
    for bad in (0.0, -1.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="bending"):
            EnduranceLimits(bending=bad, torsion=1.0)
        with pytest.raises(ValueError, match="torsion"):
            EnduranceLimits(bending=1.0, torsion=bad)
    with pytest.raises(AttributeError):
        lim.bending = 1.0  # type: ignore[misc]


@pytest.mark.parametrize("limits", LIMITS)
def test_in_phase_bending_torsion(limits):
    sa, ta = 500 * MPA, 200 * MPA
    dv, cr = both(history(s11=sa * np.sin(PHASE), s12=ta * np.sin(PHASE)), limits)
    assert cr.sqrt_j2a[0] == pytest.approx(math.sqrt(sa**2 / 3 + ta**2), rel=RTOL)
    expected_dv = (math.sqrt(sa**2 / 4 + ta**2) + limits.dang_van_a * sa / 3) / limits.torsion
    assert dv.index[0] == pytest.approx(expected_dv, rel=RTOL)
    expected_cr = (math.sqrt(sa**2 / 3 + ta**2) + limits.crossland_alpha * sa / 3) / limits.torsion
    assert cr.index[0] == pytest.approx(expected_cr, rel=RTOL)


@pytest.mark.parametrize(("sa", "ta"), [(500 * MPA, 200 * MPA), (300 * MPA, 350 * MPA),
                                        (math.sqrt(3) * 250 * MPA, 250 * MPA)])
def test_out_of_phase_bending_torsion(sa, ta):
    h = history(s11=sa * np.sin(PHASE), s12=ta * np.cos(PHASE))
    dv, cr = both(h)
    # The path is an ellipse centred at 0 in 5-D with semi-axes σa/√3 and τa.
    assert cr.sqrt_j2a[0] == pytest.approx(max(sa / math.sqrt(3), ta), rel=RTOL)
    assert_allclose(dv.centre[0], 0.0, atol=1e-12 * max(sa, ta))
    assert cr.p_max[0] == pytest.approx(sa / 3, rel=RTOL)
    expected_cr = (max(sa / math.sqrt(3), ta) + LIM.crossland_alpha * sa / 3) / LIM.torsion
    assert cr.index[0] == pytest.approx(expected_cr, rel=RTOL)
    # Dang Van by brute force at the same samples: eigvalsh of the deviator (s* = 0).
    eig = np.linalg.eigvalsh(deviator(tensor(h)))
    tau = 0.5 * (eig[:, -1] - eig[:, 0])
    p = h[:, :3].sum(axis=1) / 3
    value = tau + LIM.dang_van_a * p
    assert dv.index[0] == pytest.approx(value.max() / LIM.torsion, rel=RTOL)
    # (the maximum is attained twice, symmetric about φ = π/2: either sample will do)
    assert value[dv.time_index[0]] == pytest.approx(value.max(), rel=RTOL)
    # … and the continuous maximum over the cycle (plane stress: τ = √(σ²/4 + τ12²)),
    # which the 400 samples approach to O(Δφ²).
    def neg(phi):
        return -(math.hypot(sa * math.sin(phi) / 2, ta * math.cos(phi))
                 + LIM.dang_van_a * sa * math.sin(phi) / 3)

    best = min((minimize_scalar(neg, bounds=(lo, lo + math.pi / 2), method="bounded",
                                options={"xatol": 1e-12}) for lo in np.arange(4) * math.pi / 2),
               key=lambda r: r.fun)
    assert dv.index[0] == pytest.approx(-best.fun / LIM.torsion, rel=(2 * math.pi / N_STEPS)**2)
    assert dv.index[0] <= -best.fun / LIM.torsion * (1 + 1e-12)


def test_mean_uniaxial_stress():
    sa, sm = 400 * MPA, 250 * MPA
    dv, cr = both(history(s11=sm + sa * np.sin(PHASE)))
    assert_allclose(dv.centre[0], [math.sqrt(3) / 2 * 2 * sm / 3, 0, 0, 0, 0], atol=1e-6)
    assert cr.sqrt_j2a[0] == pytest.approx(sa / math.sqrt(3), rel=RTOL)
    assert cr.p_max[0] == pytest.approx((sm + sa) / 3, rel=RTOL)
    # ŝ is the alternating part only: τ = |σa sin|/2, p = (σm + σa sin)/3.
    assert dv.index[0] == pytest.approx((sa / 2 + LIM.dang_van_a * (sm + sa) / 3) / LIM.torsion,
                                        rel=RTOL)


# ------------------------------------------------------------- general histories
def _random_histories(rng, n_points=60, n_times=37):
    base = rng.normal(size=(n_points, 1, 6)) * 200 * MPA
    amp = rng.normal(size=(n_points, 3, 6)) * 300 * MPA
    ph = np.linspace(0, 2 * np.pi, n_times, endpoint=False)
    waves = np.stack([np.sin(ph), np.cos(2 * ph + 0.3), np.sin(3 * ph) ** 3])
    return base + np.einsum("pkc,kt->ptc", amp, waves)


def test_dang_van_against_numpy_recomputation():
    rng = np.random.default_rng(11)
    h = _random_histories(rng)
    dv = dang_van(h, LIM, time_axis=1)
    ball = min_enclosing_ball(deviatoric_vector(h))
    centres, radii = ball.centre, ball.radius
    assert_allclose(dv.centre, centres, rtol=0, atol=1e-12 * radii.max())
    assert_allclose(dv.radius, radii, rtol=RTOL)
    assert_array_equal(dv.ball_status, ball.status)
    assert_allclose(dv.ball_gap, ball.gap, rtol=0, atol=1e-15)
    s_hat = deviator(tensor(h)) - tensor(deviator_from_vector(centres))[:, None]
    eig = np.linalg.eigvalsh(s_hat)
    value = 0.5 * (eig[..., -1] - eig[..., 0]) + LIM.dang_van_a * h[..., :3].sum(-1) / 3
    assert_allclose(dv.index, value.max(axis=1) / LIM.torsion, rtol=1e-11)
    assert_array_equal(dv.time_index, np.argmax(value, axis=1))
    cr = crossland(h, LIM, time_axis=1)
    assert_array_equal(cr.sqrt_j2a, dv.radius)
    p_max = h[..., :3].sum(-1).max(axis=1) / 3
    assert_allclose(cr.index, (radii + LIM.crossland_alpha * p_max) / LIM.torsion, rtol=RTOL)


def test_constant_deviator_and_hydrostatic_stress():
    rng = np.random.default_rng(12)
    h = _random_histories(rng)
    dv, cr = dang_van(h, LIM, time_axis=1), crossland(h, LIM, time_axis=1)
    dev = rng.normal(size=6) * 500 * MPA
    dev[:3] -= dev[:3].mean()
    dv2, cr2 = dang_van(h + dev, LIM, time_axis=1), crossland(h + dev, LIM, time_axis=1)
    assert_allclose(dv2.index, dv.index, rtol=1e-10)
    assert_allclose(cr2.index, cr.index, rtol=1e-10)
    assert_allclose(dv2.centre, dv.centre + deviatoric_vector(dev), atol=1e-9 * dv.radius.max())
    hyd = 300 * MPA
    h3 = h + hyd * np.array([1, 1, 1, 0, 0, 0])
    dv3, cr3 = dang_van(h3, LIM, time_axis=1), crossland(h3, LIM, time_axis=1)
    assert_allclose(dv3.radius, dv.radius, rtol=1e-10)
    assert_allclose(dv3.tau, dv.tau, rtol=1e-10)
    assert_allclose(dv3.index, dv.index + LIM.dang_van_a * hyd / LIM.torsion, rtol=1e-10)
    assert_allclose(cr3.p_max, cr.p_max + hyd, rtol=1e-12)
    assert_allclose(cr3.index, cr.index + LIM.crossland_alpha * hyd / LIM.torsion, rtol=1e-10)


def test_chunked_equals_unchunked_and_time_axis():
    rng = np.random.default_rng(13)
    h = _random_histories(rng, n_points=97, n_times=50)
    dv, cr = dang_van(h, LIM, time_axis=1), crossland(h, LIM, time_axis=1)
    bounds = [0, 1, 13, 40, 41, 97]
    parts = [(dang_van(h[a:b], LIM, time_axis=1), crossland(h[a:b], LIM, time_axis=1))
             for a, b in zip(bounds[:-1], bounds[1:], strict=True)]
    for name in ("index", "time_index", "tau", "pressure", "centre", "radius", "ball_gap",
                 "ball_status"):
        assert_array_equal(np.concatenate([getattr(p[0], name) for p in parts]),
                           getattr(dv, name))
    for name in ("index", "sqrt_j2a", "p_max", "time_index_p_max"):
        assert_array_equal(np.concatenate([getattr(p[1], name) for p in parts]),
                           getattr(cr, name))
    # Time first, points on a 2-D grid: same numbers, point axes kept in order.
    grid = np.moveaxis(h[:96].reshape(8, 12, 50, 6), 2, 0)
    dv_grid = dang_van(grid, LIM, time_axis=0)
    cr_grid = crossland(grid, LIM, time_axis=-4)
    assert dv_grid.index.shape == (8, 12) and dv_grid.centre.shape == (8, 12, 5)
    assert_array_equal(dv_grid.index.ravel(), dv.index[:96])
    assert_array_equal(cr_grid.index.ravel(), cr.index[:96])


def test_input_errors():
    h = np.zeros((3, 10, 6))
    with pytest.raises(ValueError, match="6 stress components"):
        dang_van(np.zeros((3, 10, 5)), LIM, time_axis=1)
    with pytest.raises(ValueError, match="time_axis"):
        crossland(h, LIM, time_axis=2)
    with pytest.raises(ValueError, match="finite"):
        dang_van(np.full((3, 10, 6), np.nan), LIM, time_axis=1)
    # A constant history: zero amplitude, index from the pressure alone.
    const = np.tile([100 * MPA, 50 * MPA, 0, 10 * MPA, 0, 0], (1, 5, 1))
    dv, cr = dang_van(const, LIM, time_axis=1), crossland(const, LIM, time_axis=1)
    assert dv.radius[0] == 0.0 and cr.sqrt_j2a[0] == 0.0
    assert dv.tau[0] == 0.0
    assert dv.index[0] == pytest.approx(LIM.dang_van_a * 50 * MPA / LIM.torsion, rel=RTOL)


def test_symmetry_plane_path_gets_the_certified_ball():
    """Issue #30: the rolling line contact at 0.5 a (a path in a 3-D subspace of R⁵).

    The former pivoting routine returned √J2,a = 0.278 p0 there; the minimum is 0.25 p0 (the
    orthogonal shear amplitude, test_minimum_ball.py), which both criteria now use.
    """
    p0 = 1000 * MPA
    h = line_contact_stress(np.linspace(-5.0, 5.0, 2001), 0.5, 1.0, p0, 0.3)
    dv, cr = both(h)
    assert dv.ball_status[0] == FALLBACK
    assert dv.radius[0] == pytest.approx(0.25 * p0, rel=1e-5)
    assert dv.radius[0] <= 0.25 * p0
    assert cr.sqrt_j2a[0] == dv.radius[0]
