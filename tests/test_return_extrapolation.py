"""The step-doubled return (``sacflow.mechanics.return_extrapolation``) against the flow itself.

Reference: the Prandtl–Reuss equations integrated along the increment's straight strain path by
a fine fourth-order Runge–Kutta (written here, independent of the return mapping). For linear
isotropic hardening σ_Y = σ0 + H p the rate form is ``ds = 2μ (de − 3/2 dp s/q)``,
``dp = 3μ s:de / (q (3μ + H))`` while loading on the yield surface (consistency ``dq = H dp``).
A one-step backward-Euler return has a local error O(h²) over an increment of size h, the
step-doubled one O(h³): relative to the increment, halving it halves the one and quarters the
other.
"""

from __future__ import annotations

import numpy as np
import pytest

from sacflow.mechanics.hardening import KinematicLaw, LinearHardening
from sacflow.mechanics.return_extrapolation import extrapolated_return
from sacflow.mechanics.return_mapping import return_map

MU = 80e9
SIGMA0 = 1.0e9
MODULUS = 20e9
LAW = LinearHardening(SIGMA0, MODULUS)
#: Runge–Kutta steps of the reference over a whole increment.
REFERENCE_STEPS = 4000
#: Relative distance to the yield surface within which a loading point flows (the Runge–Kutta
#: stages sit off the surface by their truncation error, far less than this).
ON_SURFACE = 1e-6
#: Tensor-shear weights of a double contraction in (11, 22, 33, 12, 13, 23) storage.
WEIGHTS = np.array([1.0, 1.0, 1.0, 2.0, 2.0, 2.0])


def q_of(s: np.ndarray) -> float:
    """Von Mises equivalent of a deviator."""
    return float(np.sqrt(1.5 * np.sum(WEIGHTS * s * s)))


def deviatoric(a: np.ndarray) -> np.ndarray:
    """Deviatoric part of a (6,) tensor."""
    out = a.astype(float).copy()
    out[:3] -= out[:3].sum() / 3.0
    return out


def flow(s: np.ndarray, p: float, de: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
    """Rates (ds, dp, dεp) per unit path parameter for the deviatoric strain rate ``de``."""
    q = q_of(s)
    loading = np.sum(WEIGHTS * s * de)
    if q < LAW.yield_stress(p) * (1 - ON_SURFACE) or loading <= 0.0:
        return 2 * MU * de, 0.0, np.zeros(6)
    dp = 3 * MU * loading / (q * (3 * MU + MODULUS))
    deps = 1.5 * dp * s / q
    return 2 * MU * (de - deps), dp, deps


def reference(s0: np.ndarray, p0: float, de: np.ndarray) -> tuple[np.ndarray, float]:
    """Δεp and Δp along the straight path ``s0 → s0 + 2μ de`` by fine Runge–Kutta."""
    s, p, eps = s0.copy(), p0, np.zeros(6)
    h = 1.0 / REFERENCE_STEPS
    for _ in range(REFERENCE_STEPS):
        k1 = flow(s, p, de)
        k2 = flow(s + h / 2 * k1[0], p + h / 2 * k1[1], de)
        k3 = flow(s + h / 2 * k2[0], p + h / 2 * k2[1], de)
        k4 = flow(s + h * k3[0], p + h * k3[1], de)
        s = s + h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        p = p + h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
        eps = eps + h / 6 * (k1[2] + 2 * k2[2] + 2 * k3[2] + k4[2])
    assert abs(q_of(s) / LAW.yield_stress(p) - 1) < ON_SURFACE  # the drift stays negligible
    return eps, p - p0


def start_and_path(angle_deg: float, size: float) -> tuple[np.ndarray, float, np.ndarray]:
    """A point on the yield surface (p0 = 1 %), loaded along a direction ``angle`` away."""
    p0 = 0.01
    a = deviatoric(np.array([1.0, -1.0, 0.0, 0.0, 0.0, 0.0]))
    b = deviatoric(np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0]))
    a, b = a / q_of(a), b / q_of(b)
    theta = np.radians(angle_deg)
    s0 = a * LAW.yield_stress(p0)
    direction = np.cos(theta) * a + np.sin(theta) * b
    de = direction * size * SIGMA0 / (2 * MU)
    return s0, p0, de


def errors(size: float) -> tuple[float, float]:
    """Relative Δεp errors of the one-step and the step-doubled return for one increment."""
    s0, p0, de = start_and_path(60.0, size)
    exact, _ = reference(s0, p0, de)
    trial = s0 + 2 * MU * de
    one_step = return_map(trial[None], np.array([p0]), LAW, MU)
    extrapolated = extrapolated_return(s0[None], trial[None], np.array([p0]), LAW, MU)
    scale = np.abs(exact).max()
    return (float(np.abs(one_step.plastic_strain_increment[0] - exact).max() / scale),
            float(np.abs(extrapolated.plastic_strain_increment[0] - exact).max() / scale))


