"""The fixed-point solver on small problems with known solutions (no contact, no plasticity)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.sparse.linalg import LinearOperator

from sacflow.solver.nonlinear import (
    Evaluation,
    FixedPointError,
    NewtonSettings,
    difference_jacobian,
    newton_step,
    solve_fixed_point,
)

TOL = 1e-12


def relative(gx: np.ndarray, x: np.ndarray) -> float:
    return float(np.abs(gx - x).max() / max(np.abs(gx).max(), np.abs(x).max(), 1e-300))


def below_tol(x, ev: Evaluation) -> bool:
    return ev.residual < TOL


def linear_problem(n: int = 40, radius: float = 0.95, seed: int = 0):
    """G(x) = A x + b with A symmetric, spectral radius ``radius``: x* = (I − A)⁻¹ b."""
    return symmetric_problem(np.linspace(-radius, radius, n), seed)


def symmetric_problem(eigenvalues: np.ndarray, seed: int):
    """G(x) = A x + b, A symmetric with the given eigenvalues (random eigenvectors and b);
    returns the evaluation, x* = (I − A)⁻¹ b and the list of calls."""
    n = len(eigenvalues)
    rng = np.random.default_rng(seed)
    q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    a = q @ np.diag(eigenvalues) @ q.T
    b = rng.standard_normal(n)
    calls = []

    def evaluate(x):
        calls.append(1)
        gx = a @ x + b
        return Evaluation(gx, relative(gx, x))

    return evaluate, np.linalg.solve(np.eye(n) - a, b), calls


def test_plain_sweeps_converge_on_a_contraction():
    evaluate, exact, calls = linear_problem()
    out = solve_fixed_point(evaluate, np.zeros_like(exact), below_tol, max_iterations=2000)
    assert_allclose(out.x, exact, rtol=0, atol=1e-10 * np.abs(exact).max())
    assert out.newton_steps == 0 and out.sweeps == len(calls) - 1
    # Picard contracts by the spectral radius per sweep: about log(1e-12)/log(0.95) sweeps
    assert out.sweeps > 400


def test_anderson_needs_far_fewer_evaluations():
    evaluate, exact, _ = linear_problem()
    plain = solve_fixed_point(evaluate, np.zeros_like(exact), below_tol, max_iterations=2000)
    out = solve_fixed_point(evaluate, np.zeros_like(exact), below_tol, max_iterations=2000,
                            anderson_depth=5)
    assert_allclose(out.x, exact, rtol=0, atol=1e-10 * np.abs(exact).max())
    assert out.sweeps < plain.sweeps / 2, f"Anderson {out.sweeps}, plain {plain.sweeps} sweeps"


def positive_part_problem(n: int = 30, seed: int = 1):
    """G(x) = max(0, B x + c) with ‖B‖ > 1: Picard diverges; x* solves x = max(0, Bx + c).

    B = −1.5 I + small symmetric coupling, c > 0 except a few entries: the solution has an
    active set (entries at 0) that sweeps cannot find; semismooth Newton with the generalised
    Jacobian ``I − D B`` (D the indicator of ``B x + c > 0``) finds it.
    """
    rng = np.random.default_rng(seed)
    coupling = 0.05 * rng.standard_normal((n, n))
    bmat = -1.5 * np.eye(n) + (coupling + coupling.T) / 2
    c = rng.uniform(0.5, 1.0, n)
    c[:5] = -1.0  # these stay at zero in the solution
    applications = []

    def evaluate(x):
        z = bmat @ x + c
        gx = np.maximum(z, 0.0)
        return Evaluation(gx, relative(gx, x), z > 0)

    def jacobian(x, ev):
        d = ev.data.astype(float)

        def matvec(v):
            applications.append(1)
            return v - d * (bmat @ v)

        return LinearOperator((n, n), matvec=matvec, dtype=float)

    return evaluate, jacobian, bmat, c, applications


def test_semismooth_newton_takes_over_when_sweeps_stall():
    evaluate, jacobian, bmat, c, applications = positive_part_problem()
    x0 = np.zeros(c.size)
    with pytest.raises(FixedPointError) as err:
        solve_fixed_point(evaluate, x0, below_tol, max_iterations=60)
    assert err.value.residual > 1e-3, "plain sweeps alone do not solve it"
    out = solve_fixed_point(evaluate, x0, below_tol, max_iterations=60, jacobian=jacobian)
    assert out.newton_steps > 0 and applications, "Newton was used"
    x = out.x
    assert_allclose(x, np.maximum(bmat @ x + c, 0.0), rtol=0, atol=1e-12)
    assert (x[:5] == 0.0).all() and (x[5:] > 0.0).all(), "the active set is found"


def test_anderson_stall_hands_over_to_newton():
    evaluate, jacobian, bmat, c, _ = positive_part_problem(seed=2)
    settings = NewtonSettings(stall_sweeps=3)
    out = solve_fixed_point(evaluate, np.zeros(c.size), below_tol, max_iterations=100,
                            anderson_depth=5, jacobian=jacobian, settings=settings)
    assert_allclose(out.x, np.maximum(bmat @ out.x + c, 0.0), rtol=0, atol=1e-12)


def test_line_search_halves_an_overshooting_newton_step():
    """G(x) = x/2 + 1 (x* = 2) with a Jacobian 4 times too small: the full step overshoots.

    From x = 1 (after the one sweep before Newton takes over) the Newton direction is 4; the
    trial x = 5 and then x = 3 do not lower the residual 0.5, the second halving lands on 2.
    """
    trials = []

    def evaluate(x):
        trials.append(float(x[0]))
        gx = 0.5 * x + 1.0
        return Evaluation(gx, float(abs(gx[0] - x[0])), None)

    def jacobian(x, ev):
        return LinearOperator((1, 1), matvec=lambda v: 0.125 * v, dtype=float)

    settings = NewtonSettings(progress_ratio=0.0)  # no sweep counts as progress: Newton
    out = solve_fixed_point(evaluate, np.array([0.0]), lambda x, ev: ev.residual < 1e-12,
                            max_iterations=10, jacobian=jacobian, settings=settings)
    assert trials == [0.0, 1.0, 5.0, 3.0, 2.0]
    assert out.x[0] == 2.0 and out.newton_steps == 1 and out.sweeps == 1


def test_a_newton_step_without_descent_is_refused_for_a_sweep():
    """G(x) = x/2 + 1 (x* = 2) with a Jacobian of the wrong sign: every Newton step goes uphill.

    No step length lowers ‖G(x) − x‖, so each Newton step is refused and the solver sweeps from
    the same iterate instead: the iterates are those of plain sweeps, 1, 1.5, 1.75, ... (a
    solver that took the shortest trial step anyway would walk away from x*).
    """
    accepted = []

    def evaluate(x):
        gx = 0.5 * x + 1.0
        return Evaluation(gx, float(abs(gx[0] - x[0])), None)

    def jacobian(x, ev):
        accepted.append(float(x[0]))
        return LinearOperator((1, 1), matvec=lambda v: -0.5 * v, dtype=float)

    settings = NewtonSettings(progress_ratio=0.0)  # no sweep counts as progress: Newton
    out = solve_fixed_point(evaluate, np.array([0.0]), lambda x, ev: ev.residual < 1e-12,
                            max_iterations=60, jacobian=jacobian, settings=settings)
    assert out.x[0] == pytest.approx(2.0, abs=1e-11)
    assert out.newton_steps > 0 and out.sweeps == out.newton_steps + 1
    assert_allclose(accepted[:4], [1.0, 1.5, 1.75, 1.875], rtol=0, atol=0)


def test_the_line_search_merit_is_the_euclidean_norm():
    """A Newton step that lowers ‖F‖₂ but raises max|F| is taken at full length.

    G(x) = (1 + 1.2 x0, 1): at x = 0, F = G(x) − x = (1, 1). A Jacobian that sees no coupling
    (I) gives the step (1, 1), where F = (1.2, 0): the Euclidean norm falls from 1.414 to 1.2, the
    maximum rises from 1 to 1.2 (a line search on the maximum would halve this step).
    """
    def evaluate(x):
        gx = np.array([1.0 + 1.2 * x[0], 1.0])
        return Evaluation(gx, float(np.abs(gx - x).max()), None)

    def jacobian(x, ev):
        return LinearOperator((2, 2), matvec=lambda v: 1.0 * v, dtype=float)

    x0 = np.zeros(2)
    x, ev = newton_step(evaluate, jacobian, x0, evaluate(x0), NewtonSettings(), "test")
    assert_allclose(x, [1.0, 1.0], rtol=0, atol=1e-12)
    assert ev.residual == pytest.approx(1.2)


def test_the_iteration_limit_raises_with_the_last_residual():
    evaluate, exact, _ = linear_problem(radius=0.99)
    with pytest.raises(FixedPointError, match="after 10 iterations") as err:
        solve_fixed_point(evaluate, np.zeros_like(exact), below_tol, max_iterations=10)
    assert err.value.iterations == 10 and 0 < err.value.residual < 1


def test_the_difference_jacobian_of_a_linear_map_is_exact():
    """G(x) = A x + b: the directional differences give I − A (to round-off over ε)."""
    evaluate, _, _ = linear_problem(n=12, radius=0.9, seed=3)
    rng = np.random.default_rng(4)
    x = rng.standard_normal(12)
    ev = evaluate(x)
    jac = difference_jacobian(evaluate, x, ev, 1e-6, float(np.abs(x).max()))
    a = np.column_stack([evaluate(e).gx - evaluate(np.zeros(12)).gx for e in np.eye(12)])
    v = rng.standard_normal(12)
    assert_allclose(jac.matvec(v), v - a @ v, rtol=0, atol=1e-6 * np.abs(v).max())
    assert_allclose(jac.matvec(np.zeros(12)), 0.0)


def slow_directions_problem(n: int = 40, seed: int = 0):
    """G(x) = A x + b, A symmetric with ``1 − eig(A)`` spread geometrically from 1 to 1e-3.

    A smooth map with a few slow directions, as the perfectly plastic fixed point on a fine
    grid (nothing changes state, yet ``I − G'`` has eigenvalues near 0): a depth-5 Anderson
    history keeps forgetting them and plateaus; a deeper one spans them.
    """
    return symmetric_problem(1.0 - np.geomspace(1.0, 1e-3, n), seed)


def below_1e6(x, ev: Evaluation) -> bool:
    return ev.residual < 1e-6


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_stalled_anderson_history_is_deepened(seed):
    """Depth-5 sweeps stall for good on slow directions; deepened on the stall they converge."""
    evaluate, exact, calls = slow_directions_problem(seed=seed)
    x0 = np.zeros_like(exact)
    kept = NewtonSettings(stall_depth=5)  # never deeper than the run's depth: the old solver
    with pytest.raises(FixedPointError):
        solve_fixed_point(evaluate, x0, below_1e6, max_iterations=400, anderson_depth=5,
                          settings=kept)
    calls.clear()
    out = solve_fixed_point(evaluate, x0, below_1e6, max_iterations=400, anderson_depth=5)
    assert out.newton_steps == 0 and out.sweeps < 200 and len(calls) == out.sweeps + 1
    # the error is bounded by ‖(I − A)⁻¹‖ = 1e3 times the residual, which is below 1e-6
    residual = out.evaluation.gx - out.x
    assert np.linalg.norm(out.x - exact) <= 1.001e3 * np.linalg.norm(residual)
    assert np.abs(residual).max() < 1e-6 * np.abs(out.x).max()


def test_sweeps_that_do_not_stall_are_not_deepened():
    """Below ``stall_sweeps`` sweeps without progress nothing changes: the same iterates."""
    evaluate, exact, _ = linear_problem()
    runs = [solve_fixed_point(evaluate, np.zeros_like(exact), below_tol, max_iterations=2000,
                              anderson_depth=5, settings=NewtonSettings(stall_depth=depth))
            for depth in (5, 20)]
    assert runs[0].sweeps == runs[1].sweeps
    assert np.array_equal(runs[0].x, runs[1].x)


def test_an_evaluation_that_keeps_g_of_x_never_sees_it_overwritten(monkeypatch):
    """The sweep writes the next Anderson iterate into G(x)'s memory only when nothing else
    holds G(x) (or the array it views): arrays an evaluation keeps stay as it returned them,
    and the iterates are those of fresh arrays."""
    from sacflow.solver import nonlinear

    evaluate, exact, _ = linear_problem(seed=3)
    kept, copies, reused = [], [], []
    step = nonlinear.AndersonMixer.step

    def recording(self, x, gx, out=None):
        reused.append(out is not None)
        return step(self, x, gx, out)

    monkeypatch.setattr(nonlinear.AndersonMixer, "step", recording)

    def keeping(x):  # keeps a view of G(x)
        ev = evaluate(x)
        kept.append(ev.gx[:])
        copies.append(ev.gx.copy())
        return ev

    out = solve_fixed_point(keeping, np.zeros_like(exact), below_tol, max_iterations=200,
                            anderson_depth=5)
    assert all(np.array_equal(k, c) for k, c in zip(kept, copies, strict=True))
    assert reused and not any(reused)
    reused.clear()
    fresh = solve_fixed_point(evaluate, np.zeros_like(exact), below_tol, max_iterations=200,
                              anderson_depth=5)
    assert reused and all(reused)
    assert np.array_equal(out.x, fresh.x) and out.sweeps == fresh.sweeps


def test_g_of_x_held_by_the_sweep_alone_takes_the_next_iterate():
    """What decides the reuse: an array (or a view of an unshared array) held by one name."""
    from sacflow.solver.nonlinear import only_referenced

    fresh = np.zeros(12)
    assert only_referenced(fresh)
    other = fresh  # a second name
    assert not only_referenced(fresh)
    del other
    view = np.zeros(12).reshape(3, 4)  # the array behind it held by the view alone
    assert only_referenced(view)
    behind = np.zeros(12)
    view_of_shared = behind.reshape(3, 4)
    assert not only_referenced(view_of_shared)
    assert not only_referenced(np.zeros(12)[::2])  # not contiguous
    assert not only_referenced(np.zeros(12, dtype=np.float32))
    read_only = np.zeros(12)
    read_only.flags.writeable = False
    assert not only_referenced(read_only)
    assert behind.size == 12
