"""One load increment: the contact and the plastic strain increment solved together.

Per load increment the solver finds the plastic strain increment ``Δεp`` that is a fixed point of

    Δεp = R( σ^pr(p) + σ^r(εp_old + Δεp) + 2μ Δεp ),
    p   = elastic contact on the gap  h_geometry + u3^r(εp_old + Δεp),

where ``R`` is the J2 return mapping over the increment (:mod:`sacflow.solver.fixed_point`:
by default backward Euler with step doubling along the increment's straight trial path from
the converged stress σ_n, second order in the increment,
:mod:`sacflow.mechanics.return_extrapolation`; or one fully implicit step),
``σ^pr`` the stress of the contact pressure, ``σ^r`` the residual stress and ``u3^r`` the
residual surface displacement of the plastic strain (:mod:`sacflow.kernels.eigenstrain`). The
seed nests two loops (contact ↔ plastic strain, seed §1.7, Fig. 5); here both are one fixed
point (``scheme = "coupled"``: Anderson mixing, semismooth Newton when it stalls), the contact
being re-solved (warm-started) at every evaluation (``scheme = "nested"`` runs the seed's two
loops instead; both converge to the same increment, the single loop with fewer residual-stress
applications: ``benchmarks/elastic_plastic.py`` prints both counts). At convergence the seed's
two criteria hold: the plastic strain increment and the residual displacement increment have
stopped changing, and von Mises = σ_Y on plastic points.

Inhomogeneities (:mod:`sacflow.solver.inclusion`): the iterate carries their equivalent
eigenstrain ε* in their cells (where the plastic strain does not flow, or, with a hardening law
of their own, ``Δεp + ε*``: :mod:`sacflow.solver.own_hardening`), so that the residual stress
and the residual surface displacement the fixed point applies, and the contact's gap, are those
of ``εp + ε*``; an elastic body with inhomogeneities runs the same fixed point.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from sacflow.errors import ConvergenceError
from sacflow.mechanics.contact import ContactResult, solve_contact
from sacflow.solver.anderson import AndersonMixer
from sacflow.solver.body import BodyState, ContactHistory
from sacflow.solver.fixed_point import TINY, PlasticFixedPoint, PlasticUpdate
from sacflow.solver.geometry import LoadGeometry
from sacflow.solver.inclusion import EquivalentInclusion
from sacflow.solver.inputs import Material, SolverSettings
from sacflow.solver.layout import StepPlan
from sacflow.solver.operators import Operators
from sacflow.solver.subcell_contact import SubcellContact

__all__ = ["Increment", "IncrementSolver"]

log = logging.getLogger(__name__)

#: Loosest tolerance of the nested scheme's first inexact plastic solve; later ones take a
#: tenth of the last coupling change.
NESTED_INNER_TOLERANCE = 1e-2
#: Fraction of the last coupling change the nested scheme's next plastic solve converges to.
NESTED_FORCING = 0.1

#: The contact on the gap moved by a residual surface displacement.
ContactSolve = Callable[[np.ndarray], ContactResult]


@dataclass(frozen=True)
class Increment:
    """A converged increment.

    Window slices, its initial gap, the contact solution, the plastic update ``(Δεp, Δp)``
    (None when elastic), iteration counts, the final residuals of the plasticity and coupling
    loops (0 when elastic), when the solver already has them the residual stress and surface
    displacement of ``εp_old + Δεp`` (+ ε*), with kinematic hardening the updated backstress,
    and with elastic inhomogeneities their equivalent eigenstrain ε* on their cells (m, 6)
    and the Krylov iterations it took; ``stress`` the total stress of the converged state
    (initial stress included) when the coupled fixed point made it: the start of the next
    increment's trial path.
    """

    window: tuple[slice, slice]
    geometry: np.ndarray
    contact: ContactResult
    update: tuple[np.ndarray, np.ndarray] | None
    contact_iterations: int
    plasticity_iterations: int
    residual_fields: tuple[np.ndarray, np.ndarray] | None = None
    plasticity_residual: float = 0.0
    coupling_residual: float = 0.0
    backstress: np.ndarray | None = None
    equivalent_eigenstrain: np.ndarray | None = None
    inclusion_iterations: int = 0
    stress: np.ndarray | None = None


@dataclass
class CouplingTrace:
    """The last evaluation of the coupled fixed point (:meth:`IncrementSolver.coupled`).

    ``displacement`` is the residual surface displacement of its iterate and ``contact`` the
    contact solved on it; ``change`` the relative change of that displacement from the
    evaluation before (inf until there is one); ``stress`` the residual stress of the iterate,
    or, when the eigenstrain operator added the contact pressure's stress (``pressure``, on the
    body grid), that total; ``total`` the whole stress the evaluation returned.
    """

    displacement: np.ndarray | None = None
    contact: ContactResult | None = None
    change: float = np.inf
    stress: np.ndarray | None = None
    pressure: np.ndarray | None = None
    total: np.ndarray | None = None


class IncrementSolver:
    """Solves one increment of the load path on the body's state.

    Parameters
    ----------
    operators : Operators
        Contact compliance, pressure-stress and eigenstrain operators.
    geometry : LoadGeometry
        Contact window and initial gap of a load position.
    material : Material
        The body's material.
    settings : SolverSettings
        Tolerances, iteration limits, scheme.
    depth : ndarray
        Depths of the cuboid layers [m].
    initial_stress : ndarray or None
        Initial residual stress of the layers (nz, 6) [Pa], or None.
    inclusion : EquivalentInclusion or None
        The body's elastic inhomogeneities, or None.
    subcells : SubcellContact or None
        The contact on sub-cells of the surface cells (``solver.contact_subcells`` > 1), or
        None to solve it on the surface cells.
    """

    def __init__(self, operators: Operators, geometry: LoadGeometry, material: Material,
                 settings: SolverSettings, depth: np.ndarray,
                 initial_stress: np.ndarray | None,
                 inclusion: EquivalentInclusion | None = None,
                 subcells: SubcellContact | None = None) -> None:
        self.operators = operators
        self.geometry = geometry
        self.subcells = subcells
        self.inclusion = inclusion if inclusion is not None and inclusion.active else None
        # the fixed point runs for a plastic body, or for the equivalent eigenstrain
        self.plastic = material.plastic or self.inclusion is not None
        self.settings = settings
        self.initial_stress = initial_stress
        self.fixed_point = PlasticFixedPoint(operators, material, settings, depth, inclusion)

    def with_initial_stress(self, stress: np.ndarray) -> np.ndarray:
        """``stress`` plus the initial stress of a chained case, if any (in place)."""
        if self.initial_stress is not None:
            stress += self.initial_stress
        return stress

    def load_stress(self, pressure: np.ndarray, window: tuple[slice, slice],
                    subcell_pressure: np.ndarray | None = None) -> np.ndarray:
        """Stress not from this run's plastic strain: pressure (sub-cells' too) + initial [Pa]."""
        return self.with_initial_stress(
            self.operators.pressure_stress(pressure, window, subcell_pressure))

    def solve(self, step: int, plan: StepPlan, body: BodyState, history: ContactHistory,
              fixed_gap_displacement: np.ndarray | None) -> Increment:
        """Solve one increment (the fixed point of the module docstring).

        ``history`` is updated (the last contact pressure, the first contact's offset);
        ``body`` is not (the caller commits the increment). ``fixed_gap_displacement`` is the
        residual displacement the contact sees when this run's own is left out of the gap.
        """
        sl = self.geometry.window_slices(plan.position)
        geometry = self.geometry.window_gap(plan.position, sl)
        if history.first_contact_offset is None:
            # first contact: the lowest point of the initial gap (cell centres or load point)
            at_load = self.geometry.initial_gap(plan.position,
                                                *np.array(plan.position)[:, None])[0]
            history.first_contact_offset = float(min(geometry.min(), at_load))
        geometry = geometry - history.first_contact_offset
        fine = None if self.subcells is None else (
            self.subcells.window_gap(plan.position, sl) - history.first_contact_offset)
        contact_iterations = 0
        fixed = fixed_gap_displacement
        fixed_result: ContactResult | None = None

        def solve(u_r: np.ndarray) -> ContactResult:
            nonlocal contact_iterations, fixed_result
            if fixed is not None:
                if fixed_result is not None:  # the gap does not change within the increment
                    return fixed_result
                u_r = fixed
            result = self._contact(geometry, fine, u_r, sl, plan.load, step, history.pressure)
            contact_iterations += result.iterations
            history.pressure = result.pressure
            if fixed is not None:
                fixed_result = result
            return result

        if not self.plastic:
            result = solve(body.residual_displacement)
            return Increment(sl, geometry, result, None, contact_iterations, 0)
        start = (self.start_stress(body, history)
                 if self.settings.return_integration == "extrapolated" else None)
        fields = None
        inclusion = self.inclusion
        if inclusion is not None:
            inclusion.iterations = 0
        total = None
        if self.settings.scheme == "coupled":
            result, update, fields, change, total = self.coupled(
                solve, sl, step, body, fixed is None, start)
        else:
            result, update, change = self.nested(solve, sl, step, body, start)
        plastic_strain, eps_star, iterations = update.plastic_strain, None, 0
        if inclusion is not None:  # the iterate's ε* out of the plastic strain increment
            eps_star = plastic_strain[inclusion.cells]
            plastic_strain = plastic_strain.copy()
            own = update.inclusion_plastic_strain  # Δεp there, with own hardening
            if own is None:
                plastic_strain[inclusion.cells] = 0.0
            else:
                eps_star -= own
                plastic_strain[inclusion.cells] = own
            iterations = inclusion.iterations
        return Increment(sl, geometry, result,
                         (plastic_strain, update.equivalent_plastic_strain),
                         contact_iterations, update.applications, fields, update.residual, change,
                         update.backstress, eps_star, iterations, total)

    def eigenstrain(self, body: BodyState) -> np.ndarray:
        """Return the body's eigenstrain: its plastic strain, plus ε* in the inhomogeneities."""
        if self.inclusion is None:
            return body.plastic_strain
        return self.inclusion.total(body.plastic_strain, body.equivalent_eigenstrain)

    def start(self, body: BodyState) -> np.ndarray:
        """Return the fixed point's first iterate: zero, the last ε* in the inhomogeneities."""
        x = np.zeros(body.plastic_strain.shape)  # a moved copy of the last increment: worse
        if self.inclusion is not None and body.equivalent_eigenstrain is not None:
            x[self.inclusion.cells] = body.equivalent_eigenstrain
        return x

    def start_stress(self, body: BodyState, history: ContactHistory) -> np.ndarray | None:
        """Converged stress σ_n [Pa] at the start of the increment, (n1, n2, nz, 6).

        The stress of the last converged contact pressure at its window, the residual stress of
        the plastic strain and the initial stress: where the increment's trial path starts
        (kept from the last increment when its fixed point made it, computed otherwise).
        None when that stress is zero (a first increment from rest): the straight path from
        zero is radial, which one backward-Euler step integrates exactly.
        """
        if history.converged_stress is not None:
            return history.converged_stress
        if history.converged is None:
            if self.initial_stress is None and not body.residual_stress.any():
                return None
            return self.with_initial_stress(body.residual_stress.copy())
        (pressure, window), fine = history.converged, history.converged_subcells
        stress = np.ascontiguousarray(self.load_stress(pressure, window, fine))  # per point
        stress += body.residual_stress
        return stress

    def _contact(self, geometry: np.ndarray, fine: np.ndarray | None, u_r: np.ndarray,
                 sl: tuple[slice, slice], load: float, step: int,
                 pressure: np.ndarray | None) -> ContactResult:
        """Solve the contact on the window's gap: ``geometry`` (the sub-cells' ``fine``) + u_r."""
        opts, cell = self.settings, self.operators.cell
        if self.subcells is not None and fine is not None:
            return self.subcells.solve(
                fine + self.subcells.displacement(u_r, sl), load, pressure,
                tol=opts.contact_tolerance, max_iter=opts.contact_max_iterations, step=step)
        return solve_contact(
            geometry + u_r[sl], self.operators.compliance, cell[0] * cell[1], load=load,
            initial_pressure=pressure, tol=opts.contact_tolerance,
            max_iter=opts.contact_max_iterations, step=step,
        )

    def coupled(
        self, solve: ContactSolve, sl: tuple[slice, slice], step: int, body: BodyState,
        pressure_follows: bool, start_stress: np.ndarray | None = None,
    ) -> tuple[ContactResult, PlasticUpdate, tuple[np.ndarray, np.ndarray], float,
               np.ndarray | None]:
        """Plastic strain increment as one fixed point, the contact solved at every evaluation.

        ``G(x) = R(σ^pr(p(x)) + σ^r(εp_old + x) + 2μ x)`` with ``p(x)`` the contact pressure on
        the gap updated by ``u3^r(εp_old + x)`` (module docstring); residual stress and residual
        displacement share one forward transform, the contact is warm-started. Converged when
        the relative plastic residual is below ``plasticity_tolerance`` and the residual
        displacement moved by less than ``coupling_tolerance`` (relative to its change over the
        increment, or to the residual displacement already there when that is larger) between
        the last two evaluations. The increment returned is that last
        iterate ``x`` (not ``G(x)``, which differs from it by less than the tolerance): the
        residual fields of ``εp_old + x`` are then those of the last evaluation, and the step
        needs no further application. ``pressure_follows`` says whether the contact pressure
        depends on the iterate (the residual displacement is in the gap). Returns the contact,
        the plastic update, the residual stress and displacement of ``εp_old + x``, the
        final coupling change and the whole stress of the last evaluation.
        """
        opts, ops = self.settings, self.operators
        u_old = body.residual_displacement
        u_floor = max(float(np.abs(u_old).max()), TINY)  # a hold step moves u by round-off
        last = CouplingTrace()
        from sacflow.solver.vector_passes import summed  # compiled (numba): plastic runs only
        # Without friction the eigenstrain operator adds the contact pressure's stress in the
        # transforms of the residual stress (its traction correction applies Love's stresses of
        # a surface pressure): one application per evaluation, no pressure-stress convolution.
        fused = ops.traction is None

        def sigma(x: np.ndarray) -> tuple[np.ndarray, int]:
            apps = 0 if not x.any() else 1  # the fields of εp_old are known: no application
            stress, u = body.residual_stress, u_old
            if apps and fused:
                traction, surface_u = ops.eigenstrain.surface_fields(summed(body.plastic_strain,
                                                                           x))
                u = np.asarray(surface_u)
            elif apps:
                stress, u = ops.residual_fields(body.plastic_strain + x)
            result = solve(u)
            if last.displacement is not None:
                scale = max(float(np.abs(u - u_old).max()), u_floor)
                last.change = float(np.abs(u - last.displacement).max()) / scale
            last.displacement, last.contact = u, result
            if apps and fused:
                pressure = np.zeros(ops.body_shape)
                pressure[sl] = result.pressure
                total = ops.fused_stress(traction, pressure, result.subcell_pressure, sl)
                # the residual stress alone, if this is the last evaluation: made at the end
                last.stress, last.pressure = total, pressure
                last.total = total if self.initial_stress is None else total + self.initial_stress
                return last.total, apps  # ``total`` stays without the initial stress
            last.stress, last.pressure = stress, None
            last.total = self.load_stress(result.pressure, sl, result.subcell_pressure) + stress
            return last.total, apps

        def converged(res: float) -> bool:
            return res < opts.plasticity_tolerance and last.change < opts.coupling_tolerance

        x = self.start(body)
        try:
            update = self.fixed_point.solve(
                sigma, x, step, converged, "plasticity", self._state(body), coupled=True,
                pressure_follows=pressure_follows, start_stress=start_stress)
        except ConvergenceError as exc:
            if exc.what == "plasticity" and exc.residual < opts.plasticity_tolerance:
                # the plastic strain converged, the residual displacement still moved
                raise ConvergenceError("coupling", step=step, residual=last.change,
                                       tolerance=opts.coupling_tolerance,
                                       iterations=exc.iterations) from None
            raise
        coupling = 0.0 if not np.isfinite(last.change) else last.change
        stress, u, result = last.stress, last.displacement, last.contact
        assert stress is not None and u is not None and result is not None
        if last.pressure is not None:  # fused: take the contact pressure's stress out again
            stress = ops.without_pressure_stress(stress, last.pressure, result.subcell_pressure, sl)
        return result, update, (stress, u), coupling, last.total

    def nested(self, solve: ContactSolve, sl: tuple[slice, slice], step: int,
               body: BodyState, start_stress: np.ndarray | None = None,
               ) -> tuple[ContactResult, PlasticUpdate, float]:
        """Run the seed's nested loops (Fig. 5): contact ↔ plastic fixed point at fixed pressure.

        The outer loop runs on the residual displacement (Anderson-accelerated); each inner
        plastic solve is inexact (:data:`NESTED_FORCING` of the last coupling change, never
        looser than :data:`NESTED_INNER_TOLERANCE`) until the coupling has converged. Returns
        the contact, the plastic update (its applications summed over the outer loop) and the
        final coupling change.
        """
        opts, ops = self.settings, self.operators
        x = self.start(body)
        u_old = body.residual_displacement
        u_used: np.ndarray = u_old
        applications = 0
        u_floor = max(float(np.abs(u_old).max()), TINY)  # as in coupled
        mixer = AndersonMixer(opts.anderson_depth)  # on the residual displacement (the seed's)
        inner_tol = NESTED_INNER_TOLERANCE
        change = np.inf
        for _ in range(opts.coupling_max_iterations):
            result = solve(u_used)
            sig_pr = self.load_stress(result.pressure, sl, result.subcell_pressure)
            tol = max(inner_tol, opts.plasticity_tolerance)

            def sigma(x: np.ndarray, sig_pr: np.ndarray = sig_pr) -> tuple[np.ndarray, int]:
                return sig_pr + ops.residual_stress(body.plastic_strain + x), 1

            def within(res: float, tol: float = tol) -> bool:
                return res < tol

            update = self.fixed_point.solve(sigma, x, step, within, "plasticity",
                                            self._state(body), start_stress=start_stress)
            x, dp = update.plastic_strain, update.equivalent_plastic_strain
            applications += update.applications
            total = PlasticUpdate(x, dp, applications, update.residual, update.backstress,
                                  update.inclusion_plastic_strain)
            if not dp.any() and self.inclusion is None:
                return result, total, 0.0
            u_new = ops.eigenstrain.residual_displacement(body.plastic_strain + x)
            scale = max(float(np.abs(u_new - u_old).max()), u_floor)
            change = float(np.abs(u_new - u_used).max() / scale)
            log.debug("step %d coupling: residual displacement change %.3e", step, change)
            if change < opts.coupling_tolerance and inner_tol <= opts.plasticity_tolerance:
                return result, total, change
            inner_tol = (0.0 if change < opts.coupling_tolerance
                         else min(inner_tol, NESTED_FORCING * change))
            u_used = mixer.step(u_used.ravel(), u_new.ravel()).reshape(u_new.shape)
        raise ConvergenceError("coupling", step=step, residual=change,
                               tolerance=opts.coupling_tolerance,
                               iterations=opts.coupling_max_iterations)

    @staticmethod
    def _state(body: BodyState) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """Return the internal variables before the increment: εp, p and the backstress."""
        return body.plastic_strain, body.equivalent_plastic_strain, body.backstress
