"""The compiled radial return against a plain numpy one written here (``radial_kernels``).

The radial return solves one scalar equation per plastic point, r(Δp) = q − 3μΔp − σ_Y(p + Δp),
and scales the trial deviator. ``radial_increments`` takes a closed form for linear hardening
and perfect plasticity; the one-step return scatters its increments with a compiled row loop;
the step-doubled return of linear and Swift laws runs point by point in one compiled loop (its
own Newton iteration for the Swift law). Each is checked here against the array iteration
(``solve_consistency``) and against the step-doubled algorithm spelled out in numpy (three
radial returns along the straight trial path, ``2 H − F``, one drift-correcting return), on
random and structured states of several laws (tabular: the array path, as a control): elastic
points, points that yield only in the second half, large increments.
"""

from __future__ import annotations

import numpy as np
import pytest

from sacflow.config.hardening_laws import hardening_from_schema
from sacflow.mechanics.return_extrapolation import extrapolated_return
from sacflow.mechanics.return_mapping import (
    IsotropicConsistency,
    radial_increments,
    return_map,
    solve_consistency,
)

E, NU = 210e9, 0.3
MU = E / (2.0 * (1.0 + NU))
SIGMA_Y = 1.6e9
LAWS = {
    "swift": {"law": "swift", "B": 1240e6, "C": 30.0, "n": 0.085, "strain_unit": "microstrain"},
    "swift_plain": {"law": "swift", "B": 1.8e9, "C": 0.002, "n": 0.2, "strain_unit": "strain"},
    "linear": {"law": "linear", "yield_stress": SIGMA_Y, "modulus": 0.1 * E},
    "perfect": {"law": "perfectly_plastic", "yield_stress": SIGMA_Y},
    "tabular": {"law": "tabular", "plastic_strain": [0.0, 1e-3, 4e-3, 1e-2],
                "stress": [1.6e9, 1.75e9, 1.8e9, 1.82e9]},
}
#: Agreement of two solutions of the same consistency equation, both converged to 1e-12 of σ_Y
#: (relative to the largest value of the array compared).
RELATIVE = 1e-10
WEIGHTS = np.array([1.0, 1.0, 1.0, 2.0, 2.0, 2.0])


def law_of(name):
    return hardening_from_schema(LAWS[name])


