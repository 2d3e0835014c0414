"""Elastic contact (Polonsky–Keer + DC-FFT) against Hertz, and the DC-FFT operator itself."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from numpy.testing import assert_allclose

from sacflow.errors import ConvergenceError
from sacflow.kernels.convolution import Convolution
from sacflow.kernels.surface import rectangle_displacement
from sacflow.mechanics.contact import solve_contact
from sacflow.mechanics.hertz import composite_modulus, hertz_contact, hertz_pressure

E, NU, R, W = 210e9, 0.3, 105e-6, 0.65


def hertz_problem(n: int, half_width: float = 1.5, e_star: float | None = None, radius=R, load=W):
    """Sphere-on-flat on an n×n window of ±half_width·a: (h, compliance, cell area, x, hertz)."""
    e_star = e_star or composite_modulus(E, NU)
    hz = hertz_contact(load, radius, e_star)
    dx = 2 * half_width * hz.a / n
    x = (np.arange(n) - n / 2 + 0.5) * dx
    X, Y = np.meshgrid(x, x, indexing="ij")

    def love(d1, d2):
        return (rectangle_displacement(d1 * dx, d2 * dx, dx / 2, dx / 2) / (np.pi * e_star))[
            None, None
        ]

    conv = Convolution(love, (n, n), (n, n))
    return (X**2 + Y**2) / (2 * radius), conv, dx * dx, (X, Y), hz


def test_dcfft_equals_direct_summation():
    rng = np.random.default_rng(0)

    def kernel(d1, d2):  # 3 output components from 2 input components
        one = np.stack([1.0 / (1 + (d1 + 0.3) ** 2 + 2 * d2**2), np.sin(d1) + 0.1 * d2])
        return np.stack([one, np.cos(0.7 * d2) * one, (d1 - 0.5 * d2) * one[::-1]])

    x = rng.random((2, 7, 5))
    for offset, out_shape in (((0, 0), (7, 5)), ((2, -1), (4, 9)), ((-3, 2), (6, 3))):
        i, j, p, q = np.meshgrid(*(np.arange(n) for n in (*out_shape, 7, 5)), indexing="ij")
        k = kernel(i + offset[0] - p, j + offset[1] - q)  # (3, 2, o1, o2, 7, 5)
        direct = np.einsum("cdijpq,dpq->cij", k, x)
        for block in (None, 1, 2):  # all output components at once, one by one, 2 + 1
            conv = Convolution(kernel, (7, 5), out_shape, offset, block=block)
            assert_allclose(conv(x), direct, rtol=0, atol=1e-13 * np.abs(direct).max(),
                            err_msg=f"DC-FFT differs from direct summation, offset {offset}, "
                            f"block {block}")


def test_hertz_at_64_cells_across():
    # 96 cells over ±1.5 a: 64 cells across the contact diameter.
    h, conv, area, (X, Y), hz = hertz_problem(96)
    res = solve_contact(h, conv, area, load=W, tol=1e-10)
    dx = np.sqrt(area)
    assert_allclose(res.pressure.max(), hz.p0, rtol=5e-3, err_msg="p0 vs Hertz")
    assert_allclose(res.approach, hz.approach, rtol=3e-3, err_msg="approach vs Hertz")
    assert_allclose(res.load, W, rtol=1e-10, err_msg="load balance")
    radius = np.sqrt(np.count_nonzero(res.pressure > 0) * area / np.pi)
    assert abs(radius - hz.a) < dx, f"contact radius {radius} vs Hertz {hz.a} (cell {dx})"
    # Pointwise profile error on cells not cut by the contact circle (cells straddling r = a hold
    # a partial contact that a cell-constant pressure cannot resolve; reported separately).
    r = np.hypot(X, Y)
    error = np.abs(res.pressure - hertz_pressure(r, hz.a, hz.p0)) / hz.p0
    uncut = np.abs(r - hz.a) > dx / np.sqrt(2)
    assert error[uncut].max() < 1e-2, f"profile error {error[uncut].max():.3e} of p0"
    assert res.error < 1e-9, f"complementarity residual {res.error:.2e}"


def test_hertz_convergence_rate():
    errors_p0, errors_l2 = [], []
    sizes = (48, 96, 192)
    for n in sizes:
        h, conv, area, (X, Y), hz = hertz_problem(n)
        res = solve_contact(h, conv, area, load=W, tol=1e-11)
        errors_p0.append(abs(res.pressure.max() / hz.p0 - 1))
        exact = hertz_pressure(np.hypot(X, Y), hz.a, hz.p0)
        errors_l2.append(np.sqrt(np.mean((res.pressure - exact) ** 2)) / hz.p0)
    slope_p0 = np.polyfit(np.log(sizes), np.log(errors_p0), 1)[0]
    slope_l2 = np.polyfit(np.log(sizes), np.log(errors_l2), 1)[0]
    assert slope_p0 < -1.7, f"p0 error should fall ~ h², slope {slope_p0:.2f} ({errors_p0})"
    assert slope_l2 < -0.8, f"L2 pressure error should fall ~ h, slope {slope_l2:.2f}"


def test_approach_controlled_matches_load_controlled():
    h, conv, area, _, hz = hertz_problem(64)
    by_load = solve_contact(h, conv, area, load=W)
    by_approach = solve_contact(h, conv, area, approach=by_load.approach)
    assert_allclose(by_approach.load, W, rtol=1e-7, err_msg="load from approach control")
    assert_allclose(by_approach.pressure, by_load.pressure, atol=1e-6 * hz.p0,
                    err_msg="pressure, approach vs load control")


def test_elastic_counterbody_uses_composite_modulus():
    e_star = composite_modulus(E, NU, 1140e9, 0.07)
    h, conv, area, _, hz = hertz_problem(96, e_star=e_star)
    res = solve_contact(h, conv, area, load=W)
    assert_allclose(hz.a, 6.44e-6, rtol=2e-3, err_msg="diamond punch Hertz radius")
    assert_allclose(res.pressure.max(), hz.p0, rtol=5e-3, err_msg="p0, elastic punch")


def test_unit_neutrality():
    """Rescale E, W and lengths randomly: dimensionless pressure and gap are unchanged."""
    rng = np.random.default_rng(3)
    h, conv, area, _, hz = hertz_problem(48)
    base = solve_contact(h, conv, area, load=W)
    for _ in range(2):
        fe, fl, fw = 10 ** rng.uniform(-2, 2, 3)
        e_star = composite_modulus(E, NU) * fe
        h2, conv2, area2, _, hz2 = hertz_problem(48, e_star=e_star, radius=R * fl, load=W * fw)
        res = solve_contact(h2, conv2, area2, load=W * fw)
        assert_allclose(res.pressure / hz2.p0, base.pressure / hz.p0, atol=1e-8,
                        err_msg="pressure/p0 under rescaling")
        assert_allclose(res.approach / hz2.approach, base.approach / hz.approach, rtol=1e-8,
                        err_msg="approach under rescaling")


def test_symmetry_and_no_nan():
    h, conv, area, _, _ = hertz_problem(40)
    p = solve_contact(h, conv, area, load=W).pressure
    assert np.isfinite(p).all()
    assert_allclose(p, p[::-1], atol=1e-9 * p.max(), err_msg="x1 mirror symmetry")
    assert_allclose(p, p.T, atol=1e-9 * p.max(), err_msg="x1<->x2 symmetry")


def test_non_convergence_raises_named_error():
    h, conv, area, _, _ = hertz_problem(32)
    with pytest.raises(ConvergenceError, match="contact.*step 7") as info:
        solve_contact(h, conv, area, load=W, tol=1e-14, max_iter=3, step=7)
    assert info.value.step == 7 and info.value.residual > 1e-14
    assert "raise solver.contact_max_iterations" in str(info.value)  # the residual still falls


@pytest.mark.parametrize("load_fraction", [1 / 40, 1 / 1000])
def test_warm_start_on_one_cell_converges_to_the_cold_start_s_contact(load_fraction):
    """Issue #31: a contact set whose gap is already uniform (one cell: its gap is the mean that
    eliminates the approach) gave a zero conjugate-gradient step, and the overlapping free cells
    never entered: 'did not converge after 2000 iterations' at any limit, a small first increment
    failing where larger ones ran. They enter now; the solution is the cold start's."""
    n = 16
    h, conv, area, _, _ = hertz_problem(n)
    one_cell = np.zeros_like(h)
    one_cell[n // 2, n // 2] = 1.0
    load = W * load_fraction
    cold = solve_contact(h, conv, area, load=load)
    warm = solve_contact(h, conv, area, load=load, initial_pressure=one_cell)
    assert warm.error < 1e-10 and warm.load == pytest.approx(load, rel=1e-12)
    assert np.array_equal(warm.pressure > 0, cold.pressure > 0)
    assert_allclose(warm.pressure, cold.pressure, rtol=0, atol=1e-8 * cold.pressure.max())
    assert_allclose(warm.approach, cold.approach, rtol=1e-8)


def test_stalled_contact_says_more_iterations_will_not_help():
    """A residual that stopped falling gets no advice to raise the iterations or refine the
    increments (a rigid 'compliance': the step on the contact set is zero, nothing overlaps)."""
    h, _, area, _, _ = hertz_problem(8)
    with pytest.raises(ConvergenceError, match="stopped falling with 64 cells in contact: more "
                       "iterations or smaller load increments will not help") as info:
        solve_contact(h, np.zeros_like, area, load=W, max_iter=50, step=1)
    assert "raise solver" not in str(info.value) and info.value.advice is not None
    assert pickle.loads(pickle.dumps(info.value)).args == info.value.args


@pytest.mark.parametrize("tol", [1e-4, 1e-7, 1e-10])
def test_contact_stops_on_the_gap_error(tol):
    """The documented criterion: complementarity residual below ``tol``, checked independently.

    From the returned pressure alone: the gap h + K p − δ is zero on the contact set and never
    negative off it, to ``tol`` times the height range of h; ``error`` is that residual.
    """
    h, conv, area, _, _ = hertz_problem(48)
    res = solve_contact(h, conv, area, load=W, tol=tol)
    gap = h + conv(res.pressure) - res.approach
    contact = res.pressure > 0
    scale = np.ptp(h)
    residual = max(np.abs(gap[contact]).max(), -gap[~contact].min(), 0.0) / scale
    assert residual < tol, f"gap error {residual:.3e} above the tolerance {tol:.0e}"
    assert_allclose(res.error, residual, rtol=1e-3, atol=1e-3 * tol,
                    err_msg="reported error is the gap error")


def test_contact_at_zero_load_rests_on_the_highest_point():
    """No load: zero pressure and the approach at which the counter-body touches (min h)."""
    h, conv, area, _, _ = hertz_problem(16)
    bump = h - 2e-9 * np.exp(-((np.arange(16) - 7.5) ** 2)[:, None] / 4.0)  # a hollow: deeper
    res = solve_contact(bump, conv, area, load=0.0)
    assert not res.pressure.any() and res.load == 0.0
    assert res.approach == bump.min() and res.gap.min() == 0.0


def test_converged_warm_start_costs_no_iteration():
    """The criterion is checked on the pressure as given: a solution needs no further update.

    (A criterion on the pressure change needs at least one update to measure a change: every
    warm-started solve inside the coupled elastic-plastic loop paid for it.)
    """
    h, conv, area, _, _ = hertz_problem(48)
    res = solve_contact(h, conv, area, load=W, tol=1e-10)
    again = solve_contact(h, conv, area, load=W, tol=1e-10, initial_pressure=res.pressure)
    assert again.iterations == 0
    assert_allclose(again.pressure, res.pressure, rtol=0, atol=1e-12 * res.pressure.max())
    assert_allclose(again.error, res.error, rtol=1e-3)  # u exact here, updated there
