"""Fixed points ``x = G(x)``: Anderson-accelerated sweeps with a semismooth Newton–Krylov fallback.

The plastic strain increment of a load step is such a fixed point (seed §1.7, Figs. 4–5): ``G``
is the J2 radial return of the trial stress, piecewise smooth in ``x``. Sweeps accelerated by
Anderson mixing (:mod:`sacflow.solver.anderson`; Walker & Ni, SIAM J. Numer. Anal. 49 (2011) 1715)
solve
most steps in a few evaluations. A short history can plateau on a smooth map with a few slow
directions (``I − ∂G/∂x`` nearly singular: perfect plasticity on a fine grid, where no cell
changes state); the first time the sweeps stall, the history is deepened, keeping what it holds
(Anderson(m) on a linear map is a windowed GMRES, Walker & Ni §2: a deeper window spans the
slow directions). When the plastic zone changes (cells entering or leaving the
active set) the sweeps can stall again; the solver then switches to semismooth Newton on
``F(x) = G(x) − x`` (Qi & Sun, Math. Program. 58 (1993) 353): the generalised Jacobian
``J = I − ∂G/∂x`` is given by the caller as a matrix-free operator, inverted inexactly by
restarted GMRES (Saad & Schultz 1986; forcing term as in Eisenstat & Walker, SIAM J. Sci. Comput.
17 (1996) 16: the linear tolerance follows the nonlinear residual), with a backtracking line
search on the Euclidean norm of ``F`` (a smooth merit function, where the maximum norm of the
convergence test is not). A Newton step that no step length makes a descent (the Jacobian is
inexact: the caller may leave couplings out) is not taken: the solver sweeps from the same
iterate with a fresh Anderson history, and returns to Newton when the sweeps stall again.

Nothing here knows about contact or plasticity: the caller's ``evaluate(x)`` returns ``G(x)``,
the relative residual it converges on, and any data its Jacobian needs.
"""

from __future__ import annotations

import logging
import sys
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from sacflow.solver.anderson import AndersonMixer

__all__ = [
    "Evaluation",
    "difference_jacobian",
    "FixedPointError",
    "FixedPointResult",
    "NewtonSettings",
    "newton_step",
    "only_referenced",
    "solve_fixed_point",
]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class NewtonSettings:
    """The constants of the stall test, the Newton–Krylov fallback and its line search.

    Attributes
    ----------
    progress_ratio : float
        A residual counts as progress when it is below this fraction of the best one so far
        (with Anderson) or of the previous one (plain sweeps).
    stall_sweeps : int
        Anderson sweeps without progress after which the history is deepened to
        ``stall_depth`` (once), and then Newton takes over when they stall again.
    stall_depth : int
        Anderson history depth after the first stall. A smooth map with a few slow directions
        (perfect plasticity on a fine grid: no cell changes state, yet a short history plateaus
        for tens of sweeps) needs the deeper window; it costs no evaluation, where a
        finite-difference Newton step costs one per Krylov vector and its restarted GMRES
        stagnates on the same directions.
    gmres_restart : int
        Krylov subspace size before GMRES restarts.
    gmres_restarts : int
        GMRES restart cycles per Newton step (the linear solve is inexact on purpose).
    gmres_rtol_loosest, gmres_rtol_tightest : float
        Bounds of the relative GMRES tolerance, which otherwise equals the current nonlinear
        residual (a forcing term: loose far from the solution, tight near it).
    line_search_halvings : int
        Times a Newton step may be halved while it does not lower the merit ``‖G(x) − x‖₂``.
    shortest_step : float
        Step length below which the line search stops halving; a step that still does not
        lower the merit is then refused (the solver sweeps instead).
    """

    progress_ratio: float = 0.5
    stall_sweeps: int = 25
    stall_depth: int = 20
    gmres_restart: int = 30
    gmres_restarts: int = 4
    gmres_rtol_loosest: float = 0.1
    gmres_rtol_tightest: float = 1e-4
    line_search_halvings: int = 6
    shortest_step: float = 0.05


@dataclass(frozen=True)
class Evaluation:
    """One evaluation of ``G`` at ``x``: ``G(x)``, the relative residual, the caller's data."""

    gx: np.ndarray
    residual: float
    data: Any = None


@dataclass(frozen=True)
class FixedPointResult:
    """The accepted iterate ``x``, its evaluation, and how many sweeps and Newton steps it took."""

    x: np.ndarray
    evaluation: Evaluation
    sweeps: int
    newton_steps: int