def states(seed: int, points: int = 400, scale: float = 1.6):
    """Start stresses (admissible for p), end trials and p; a quarter of the trials pure
    pressure or scaled down to stay elastic."""
    rng = np.random.default_rng(seed)
    start = rng.standard_normal((points, 6)) * 0.4 * SIGMA_Y
    trial = start + rng.standard_normal((points, 6)) * scale * SIGMA_Y
    trial[: points // 8] *= 0.05
    trial[points // 8: points // 4, 3:] = 0.0
    trial[points // 8: points // 4, :3] = -3.0 * SIGMA_Y
    p = rng.uniform(0.0, 0.02, points)
    p[:10] = 0.0
    return start, trial, p


def plain_radial(trial, p, law):
    """Radial return in numpy: (stress, Δεp, Δp), the array Newton iteration for Δp."""
    mean = trial[:, :3].sum(axis=1) / 3.0
    s = trial.copy()
    s[:, :3] -= mean[:, None]
    q = np.sqrt(1.5 * np.sum(WEIGHTS * s * s, axis=1))
    dp = np.zeros(len(q))
    plastic = q > law.yield_stress(p)
    if plastic.any():
        dp[plastic], _ = solve_consistency(
            IsotropicConsistency(q[plastic], p[plastic], None, law, 3.0 * MU), 1e-12, 60)
    ratio = np.ones(len(q))
    ratio[plastic] = law.yield_stress(p[plastic] + dp[plastic]) / q[plastic]
    stress = s * ratio[:, None]
    stress[:, :3] += mean[:, None]
    strain = np.zeros_like(s)
    strain[plastic] = s[plastic] * (1.5 * dp[plastic] / q[plastic])[:, None]
    return stress, strain, dp


def plain_step_doubled(start, trial, p, law):
    """The step-doubled return spelled out: 2 (H₁ + H₂) − F, then one return from there."""
    _, full_strain, full_dp = plain_radial(trial, p, law)
    half = 0.5 * (trial - start)
    first_stress, first_strain, first_dp = plain_radial(start + half, p, law)
    _, second_strain, second_dp = plain_radial(first_stress + half, p + first_dp, law)
    strain = 2.0 * (first_strain + second_strain) - full_strain
    dp = np.maximum(2.0 * (first_dp + second_dp) - full_dp, 0.0)
    _, correction_strain, correction_dp = plain_radial(trial - 2.0 * MU * strain, p + dp, law)
    plastic = full_dp > 0.0  # points elastic over the whole step are elastic throughout
    strain = np.where(plastic[:, None], strain + correction_strain, 0.0)
    dp = np.where(plastic, dp + correction_dp, 0.0)
    return strain, dp


def assert_close(actual, expected, what):
    scale = float(np.abs(expected).max())
    assert scale > 0.0, f"{what}: nothing to compare"
    error = float(np.abs(actual - expected).max())
    assert error <= RELATIVE * scale, f"{what}: {error:.3e} > {RELATIVE:g} × {scale:.3e}"


@pytest.mark.parametrize("name", ["linear", "perfect"])
def test_closed_form_increments_solve_the_consistency_equation(name):
    law = law_of(name)
    rng = np.random.default_rng(7)
    p = rng.uniform(0.0, 0.05, 2000)
    q = law.yield_stress(p) * rng.uniform(1.0 + 1e-9, 12.0, p.size)
    dp, iterations = radial_increments(q, p, None, law, 3.0 * MU)
    expected, _ = solve_consistency(IsotropicConsistency(q, p, None, law, 3.0 * MU), 1e-12, 60)
    assert_close(dp, expected, name)
    residual = q - 3.0 * MU * dp - law.yield_stress(p + dp)
    assert np.all(np.abs(residual) <= 1e-11 * law.yield_stress(p + dp)), name
    assert np.all(dp > 0.0) and iterations >= 1


@pytest.mark.parametrize("name", sorted(LAWS))
def test_one_step_return_is_the_plain_radial_return(name):
    law = law_of(name)
    _, trial, p = states(3)
    got = return_map(trial, p, law, MU)
    stress, strain, dp = plain_radial(trial, p, law)
    assert_close(got.stress, stress, f"{name} stress")
    assert_close(got.plastic_strain_increment, strain, f"{name} strain")
    assert_close(got.equivalent_plastic_strain_increment, dp, f"{name} dp")
    elastic = dp == 0.0
    assert elastic.any() and (~elastic).any()
    np.testing.assert_array_equal(got.stress[elastic], trial[elastic])  # bit for bit


@pytest.mark.parametrize("name", sorted(LAWS))
@pytest.mark.parametrize("scale", [0.3, 1.6, 8.0])
def test_step_doubled_return_is_the_plain_algorithm(name, scale):
    law = law_of(name)
    start, trial, p = states(11, scale=scale)
    # start stresses admissible: scale the deviator back inside the yield surface
    q0 = np.sqrt(1.5 * np.sum(WEIGHTS * (start - np.r_[[1, 1, 1, 0, 0, 0]] * start[:, :3]
                                         .mean(axis=1, keepdims=True)) ** 2, axis=1))
    shrink = np.minimum(1.0, 0.9 * law.yield_stress(p) / q0)
    mean = start[:, :3].mean(axis=1, keepdims=True) * np.r_[[1, 1, 1, 0, 0, 0]]
    start = mean + (start - mean) * shrink[:, None]
    got = extrapolated_return(start.reshape(20, 20, 6), trial.reshape(20, 20, 6),
                              p.reshape(20, 20), law, MU)
    strain, dp = plain_step_doubled(start, trial, p, law)
    if not dp.any():
        pytest.skip("no plastic point at this scale")
    assert_close(got.plastic_strain_increment.reshape(-1, 6), strain, f"{name} strain")
    assert_close(got.equivalent_plastic_strain_increment.reshape(-1), dp, f"{name} dp")


def test_points_yielding_only_in_the_second_half_are_extrapolated():
    """A proportional path that crosses the yield surface at 3/4 of the increment: the first
    half is elastic, and the step-doubled return integrates the flow exactly (radial path)."""
    law = law_of("linear")
    direction = np.array([1.0, -0.5, -0.5, 0.0, 0.0, 0.0])  # uniaxial deviator, q = 1.5 |x|
    start = np.zeros((1, 6))
    trial = direction[None, :] * (SIGMA_Y / 1.5) * (4.0 / 3.0)
    p = np.zeros(1)
    got = extrapolated_return(start, trial, p, law, MU)
    exact_dp = (1.5 * trial[0, 0] - SIGMA_Y) / (3.0 * MU + law.modulus)
    assert got.equivalent_plastic_strain_increment[0] == pytest.approx(exact_dp, rel=1e-12)


@pytest.mark.parametrize("name", ["linear", "swift"])
@pytest.mark.parametrize("threads", [2, 3])
def test_returns_shared_out_between_threads_equal_the_single_thread_ones(monkeypatch, threads,
                                                                         name):
    """The compiled returns split their points between threads: each point's arithmetic is
    its own, so any split gives the single-thread result bit for bit (step-doubled and one-step,
    increments and returned stresses), iteration counts included."""
    from sacflow.kernels import fft
    from sacflow.machine import threads as thread_budget

    monkeypatch.setattr(thread_budget, "SPLIT_ITEMS", 1000)  # split these points, not only boxes
    law = law_of(name)
    start, trial, p = states(23, scale=1.6, points=40_000)
    results = {}
    for count in (1, threads):
        monkeypatch.setattr(fft, "default_threads", lambda count=count: count)  # both returns
        one = return_map(trial, p, law, MU)
        doubled = extrapolated_return(start, trial, p, law, MU)
        results[count] = (one, doubled)
    (one, doubled), (one_split, doubled_split) = results[1], results[threads]
    assert one.plastic.sum() > 20_000  # points for every thread
    for a, b in ((one, one_split), (doubled, doubled_split)):
        np.testing.assert_array_equal(a.plastic_strain_increment, b.plastic_strain_increment)
        np.testing.assert_array_equal(a.equivalent_plastic_strain_increment,
                                      b.equivalent_plastic_strain_increment)
        assert a.iterations == b.iterations
    np.testing.assert_array_equal(one.stress, one_split.stress)


def test_a_large_radial_return_is_shared_out_between_threads(monkeypatch):
    """The radial return's scatters weigh each plastic point by the box entries it reads and
    writes (:data:`POINT_ENTRIES`): a plastic zone of SPLIT_ITEMS / POINT_ENTRIES points (a
    strongly plastic step's half million at 128 × 128 × 64 cuboids is three times that) goes to
    every thread, where counted as one entry a point it stayed on the calling thread."""
    from sacflow.kernels import fft
    from sacflow.machine import threads as thread_budget
    from sacflow.mechanics.return_mapping import POINT_ENTRIES

    shares = []
    split = thread_budget.over_ranges

    def recorded(kernel, count, threads, *arguments, weight=1):
        shares.append((kernel.__name__, count * weight >= thread_budget.SPLIT_ITEMS))
        return split(kernel, count, threads, *arguments, weight=weight)

    monkeypatch.setattr(thread_budget, "over_ranges", recorded)
    monkeypatch.setattr(fft, "default_threads", lambda: 2)
    points = thread_budget.SPLIT_ITEMS // POINT_ENTRIES + 1
    _, trial, p = states(5, scale=1.6, points=2 * points)
    result = return_map(trial, p, law_of("linear"), MU)
    assert result.plastic.sum() >= points
    assert ("scaled_deviators_into", True) in shares
    assert ("returned_into", True) in shares
