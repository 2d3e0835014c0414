"""The contact solved on sub-cells of the body's surface cells: its edge resolved inside a cell.

With a pressure uniform over each surface cell and the gap collocated at the cells' centres
(:func:`~sacflow.mechanics.contact.solve_contact`), the edge of the contact moves from cell to
cell. Where it falls inside its cell changes with the cell size and with the load, in a
sawtooth that is not a power of the cell size: at 600 N on 48² cells, the press of the
indentation-made dent deepens its print by 0.43 % while its edge runs across half a cell, and
gives 0.43 % back when the edge enters the next one (``docs/convergence.md``, "The contact on
sub-cells").

Here the contact is solved on s × s sub-cells of each body surface cell (Polonsky and Keer's
conjugate gradients, Love's rectangles of the sub-cell's size); the body keeps its cells. The
gap at the sub-cells' centres is the initial gap there (the geometry and the surface features
evaluated exactly) plus the body's residual surface displacement, interpolated from the body's
cell centres by bicubic splines (exact for the quadratic gap of a sphere). The body's cells
carry the mean of their sub-cells' pressures (each cell's share of the load, exactly: the
state's pressure field), and the body's stress is that of the sub-cells' pressure itself:
the cell means' stress plus that of each sub-cell's deviation from its cell's mean
(:meth:`~sacflow.solver.operators.Operators.subcell_pressure_stress`). Smeared over its cell,
the pressure at the contact's edge, where a plastic indentation's pressure is highest and
falls to zero within a cell, would move its load by up to half a cell: on Hertz's contact the
stress a cell deep and below is then 3.5 to 7 times further from Huber's closed form
(``tests/test_subcell_contact.py``). The contact area is that of the loaded sub-cells.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from sacflow.kernels.convolution import Convolution
from sacflow.kernels.surface import rectangle_displacement
from sacflow.mechanics.contact import ContactResult, solve_contact
from sacflow.solver.body import ContactHistory
from sacflow.solver.geometry import LoadGeometry
from sacflow.solver.inputs import MAX_CONTACT_SUBCELLS, SolverInputs, SolverSettings
from sacflow.solver.layout import StepPlan

__all__ = ["SubcellContact", "subcell_contact"]

#: Degree of the splines that carry the residual surface displacement to the sub-cells.
SPLINE_DEGREE = 3
#: Body cells beyond the contact window, on each side, through which those splines pass. A
#: node's influence on a cubic interpolating spline decays by 2 − √3 ≈ 0.27 per cell (C. de Boor,
#: A Practical Guide to Splines, 1978, ch. IV): 8 cells leave it below 3e-5, and a rolled track
#: longer than the window costs no more than the window.
SPLINE_MARGIN = 8


class SubcellContact:
    """Normal contact on ``subcells`` × ``subcells`` sub-cells of each surface cell.

    Parameters
    ----------
    geometry : LoadGeometry
        The run's body grid, contact window and initial gap.
    e_star : float
        Contact modulus E* of the two bodies [Pa].
    subcells : int
        Sub-cells per body cell along each axis (2 or more).
    threads : int or None
        FFT threads of the compliance.
    """

    def __init__(self, geometry: LoadGeometry, e_star: float, subcells: int,
                 threads: int | None = None) -> None:
        if not 2 <= subcells <= MAX_CONTACT_SUBCELLS:
            raise ValueError(f"subcells must lie in 2..{MAX_CONTACT_SUBCELLS}, not {subcells}")
        self.geometry = geometry
        self.subcells = subcells
        dx1, dx2 = geometry.cell
        self.sub_cell = (dx1 / subcells, dx2 / subcells)
        s1, s2 = self.sub_cell
        shape = (geometry.window[0] * subcells, geometry.window[1] * subcells)

        def love(d1: np.ndarray, d2: np.ndarray) -> np.ndarray:
            unit: np.ndarray = rectangle_displacement(d1 * s1, d2 * s2, s1 / 2, s2 / 2)
            return (unit / (np.pi * e_star))[None, None]

        self.compliance = Convolution(love, shape, shape, threads=threads)
        #: sub-cell centres relative to their cell's centre, in cells
        self.offsets = (np.arange(subcells) + 0.5) / subcells - 0.5
        self._last: tuple[np.ndarray, np.ndarray] | None = None

    def points(self, window: tuple[slice, slice]) -> tuple[np.ndarray, np.ndarray]:
        """Return the sub-cells' centres along x1 and x2 [m] over the body cells ``window``."""
        coords, (dx1, dx2) = self.geometry.coords, self.geometry.cell
        x1 = (coords.x1[window[0]][:, None] + self.offsets[None, :] * dx1).ravel()
        x2 = (coords.x2[window[1]][:, None] + self.offsets[None, :] * dx2).ravel()
        return x1, x2

    def window_gap(self, position: tuple[float, float],
                   window: tuple[slice, slice]) -> np.ndarray:
        """Return the initial gap [m] at the sub-cells' centres of the contact window."""
        x1, x2 = self.points(window)
        return self.geometry.initial_gap(position, x1[:, None], x2[None, :])

    def displacement(self, surface: np.ndarray, window: tuple[slice, slice]) -> np.ndarray:
        """Return a body-grid surface field (n1, n2) at the sub-cells' centres of ``window``.

        Bicubic splines through the body's cell centres over the window and
        :data:`SPLINE_MARGIN` cells beyond it where the body has them (so that the window's
        border has neighbours), evaluated at the sub-cells.
        """
        from scipy.interpolate import RectBivariateSpline  # a run without sub-cells needs none

        x1, x2 = self.points(window)
        if not surface.any():
            return np.zeros((x1.size, x2.size))
        coords, (dx1, dx2) = self.geometry.coords, self.geometry.cell
        near = tuple(slice(max(w.start - SPLINE_MARGIN, 0), w.stop + SPLINE_MARGIN)
                     for w in window)
        c1, c2 = coords.x1[near[0]], coords.x2[near[1]]
        box = [c1[0] - dx1 / 2, c1[-1] + dx1 / 2, c2[0] - dx2 / 2, c2[-1] + dx2 / 2]
        spline = RectBivariateSpline(c1, c2, surface[near], bbox=box,
                                     kx=SPLINE_DEGREE, ky=SPLINE_DEGREE)
        values: np.ndarray = spline(x1, x2)
        return values

    def cell_mean(self, values: np.ndarray) -> np.ndarray:
        """Return the mean over each body cell of a sub-cell field (n1 s, n2 s) -> (n1, n2)."""
        s = self.subcells
        n1, n2 = values.shape[0] // s, values.shape[1] // s
        mean: np.ndarray = values.reshape(n1, s, n2, s).mean(axis=(1, 3))
        return mean

    def warm_start(self, pressure: np.ndarray | None) -> np.ndarray | None:
        """Return the sub-cells' warm start for the body cells' warm start ``pressure``.

        The last solution's sub-cell pressure when ``pressure`` is that solution's cell mean
        (the solver's own memory), else ``pressure`` spread over each cell's sub-cells (a
        restart, a cutback's saved copy); None without one.
        """
        if pressure is None:
            return None
        if self._last is not None and pressure is self._last[0]:
            return self._last[1]
        s = self.subcells
        spread: np.ndarray = np.repeat(np.repeat(pressure, s, axis=0), s, axis=1)
        return spread

    def solve(self, gap: np.ndarray, load: float, pressure: np.ndarray | None, *,
              tol: float, max_iter: int, step: int) -> ContactResult:
        """Solve the contact on the sub-cells' initial ``gap`` and return it on the body cells.

        ``pressure`` is the warm start on the body cells (:meth:`warm_start`). The result's
        pressure, displacement and gap are cell means, its area that of the loaded sub-cells,
        and its ``subcell_pressure`` the sub-cells' own (the load of the body's stress).
        """
        s1, s2 = self.sub_cell
        fine = solve_contact(gap, self.compliance, s1 * s2, load=load,
                             initial_pressure=self.warm_start(pressure), tol=tol,
                             max_iter=max_iter, step=step)
        result = replace(fine, pressure=self.cell_mean(fine.pressure),
                         displacement=self.cell_mean(fine.displacement),
                         gap=self.cell_mean(fine.gap),
                         area=float(np.count_nonzero(fine.pressure > 0) * s1 * s2),
                         subcell_pressure=fine.pressure)
        self._last = (result.pressure, fine.pressure)
        return result


    def restored_pressure(self, plan: StepPlan, history: ContactHistory,
                          residual_displacement: np.ndarray, settings: SolverSettings,
                          step: int) -> np.ndarray | None:
        """Return the sub-cells' pressure of a restored step (None when it was unloaded).

        Stored steps keep the cells' pressure only (``history.converged``). The step's contact
        is solved on the sub-cells again, on the restored residual displacement and
        warm-started from that pressure, so that the next increment starts from the stress of
        the sub-cells' pressure as in an uninterrupted run.
        """
        if history.converged is None:
            return None
        pressure, window = history.converged
        gap = (self.window_gap(plan.position, window) - (history.first_contact_offset or 0.0)
               + self.displacement(residual_displacement, window))
        result = self.solve(gap, plan.load, pressure, tol=settings.contact_tolerance,
                            max_iter=settings.contact_max_iterations, step=step)
        return result.subcell_pressure


def subcell_contact(geometry: LoadGeometry, inputs: SolverInputs) -> SubcellContact | None:
    """Return the run's contact on sub-cells (``settings.contact_subcells`` > 1), else None."""
    subcells = inputs.settings.contact_subcells
    if subcells == 1:
        return None
    return SubcellContact(geometry, inputs.contact.e_star, subcells, inputs.settings.fft_threads)