class FixedPointError(ArithmeticError):
    """The iteration limit was reached; ``residual`` is the last relative residual."""

    def __init__(self, residual: float, iterations: int) -> None:
        self.residual = residual
        self.iterations = iterations
        super().__init__(f"no fixed point after {iterations} iterations: residual {residual:.3e}")


Evaluate = Callable[[np.ndarray], Evaluation]
#: ``jacobian(x, evaluation)`` -> a linear operator (``scipy.sparse.linalg.LinearOperator`` or
#: anything :func:`scipy.sparse.linalg.gmres` accepts) applying ``I − ∂G/∂x`` to flat vectors.
Jacobian = Callable[[np.ndarray, Evaluation], Any]


def solve_fixed_point(
    evaluate: Evaluate,
    x: np.ndarray,
    converged: Callable[[np.ndarray, Evaluation], bool],
    *,
    max_iterations: int,
    anderson_depth: int = 0,
    jacobian: Jacobian | None = None,
    settings: NewtonSettings = NewtonSettings(),  # noqa: B008 (frozen, never mutated)
    label: str = "fixed point",
) -> FixedPointResult:
    """Find ``x = G(x)`` from the start ``x``.

    Parameters
    ----------
    evaluate : callable
        ``evaluate(x) -> Evaluation`` with ``G(x)`` and the relative residual of ``x``.
    x : ndarray
        Starting iterate (any shape; ``G(x)`` has the same).
    converged : callable
        ``converged(x, evaluation) -> bool``: accept ``x``.
    max_iterations : int
        Limit on sweeps plus Newton steps.
    anderson_depth : int
        Anderson history depth; 0 for plain sweeps (which hand over to Newton as soon as a sweep
        fails to halve the residual).
    jacobian : callable, optional
        ``jacobian(x, evaluation)``: the operator ``I − ∂G/∂x`` at ``x`` (see :data:`Jacobian`).
        Without it the sweeps go on to the limit.
    settings : NewtonSettings
        Stall test, GMRES and line-search constants.
    label : str
        Name in the debug log.

    Returns
    -------
    FixedPointResult

    Raises
    ------
    FixedPointError
        After ``max_iterations`` sweeps and Newton steps without convergence.
    """
    shape = x.shape
    ev = evaluate(x)
    newton, previous, best, stalled = False, np.inf, np.inf, 0
    sweeps = newton_steps = 0
    mixer = AndersonMixer(anderson_depth, shape=shape) if anderson_depth else None
    for iteration in range(1, max_iterations + 1):
        if converged(x, ev):
            return FixedPointResult(x, ev, sweeps, newton_steps)
        if mixer is None:
            newton = newton or ev.residual > settings.progress_ratio * previous
        else:  # Anderson stalls: deepen its history once, then fall back to Newton
            if ev.residual < settings.progress_ratio * best:
                best, stalled = ev.residual, 0
            stalled += 1
            if stalled > settings.stall_sweeps and mixer.depth < settings.stall_depth:
                mixer.deepen(settings.stall_depth)
                log.debug("%s: stalled, Anderson depth %d", label, settings.stall_depth)
                stalled = 1
            newton = newton or stalled > settings.stall_sweeps
        previous = ev.residual
        if newton and jacobian is not None:
            x_new, ev_new = newton_step(evaluate, jacobian, x, ev, settings, label)
            newton_steps += 1
            if _merit(x_new, ev_new) < _merit(x, ev):
                x, ev = x_new, ev_new
                continue
            # No step length lowered the residual: the Jacobian (inexact, or at a kink of G)
            # points nowhere useful here. Sweep from the unchanged iterate instead, with a fresh
            # Anderson history; Newton takes over again when the sweeps stall. (The sweep's
            # evaluation is then the last one, as callers that keep its by-products expect.)
            log.debug("%s newton: no descent, back to sweeps", label)
            newton, stalled, best = False, 0, ev.residual
            if mixer is not None:
                mixer.reset()
        gx = ev.gx
        del ev  # its other fields (box-size arrays) freed before the mixing and the next
        if mixer is None:  # evaluation make their own
            x = gx
        else:  # G(x) takes the next iterate if nothing else holds it
            spare = gx.ravel() if only_referenced(gx) else None
            x = mixer.step(x.ravel(), gx.ravel(), spare).reshape(shape)
            del spare
        del gx
        ev = evaluate(x)
        sweeps += 1
        log.debug("%s sweep %d: residual %.3e", label, iteration, ev.residual)
    raise FixedPointError(ev.residual, max_iterations)


