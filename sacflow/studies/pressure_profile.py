"""The contact pressure of a run on sub-cells at its peak load: where its peak sits, and the gap.

Two questions about the press of the indentation-made dent (issue #32), whose peak pressure
converges slowly (order 1.36 in the convergence study's ``together`` sequence):

* **Where is the peak?** At the contact's edge, where the pressure falls to zero within a cell,
  the largest cell mean would sample a feature no cell resolves; at a smooth maximum inside the
  contact it differs from the point maximum by the cell mean's O(h²) alone. The radial profile
  along the cell row nearest the axis, on the cells and on the sub-cells, says which.
* **What do the splines put into the sub-cells' gap?** The residual surface displacement
  reaches the sub-cells through bicubic splines from the cells' centres
  (:mod:`sacflow.solver.subcell_contact`). The alternative is the cells' plastic strain's own
  displacement at the sub-cells (:class:`~sacflow.kernels.subcell_displacement.
  SubcellResidualDisplacement`). The step's contact is solved again on each, and the
  alternation of the sub-cells' pressure from sub-cell to sub-cell measured (:func:`sawtooth`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from sacflow.kernels.subcell_displacement import SubcellResidualDisplacement
from sacflow.solver.simulation import Simulation

__all__ = ["PeakLoadSnapshot", "peak_load_snapshot", "row_profile", "sawtooth",
           "pressure_profile"]

#: Part of the contact radius inside which the sub-cells' pressure oscillation is measured:
#: away from the edge, whose fall to zero is no oscillation.
INTERIOR = 0.9


@dataclass
class PeakLoadSnapshot:
    """The body and contact at the step of the largest load (copies)."""

    step: int
    load: float
    position: tuple[float, float]
    plastic_strain: np.ndarray
    residual_displacement: np.ndarray
    pressure: np.ndarray
    window: tuple[slice, slice]
    subcell_pressure: np.ndarray
    first_contact_offset: float


def peak_load_snapshot(sim: Simulation) -> PeakLoadSnapshot:
    """Run ``sim`` (contact on sub-cells) up to its first unloading step; keep the peak load's."""
    best: PeakLoadSnapshot | None = None
    for state in sim.run():
        if best is not None and state.load < best.load:
            break
        history = sim.history
        if history.converged is None or history.converged_subcells is None:
            continue
        pressure, window = history.converged
        best = PeakLoadSnapshot(
            state.step, state.load, (state.load_x1, state.load_x2),
            sim.body.plastic_strain.copy(), sim.body.residual_displacement.copy(),
            pressure.copy(), window, history.converged_subcells.copy(),
            float(history.first_contact_offset or 0.0))
    if best is None:
        raise ValueError("the run has no loaded step on sub-cells (solver.contact_subcells > 1)")
    return best


def row_profile(values: np.ndarray, x1: np.ndarray, x2: np.ndarray,
                centre: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Return (x1, values) beyond ``centre`` along +x1, on the row of ``values`` nearest it.

    ``values`` has shape (len(x1), len(x2)) on the points ``x1``, ``x2``; the row is the one
    whose x2 is nearest ``centre[1]``, and its points those with x1 > ``centre[0]``.
    """
    j = int(np.argmin(np.abs(x2 - centre[1])))
    ahead = x1 > centre[0]
    return x1[ahead], values[ahead, j]


def sawtooth(r: np.ndarray, pressure: np.ndarray, contact_radius: float) -> float:
    """Amplitude of the pressure's alternation from sub-cell to sub-cell along a row [Pa].

    |mean of (−1)ᵏ (p_k − (p_k−1 + p_k+1)/2)| / 2 over the points inside ``INTERIOR`` of the
    contact radius: p = p̄ + A (−1)ᵏ gives A; a smooth profile's curvature and a single dip
    (the edge's own fall) average out, to O(1/n) of their size.
    """
    middle = pressure[1:-1] - 0.5 * (pressure[:-2] + pressure[2:])
    inside = r[1:-1] < INTERIOR * contact_radius
    if not inside.any():
        return float("nan")
    signs = (-1.0) ** np.arange(middle.size)
    return float(abs(np.mean(signs[inside] * middle[inside])) / 2.0)


def pressure_profile(sim: Simulation) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """Measure the peak-load pressure of ``sim`` (module doc): a summary and profile rows."""
    snap = peak_load_snapshot(sim)
    contact = sim.increments.subcells
    settings = sim.increments.settings
    assert contact is not None  # peak_load_snapshot found a sub-cell pressure
    coords = sim.coords
    x1c, x2c = coords.x1[snap.window[0]], coords.x2[snap.window[1]]
    x1s, x2s = contact.points(snap.window)
    spline = contact.displacement(snap.residual_displacement, snap.window)
    operator = SubcellResidualDisplacement(
        snap.plastic_strain.shape[:3], sim.operators.cell, coords.x3,
        np.full_like(coords.x3, 0.5 * sim.dz), sim.operators.nu, contact.subcells,
        settings.fft_threads)
    cuboids = operator(snap.plastic_strain)[_fine(snap.window, contact.subcells)]
    gap = contact.window_gap(snap.position, snap.window) - snap.first_contact_offset
    solved = {name: contact.solve(gap + u, snap.load, snap.pressure,
                                  tol=settings.contact_tolerance,
                                  max_iter=settings.contact_max_iterations, step=snap.step)
              for name, u in (("splines", spline), ("cuboids", cuboids))}
    x_fine, p_fine = row_profile(snap.subcell_pressure, x1s, x2s, snap.position)
    r_fine = x_fine - snap.position[0]
    contact_radius = float(r_fine[p_fine > 0].max()) if (p_fine > 0).any() else float("nan")
    xc, pc = row_profile(snap.pressure, x1c, x2c, snap.position)
    rc = xc - snap.position[0]
    where = np.unravel_index(int(np.argmax(snap.pressure)), snap.pressure.shape)
    peak_r = float(np.hypot(x1c[where[0]] - snap.position[0], x2c[where[1]] - snap.position[1]))
    inside = snap.subcell_pressure > 0
    difference = spline - cuboids
    summary: dict[str, Any] = {
        "step": snap.step, "load": snap.load, "cell": float(sim.operators.cell[0]),
        "contact_radius": contact_radius, "peak_pressure": float(snap.pressure.max()),
        "peak_radius": peak_r, "subcell_peak_pressure": float(snap.subcell_pressure.max()),
        "splines_minus_cuboids_max": float(np.abs(difference[inside]).max()),
    }
    rows = [{"source": "cells", "r": float(r), "pressure": float(p)}
            for r, p in zip(rc, pc, strict=True)]
    for name, result in solved.items():
        assert result.subcell_pressure is not None
        x, p = row_profile(result.subcell_pressure, x1s, x2s, snap.position)
        r = x - snap.position[0]
        summary[f"peak_pressure_{name}"] = float(result.pressure.max())
        summary[f"sawtooth_{name}"] = sawtooth(r, p, contact_radius)
        rows += [{"source": f"subcells_{name}", "r": float(a), "pressure": float(b)}
                 for a, b in zip(r, p, strict=True)]
    return summary, rows


def _fine(window: tuple[slice, slice], subcells: int) -> tuple[slice, slice]:
    """Return the sub-cell index range of the body cells ``window``."""
    first, second = window
    return (slice(first.start * subcells, first.stop * subcells),
            slice(second.start * subcells, second.stop * subcells))