def test_step_doubling_is_second_order_where_backward_euler_is_first():
    """Relative errors of Δεp over one increment of von Mises size 0.1 and 0.05 σ0.

    One step: first order (local error O(h²) of an O(h) increment), step-doubled: second.
    """
    coarse, fine = errors(0.1), errors(0.05)
    one_step_order = np.log2(coarse[0] / fine[0])
    doubled_order = np.log2(coarse[1] / fine[1])
    assert 0.8 < one_step_order < 1.2, (coarse, fine)
    assert doubled_order > 1.7, (coarse, fine)
    assert coarse[1] < coarse[0] / 10, (coarse, fine)


def test_proportional_loading_is_exact_either_way():
    s0, p0, de = start_and_path(0.0, 2.0)
    trial = s0 + 2 * MU * de
    one_step = return_map(trial[None], np.array([p0]), LAW, MU)
    extrapolated = extrapolated_return(s0[None], trial[None], np.array([p0]), LAW, MU)
    exact, dp = reference(s0, p0, de)
    np.testing.assert_allclose(one_step.plastic_strain_increment[0], exact,
                               rtol=0, atol=1e-9 * np.abs(exact).max())
    np.testing.assert_allclose(extrapolated.plastic_strain_increment[0], exact,
                               rtol=0, atol=1e-9 * np.abs(exact).max())
    np.testing.assert_allclose(extrapolated.equivalent_plastic_strain_increment[0], dp,
                               rtol=1e-9)


def test_elastic_points_are_left_alone_and_plastic_strain_never_shrinks():
    rng = np.random.default_rng(3)
    start = rng.normal(scale=0.3 * SIGMA0, size=(500, 6))
    trial = start + rng.normal(scale=0.6 * SIGMA0, size=(500, 6))
    p0 = np.zeros(500)
    start_q = np.sqrt(1.5 * np.sum(WEIGHTS * np.array([deviatoric(r) for r in start]) ** 2,
                                   axis=1))
    keep = start_q < SIGMA0  # admissible starts only
    one_step = return_map(trial[keep], p0[keep], LAW, MU)
    extrapolated = extrapolated_return(start[keep], trial[keep], p0[keep], LAW, MU,
                                       full=return_map(trial[keep], p0[keep], LAW, MU))
    elastic = ~one_step.plastic
    assert elastic.any() and one_step.plastic.any()
    assert not extrapolated.plastic_strain_increment[elastic].any()
    assert (extrapolated.equivalent_plastic_strain_increment >= 0).all()


@pytest.mark.parametrize("recall", [0.0, 50.0])
def test_kinematic_hardening_proportional_path_matches_one_step(recall):
    """Under a proportional path the one-step return is exact: so is the step-doubled one."""
    kinematic = KinematicLaw(30e9, recall)
    s0, p0, de = start_and_path(0.0, 2.0)
    law = LinearHardening(SIGMA0, 0.0)
    s0 = s0 / LAW.yield_stress(p0) * SIGMA0  # on the surface of this law, no backstress yet
    trial = s0 + 2 * MU * de
    one_step = return_map(trial[None], np.array([p0]), law, MU, kinematic=kinematic,
                          backstress=np.zeros((1, 6)))
    extrapolated = extrapolated_return(
        s0[None], trial[None], np.array([p0]), law, MU, kinematic=kinematic,
        backstress=np.zeros((1, 6)))
    assert one_step.plastic.all()
    scale = np.abs(one_step.plastic_strain_increment).max()
    np.testing.assert_allclose(extrapolated.plastic_strain_increment,
                               one_step.plastic_strain_increment, rtol=0, atol=1e-9 * scale)
    assert extrapolated.backstress is not None and one_step.backstress is not None
    np.testing.assert_allclose(extrapolated.backstress, one_step.backstress, rtol=0,
                               atol=1e-9 * np.abs(one_step.backstress).max())


def test_layer_depths_are_gathered_as_a_broadcast_would():
    """A depth per layer (the solver's) gives the same return as the depths broadcast."""
    from sacflow.mechanics.hardening import DepthScaledHardening

    rng = np.random.default_rng(5)
    shape = (4, 3, 5)
    layers = np.linspace(1e-6, 5e-6, shape[-1])
    law = DepthScaledHardening(LAW, np.array([0.0, 1e-5]), np.array([1.0, 2.0]))
    start = rng.normal(scale=0.2 * SIGMA0, size=shape + (6,))
    trial = start + rng.normal(scale=1.5 * SIGMA0, size=shape + (6,))
    p0 = np.zeros(shape)
    by_layer = extrapolated_return(start, trial, p0, law, MU, layers)
    broadcast = extrapolated_return(start, trial, p0, law, MU,
                                    np.broadcast_to(layers, shape).copy())
    assert by_layer.plastic.any()
    np.testing.assert_array_equal(by_layer.plastic_strain_increment,
                                  broadcast.plastic_strain_increment)
