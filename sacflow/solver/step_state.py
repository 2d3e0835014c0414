"""The fields of a :class:`~sacflow.solver.state.State`: a converged increment made output.

Per-step scalars (load, approach, contact area, iterations, residuals and whether they met their
tolerances), surface fields on the body grid (pressure, gap, initial gap, residual and total
surface displacement, shear traction), the volume fields the output plan asks for at this step
and the solver state a resume needs (:data:`~sacflow.solver.state.RESTART_FIELDS`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from sacflow.mechanics.contact import ContactResult
from sacflow.mechanics.stress_measures import von_mises
from sacflow.solver.body import BodyState
from sacflow.solver.increment import Increment, IncrementSolver
from sacflow.solver.inputs import SolverInputs
from sacflow.solver.layout import StepPlan
from sacflow.solver.state import INCLUSION_FIELDS, VOLUME_FIELDS, GridCoords, State

__all__ = ["StateBuilder"]


class StateBuilder:
    """Makes the :class:`~sacflow.solver.state.State` of each converged increment.

    Parameters
    ----------
    inputs : SolverInputs
        The run's material, contact, settings.
    coords : GridCoords
        Cell centres of the body grid.
    increments : IncrementSolver
        The increment solver (the stress of the load and the initial stress).
    """

    def __init__(self, inputs: SolverInputs, coords: GridCoords,
                 increments: IncrementSolver) -> None:
        self.material = inputs.material
        self.contact = inputs.contact
        self.settings = inputs.settings
        self.cell = inputs.grid.cell
        self.coords = coords
        self.body_shape = (coords.x1.size, coords.x2.size)
        self.increments = increments
        self.inhomogeneities = bool(inputs.inhomogeneities)

    def volume_fields(self, body: BodyState, result: ContactResult, sl: tuple[slice, slice],
                      names: Sequence[str] | None = None) -> dict[str, np.ndarray]:
        """Volume fields of the state (all, or those in ``names``: only what they need)."""
        every = (*VOLUME_FIELDS, *(INCLUSION_FIELDS if self.inhomogeneities else ()))
        wanted = set(every if names is None else names)
        out: dict[str, np.ndarray] = {}
        if wanted & {"stress", "von_mises"}:
            stress = (self.increments.load_stress(result.pressure, sl, result.subcell_pressure)
                      + body.residual_stress)
            out["stress"] = stress
            out["von_mises"] = von_mises(stress)
        if "residual_stress" in wanted:
            residual = body.residual_stress.copy()
            out["residual_stress"] = self.increments.with_initial_stress(residual)
        equivalent = body.equivalent_plastic_strain
        if "yield_stress" in wanted:
            yield_stress = (self.material.law.yield_stress(equivalent, self.coords.x3)
                            if self.material.plastic else np.full(equivalent.shape, np.inf))
            out["yield_stress"] = np.asarray(yield_stress, dtype=float)
            inclusion = self.increments.fixed_point.inclusion
            if inclusion is not None and inclusion.own is not None:  # their own laws
                out["yield_stress"] = out["yield_stress"].copy()
                inclusion.own.yield_stress(equivalent, out["yield_stress"])
        out["plastic_strain"] = body.plastic_strain.copy()
        out["equivalent_plastic_strain"] = equivalent.copy()
        if body.backstress is not None:
            out["backstress"] = body.backstress.copy()
        if self.inhomogeneities:
            out.update(self._inclusion_fields(body))
        return {name: array for name, array in out.items() if name in wanted}

    def _inclusion_fields(self, body: BodyState) -> dict[str, np.ndarray]:
        """``equivalent_eigenstrain`` (n1, n2, nz, 6) and ``phase`` (n1, n2, nz) int8."""
        inclusion = self.increments.fixed_point.inclusion
        assert inclusion is not None
        eps = np.zeros((*inclusion.phase.shape, 6))
        if body.equivalent_eigenstrain is not None:
            inclusion.embed(body.equivalent_eigenstrain, eps)
        return {"equivalent_eigenstrain": eps, "phase": inclusion.phase.copy()}

    def _shear_traction(self, pressure: np.ndarray) -> dict[str, np.ndarray]:
        """``{"shear_traction": μ p d}`` (nx1, nx2, 2) [Pa] with a ``[friction]`` table, else {}."""
        if not self.contact.friction:
            return {}
        t1, t2 = self.contact.traction or (0.0, 0.0)
        return {"shear_traction": np.stack((t1 * pressure, t2 * pressure), axis=-1)}

    def _restart(self, body: BodyState, pressure: np.ndarray) -> dict[str, np.ndarray]:
        """Return the solver state a resume needs (:data:`~sacflow.solver.state.RESTART_FIELDS`)."""
        keep = np.copy if self.material.plastic else np.asarray  # an elastic body's zeros stay
        return {
            "plastic_strain": keep(body.plastic_strain),
            "equivalent_plastic_strain": keep(body.equivalent_plastic_strain),
            "residual_displacement": keep(body.residual_displacement),
            "pressure": pressure,
            **({} if body.backstress is None else {"backstress": body.backstress.copy()}),
            **self._inclusion_restart(body),
        }

    def _inclusion_restart(self, body: BodyState) -> dict[str, np.ndarray]:
        """``{"equivalent_eigenstrain": ε*}`` on the body grid when the body has one, else {}."""
        inclusion = self.increments.inclusion
        if inclusion is None or body.equivalent_eigenstrain is None:
            return {}
        return {"equivalent_eigenstrain": inclusion.embed(body.equivalent_eigenstrain)}

    def _surface(self, body: BodyState, inc: Increment,
                 pressure: np.ndarray) -> dict[str, np.ndarray]:
        """Surface fields on the body grid (NaN outside the contact window where not defined)."""
        shape, sl, result = self.body_shape, inc.window, inc.contact
        gap = np.full(shape, np.nan)
        gap[sl] = result.gap
        geometry = np.full(shape, np.nan)
        geometry[sl] = inc.geometry
        material = self.material
        elastic_share = self.contact.e_star * (1.0 - material.nu**2) / material.E
        surface_displacement = body.residual_displacement.copy()
        surface_displacement[sl] += elastic_share * result.displacement
        return {
            "pressure": pressure,
            "gap": gap,
            "geometry": geometry,
            "residual_displacement": body.residual_displacement.copy(),
            "surface_displacement": surface_displacement,
            **self._shear_traction(pressure),
        }

    def state(self, step: int, plan: StepPlan, inc: Increment, body: BodyState,
              first_contact_offset: float | None, volume: dict[str, np.ndarray],
              substeps: int = 1) -> State:
        """Return the state after increment ``step`` (``volume``: its volume fields, or none)."""
        result = inc.contact
        pressure = np.zeros(self.body_shape)
        pressure[inc.window] = result.pressure
        restart = self._restart(body, pressure)
        cell_area = self.cell[0] * self.cell[1]
        opts = self.settings
        contact_ok = result.error < opts.contact_tolerance
        plastic_ok = inc.plasticity_residual < opts.plasticity_tolerance
        coupling_ok = inc.coupling_residual < opts.coupling_tolerance
        return State(
            step=step,
            segment=plan.segment,
            pass_index=plan.pass_index,
            substeps=substeps,
            load=float(plan.load),
            approach=float(result.approach),
            load_x1=float(plan.position[0]),
            load_x2=float(plan.position[1]),
            contact_area=float(np.count_nonzero(result.pressure > 0) * cell_area
                               if result.area is None else result.area),
            max_pressure=float(result.pressure.max(initial=0.0)),
            contact_iterations=int(inc.contact_iterations),
            plasticity_iterations=int(inc.plasticity_iterations),
            inclusion_iterations=int(inc.inclusion_iterations),
            converged=contact_ok and plastic_ok and coupling_ok,
            contact_converged=contact_ok,
            plasticity_converged=plastic_ok,
            coupling_converged=coupling_ok,
            contact_residual=float(result.error),
            plasticity_residual=float(inc.plasticity_residual),
            coupling_residual=float(inc.coupling_residual),
            restart=restart,
            first_contact_offset=first_contact_offset,
            surface=self._surface(body, inc, pressure),
            volume=volume,
        )
