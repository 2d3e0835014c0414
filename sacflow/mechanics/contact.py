"""Elastic normal contact for an arbitrary initial gap: Polonsky–Keer conjugate gradients.

Conventions: the gap is ``g = h + u − δ`` with ``h`` the initial separation of the two surfaces
(geometry, dents, residual displacement: anything independent of the current pressure), ``u`` the
normal displacement of the surfaces caused by the pressure (sum of both bodies, positive when the
surfaces move apart, i.e. into each body), and ``δ`` the rigid-body approach. Contact conditions:
``g ≥ 0``, ``p ≥ 0``, ``p·g = 0``; load balance ``Σ p ΔA = W``.

Method: I. A. Polonsky and L. M. Keer, "A numerical method for solving rough contact problems
based on the multi-level multi-summation and conjugate gradient techniques", Wear 231 (1999) 206,
doi:10.1016/S0043-1648(99)00113-1 — constrained conjugate gradients on the contact set, either
load-controlled (δ eliminated through the mean gap over the contact set) or approach-controlled;
the compliance operator is applied with DC-FFT (:mod:`sacflow.kernels.fft`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from sacflow.errors import ConvergenceError
from sacflow.machine.threads import single_threaded_blas

__all__ = ["ContactResult", "solve_contact"]

#: At the iteration limit, a residual that fell by less than this factor over the last half of
#: the iterations has stalled: more iterations would not help, and the message says so.
_STALLED_REDUCTION = 2.0

#: Recompute ``u = K p`` exactly at least every this many algebraic updates (round-off control:
#: each update adds a relative error of order 1e-16 to ``u``; 32 keeps it far below the 1e-10
#: tolerance while saving most of the refresh convolutions).
_REFRESH_EVERY = 32


@dataclass(frozen=True)
class ContactResult:
    """Converged elastic contact state (arrays on the contact grid, SI units).

    ``area`` is the contact area [m²] when the solution knows it more finely than its grid's
    loaded cells (:class:`~sacflow.solver.subcell_contact.SubcellContact`), else None;
    ``subcell_pressure`` that solution's pressure on the sub-cells [Pa], else None.
    """

    pressure: np.ndarray
    displacement: np.ndarray
    gap: np.ndarray
    approach: float
    load: float
    iterations: int
    error: float
    area: float | None = None
    subcell_pressure: np.ndarray | None = None


def solve_contact(
    h: np.ndarray,
    compliance: Callable[[np.ndarray], np.ndarray],
    cell_area: float,
    *,
    load: float | None = None,
    approach: float | None = None,
    initial_pressure: np.ndarray | None = None,
    tol: float = 1e-10,
    max_iter: int = 2000,
    step: int = 0,
) -> ContactResult:
    """Solve the frictionless normal contact for the initial gap ``h``.

    Parameters
    ----------
    h : ndarray
        Initial separation [m] on the contact grid (any shape the compliance accepts).
    compliance : callable
        Linear operator ``p -> u`` (surface displacement [m] from pressure [Pa]).
    cell_area : float
        Area of one cell [m²].
    load, approach : float
        Give exactly one: the normal load W [N] (load control) or the approach δ [m].
    initial_pressure : ndarray, optional
        Warm start (e.g. the previous increment's pressure).
    tol : float
        Convergence tolerance on the relative gap error (the complementarity residual)
        ``max(max_contact |g|, max_free max(−g, 0)) / (max h − min h)``: the gap is zero where
        the pressure is positive and never negative where it is zero, to ``tol`` times the
        height range of the initial gap. The returned ``error`` is that residual.
    max_iter : int
        Iteration limit; exceeding it raises :class:`~sacflow.errors.ConvergenceError`.
    step : int
        Load step, quoted in the error message.

    Returns
    -------
    ContactResult
        With ``approach`` the rigid-body approach δ: for no load, the lowest initial separation
        ``min h`` (the counter-body touching the surface), so that δ is continuous as W → 0.
    """
    if (load is None) == (approach is None):
        raise ValueError("give exactly one of load or approach")
    with single_threaded_blas():
        return _solve(h, compliance, cell_area, load, approach, initial_pressure, tol, max_iter,
                      step)


def _solve(
    h: np.ndarray,
    compliance: Callable[[np.ndarray], np.ndarray],
    cell_area: float,
    load: float | None,
    approach: float | None,
    initial_pressure: np.ndarray | None,
    tol: float,
    max_iter: int,
    step: int,
) -> ContactResult:
    """Body of :func:`solve_contact` (same arguments, run with one BLAS thread)."""
    h = np.asarray(h, dtype=float)
    unloaded = _without_contact(h, load, approach, initial_pressure)
    if unloaded is not None:
        return unloaded
    p = _start_pressure(h, cell_area, load, approach, initial_pressure)
    load_control = load is not None

    # Flat views and float masks: dot products (BLAS) instead of boolean gathers.
    shape = h.shape
    h = h.ravel()
    p = p.ravel()
    t = np.zeros_like(h)
    g_norm_old = 1.0
    conjugate = False
    u = compliance(p.reshape(shape)).ravel()
    exact_age = 0
    scale = max(float(np.ptp(h)), 1e-300)
    error = halfway_error = np.inf
    gap = np.empty_like(h)
    for iteration in range(max_iter + 1):
        np.add(h, u, out=gap)
        mask, n_contact = _contact_set(p, gap)
        delta = float(gap @ mask) / n_contact if approach is None else float(approach)
        gap -= delta
        g = gap * mask
        error = _gap_error(gap, g, mask, scale)
        if error < tol:
            break
        if iteration == max_iter // 2:
            halfway_error = error
        if iteration == max_iter:
            raise _not_converged(step, error, tol, max_iter, halfway_error, n_contact)
        g_norm_old = _search_direction(t, g, mask, conjugate, g_norm_old)
        r = compliance(t.reshape(shape)).ravel()
        tau = _step_length(r, t, g, mask, n_contact if load_control else None)
        if tau == 0.0:  # nothing to move on the set: let the overlapping free cells in
            _enter_overlap(p, gap, n_contact)
            clipped, conjugate = False, False
        else:
            clipped, conjugate = _descend(p, t, gap, tau)
        rescale = 1.0
        if load is not None:
            rescale = _rescale_to_load(p, load, cell_area, step, tol, iteration)
        # u = K p by linearity (u ← s (u − τ K t)) when the step was neither clipped nor
        # corrected on overlapping cells; an exact FFT evaluation otherwise and periodically.
        if conjugate and not clipped and exact_age < _REFRESH_EVERY:
            u -= tau * r
            u *= rescale
            exact_age += 1
        else:
            u = compliance(p.reshape(shape)).ravel()
            exact_age = 0
    # u is consistent with p (exact or a few algebraic updates old); gap is h + u − δ of the
    # accepted pressure (error < tol).
    return _result(p.reshape(shape), u.reshape(shape), gap.reshape(shape), delta, cell_area,
                   iteration, error)


def _without_contact(
    h: np.ndarray, load: float | None, approach: float | None,
    initial_pressure: np.ndarray | None,
) -> ContactResult | None:
    """Return the result when nothing touches (no load, or an approach short of ``min h``)."""
    if load is not None and load <= 0.0:
        # No load: the counter-body rests on the surface, touching its highest point (the lowest
        # initial separation); after an indentation this approach is the residual print depth.
        zero = np.zeros_like(h)
        lowest = float(h.min())
        return ContactResult(zero, zero, h - lowest, lowest, 0.0, 0, 0.0)
    warm = initial_pressure is not None and np.any(initial_pressure > 0)
    if approach is not None and not warm and not np.any(h < approach):
        zero = np.zeros_like(h)
        return ContactResult(zero, zero, h - approach, float(approach), 0.0, 0, 0.0)
    return None


def _start_pressure(
    h: np.ndarray, cell_area: float, load: float | None, approach: float | None,
    initial_pressure: np.ndarray | None,
) -> np.ndarray:
    """Return the first pressure: the warm start, else uniform (load) or the overlap (approach).

    Under load control it is scaled to carry the load.
    """
    p: np.ndarray
    if initial_pressure is not None and np.any(initial_pressure > 0):
        p = np.maximum(np.asarray(initial_pressure, dtype=float), 0.0).copy()
    elif load is not None:
        p = np.ones_like(h)  # uniform start: the iteration shrinks the contact set
    else:
        p = np.where(h < approach, 1.0, 0.0)  # start from the geometric overlap
    if load is not None:
        p *= load / (cell_area * p.sum())
    return p


def _contact_set(p: np.ndarray, gap: np.ndarray) -> tuple[np.ndarray, float]:
    """Return the contact set as a float mask and its size.

    The cells under pressure; with none, the cells of the smallest gap.
    """
    mask = (p > 0.0).astype(float)
    n_contact = mask.sum()
    if n_contact == 0.0:
        mask = (gap <= gap.min()).astype(float)
        n_contact = mask.sum()
    return mask, n_contact


def _search_direction(
    t: np.ndarray, g: np.ndarray, mask: np.ndarray, conjugate: bool, g_norm_old: float
) -> float:
    """Update the direction ``t`` in place: ``g``, conjugated with the last when allowed.

    Returns ``|g|²``, the next call's ``g_norm_old``.
    """
    g_norm = float(g @ g)
    if conjugate:
        t *= (g_norm / g_norm_old) * mask
        t += g
    else:
        t[:] = g
    return g_norm


def _step_length(
    r: np.ndarray, t: np.ndarray, g: np.ndarray, mask: np.ndarray, n_contact: float | None
) -> float:
    """Return the step τ along ``t`` (``r = K t``); ``n_contact`` given under load control.

    Under load control the mean of ``r`` over the contact set is removed (δ eliminated).
    """
    r_t = float(r @ t)
    if n_contact is not None:
        r_t -= float(r @ mask) / n_contact * float(t.sum())
    return float(g @ t) / r_t if r_t != 0.0 else 0.0


def _descend(p: np.ndarray, t: np.ndarray, gap: np.ndarray, tau: float) -> tuple[bool, bool]:
    """Move ``p`` by ``−τ t`` in place, clip it at 0, press the overlapping free cells.

    Returns ``(clipped, conjugate)``: whether the clip changed a cell, and whether no free cell
    overlaps (the next direction may then be conjugated).
    """
    p -= tau * t
    clipped = bool(p.min() < 0.0)
    np.maximum(p, 0.0, out=p)
    overlap = (p == 0.0) & (gap < 0.0)
    conjugate = not overlap.any()
    if not conjugate:
        p[overlap] -= tau * gap[overlap]
    return clipped, conjugate


def _enter_overlap(p: np.ndarray, gap: np.ndarray, n_contact: float) -> None:
    """Give the free cells that overlap the mean pressure of the contact set, in place.

    The conjugate-gradient step on the contact set is zero when the gap is already uniform on
    it: a set of one cell (its gap is the mean gap that eliminates δ under load control), or
    cells of equal gaps by symmetry. Polonsky and Keer's update ``p -= τ g`` of the overlapping
    cells then moves nothing, and the iteration would repeat the same state for ever (a warm
    start of one loaded cell, a first increment of a few cells). Started at the set's mean
    pressure, they join the set, and the next steps (load rescaled, clipped where they pull)
    proceed as from a uniform start.
    """
    overlap = (p == 0.0) & (gap < 0.0)
    p[overlap] = p.sum() / n_contact


def _not_converged(step: int, error: float, tol: float, max_iter: int, halfway_error: float,
                   n_contact: float) -> ConvergenceError:
    """Return the error at the iteration limit, with advice that fits how the residual behaved.

    A residual still falling: more iterations (or smaller increments) may do. One that fell by
    less than :data:`_STALLED_REDUCTION` over the last half of the iterations has stalled:
    neither more iterations nor smaller increments (a smaller contact) help.
    """
    advice = None
    if error * _STALLED_REDUCTION > halfway_error:
        advice = (f"the residual stopped falling with {int(n_contact)} cells in contact: more "
                  f"iterations or smaller load increments will not help; a finer grid "
                  f"(more cells across the contact) may, else report the case")
    return ConvergenceError("contact", step=step, residual=error, tolerance=tol,
                            iterations=max_iter, advice=advice)


def _rescale_to_load(
    p: np.ndarray, load: float, cell_area: float, step: int, tol: float, iteration: int
) -> float:
    """Scale ``p`` in place to carry ``load``; return the factor."""
    total = p.sum() * cell_area
    if total <= 0.0:
        raise ConvergenceError(
            "contact", step=step, residual=np.inf, tolerance=tol, iterations=iteration
        )
    rescale = float(load / total)
    p *= rescale
    return rescale


def _result(
    p: np.ndarray, u: np.ndarray, gap: np.ndarray, delta: float, cell_area: float,
    iteration: int, error: float,
) -> ContactResult:
    """Return the converged state, the gap set to 0 on the contact set and ≥ 0 off it."""
    contact = p > 0.0
    np.maximum(gap, 0.0, out=gap, where=~contact)
    gap[contact] = 0.0
    return ContactResult(
        pressure=p, displacement=u, gap=gap, approach=delta,
        load=float(p.sum() * cell_area), iterations=iteration, error=error,
    )


def _gap_error(gap: np.ndarray, g: np.ndarray, mask: np.ndarray, scale: float) -> float:
    """Relative complementarity residual: gap on the contact set, overlap off it, over ``scale``.

    ``g`` is ``gap`` on the contact set (``mask`` 1) and 0 elsewhere; off the set a negative
    gap (interpenetration) counts.
    """
    on_set = float(np.abs(g).max())
    overlap = float(-(gap - g).min())  # the largest interpenetration off the set (or ≤ 0)
    return max(on_set, overlap, 0.0) / scale
