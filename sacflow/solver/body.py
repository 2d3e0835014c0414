"""What a simulation carries from one increment to the next.

The body's internal variables and the residual fields they cause (:class:`BodyState`), and the
contact's memory of the load path (:class:`ContactHistory`): the last contact pressure, the warm
start of the next contact solve, and the origin of the approach.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["BodyState", "ContactHistory"]


@dataclass
class BodyState:
    """The body's state on the body grid (n1, n2, nz) after the last converged increment.

    Attributes
    ----------
    plastic_strain : ndarray, shape (n1, n2, nz, 6)
        Plastic strain tensor εp (tensor shears).
    equivalent_plastic_strain : ndarray, shape (n1, n2, nz)
        Equivalent plastic strain p.
    initial_equivalent_plastic_strain : ndarray, shape (n1, n2, nz)
        p before the first increment (initial hardening, or a stored run's): plastic flow in
        this run is where p exceeds it.
    backstress : ndarray, shape (n1, n2, nz, 6), or None
        Backstress X of kinematic hardening [Pa], None without it.
    residual_stress : ndarray, shape (n1, n2, nz, 6)
        Residual stress of εp [Pa] (without the initial stress of the case).
    residual_displacement : ndarray, shape (n1, n2)
        Residual normal surface displacement of εp [m].
    equivalent_eigenstrain : ndarray, shape (m, 6), or None
        Equivalent eigenstrain ε* of the cells of the elastic inhomogeneities
        (:mod:`sacflow.solver.inclusion`), None without them. With it the residual stress and
        displacement are those of ``εp + ε*``: the disturbance of the inhomogeneities included.
    """

    plastic_strain: np.ndarray
    equivalent_plastic_strain: np.ndarray
    initial_equivalent_plastic_strain: np.ndarray
    backstress: np.ndarray | None
    residual_stress: np.ndarray
    residual_displacement: np.ndarray
    equivalent_eigenstrain: np.ndarray | None = None


@dataclass
class ContactHistory:
    """The contact's memory along the load path.

    ``pressure`` is the last contact pressure on the window (the warm start of the next contact
    solve; None when unloaded), ``first_contact_offset`` the initial-gap offset of the first
    contact [m] (the origin of the approach; None before it), and ``converged`` the contact
    pressure of the last converged increment with the body-grid slices of its window (None
    when that increment was unloaded): the load of the stress the next increment starts from,
    ``converged_subcells`` its pressure on the contact's sub-cells (None without them), and
    ``converged_stress`` that whole stress when the solver kept it.
    """

    pressure: np.ndarray | None = None
    first_contact_offset: float | None = None
    converged: tuple[np.ndarray, tuple[slice, slice]] | None = None
    converged_stress: np.ndarray | None = None
    converged_subcells: np.ndarray | None = None

    def remember(self, pressure: np.ndarray, window: tuple[slice, slice], load: float,
                 stress: np.ndarray | None = None,
                 subcell_pressure: np.ndarray | None = None) -> None:
        """Keep the converged ``pressure`` at ``window`` (None when unloaded) and ``stress``."""
        self.converged = (pressure, window) if load > 0.0 and pressure.any() else None
        self.converged_subcells = subcell_pressure if self.converged is not None else None
        self.converged_stress = stress