def _reference_counts(array: np.ndarray) -> tuple[int, int]:
    """``sys.getrefcount`` of ``array`` and of the array it views (0 when it views none)."""
    base = array.base
    return sys.getrefcount(array), (0 if base is None else sys.getrefcount(base))


def _passed_on(array: np.ndarray) -> tuple[int, int]:
    """:func:`_reference_counts` one call down, as :func:`only_referenced` takes them."""
    return _reference_counts(array)


def _sole_reference_counts() -> tuple[int, int]:
    """Return the counts of a view held by one name, its array by the view alone.

    Taken through the same calls as :func:`only_referenced`'s, so that whatever references
    the interpreter counts for names, arguments and frames are counted alike.
    """
    held = np.empty(2).reshape(1, 2)
    return _passed_on(held)


#: Reference counts of an array (and of the array it views) that one name holds alone.
_SOLE = _sole_reference_counts()


def only_referenced(gx: np.ndarray) -> bool:
    """Whether ``gx`` (and the array it views, if any) is held by the caller's name alone.

    Then its memory can take the next iterate: nothing else (an evaluation's by-products, a
    view of it) can see the change. ``gx`` a view of an array that is itself a view: False.
    """
    if not (gx.flags.writeable and gx.flags.c_contiguous and gx.dtype == np.float64):
        return False
    count, base_count = _reference_counts(gx)
    if count > _SOLE[0]:
        return False
    base = gx.base
    return base is None or (isinstance(base, np.ndarray) and base.base is None
                            and base_count <= _SOLE[1])


def difference_jacobian(
    evaluate: Evaluate, x: np.ndarray, ev: Evaluation, relative_step: float, size: float
) -> Any:
    """``I − ∂G/∂x`` at ``x`` by directional finite differences of ``G`` (Jacobian-free).

    ``J v = v − (G(x + εv) − G(x)) / ε`` with ``ε = relative_step · size / max|v|``, ``size``
    the scale of ``x`` (Knoll & Keyes, J. Comput. Phys. 193 (2004) 357): one evaluation of
    ``G`` per product, every coupling inside ``G`` included. Returns a
    ``scipy.sparse.linalg.LinearOperator`` on flat vectors (a :data:`Jacobian`).
    """
    from scipy.sparse.linalg import LinearOperator  # only when a step stalls

    shape, n = x.shape, x.size

    def matvec(v: np.ndarray) -> np.ndarray:
        v = v.reshape(shape)
        size_v = float(np.abs(v).max())
        if size_v == 0.0:
            return np.zeros(n)
        eps = relative_step * size / size_v
        product: np.ndarray = (v - (evaluate(x + eps * v).gx - ev.gx) / eps).ravel()
        return product

    return LinearOperator((n, n), matvec=matvec, dtype=float)


def _merit(x: np.ndarray, ev: Evaluation) -> float:
    """Euclidean norm of ``F(x) = G(x) − x``: the line search's merit (smooth, unlike the max)."""
    return float(np.linalg.norm(ev.gx - x))


def newton_step(
    evaluate: Evaluate,
    jacobian: Jacobian,
    x: np.ndarray,
    ev: Evaluation,
    settings: NewtonSettings,
    label: str,
) -> tuple[np.ndarray, Evaluation]:
    """One inexact Newton step on ``F(x) = G(x) − x`` with a backtracking line search."""
    from scipy.sparse.linalg import gmres  # only when a step stalls

    rtol = max(min(settings.gmres_rtol_loosest, ev.residual), settings.gmres_rtol_tightest)
    delta, _ = gmres(jacobian(x, ev), (ev.gx - x).ravel(), rtol=rtol, atol=0.0,
                     restart=settings.gmres_restart, maxiter=settings.gmres_restarts)
    delta = delta.reshape(x.shape)
    length = 1.0
    merit = _merit(x, ev)
    for _ in range(settings.line_search_halvings):
        x_try = x + length * delta
        ev_try = evaluate(x_try)
        if _merit(x_try, ev_try) < merit or length < settings.shortest_step:
            break
        length *= 0.5
    log.debug("%s newton: residual %.3e -> %.3e (step length %.3g)", label, ev.residual,
              ev_try.residual, length)
    return x_try, ev_try
