"""The plastic strain increment of one increment as a fixed point (seed Fig. 4).

``x = G(x) = Δεp_return(σ(x) + 2μ x)``: ``σ(x)`` the elastic stress for the increment ``x``
(pressure stress plus residual stress of ``εp_old + x``), the return that of the body's
hardening (isotropic J2 radial return, or with a backstress). Solved by
:func:`sacflow.solver.nonlinear.solve_fixed_point`: sweeps accelerated by Anderson mixing and,
when they stall, semismooth Newton–Krylov with an analytic or a finite-difference Jacobian.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from sacflow.errors import ConvergenceError
from sacflow.mechanics.return_extrapolation import extrapolated_return
from sacflow.mechanics.return_mapping import ReturnResult, return_map
from sacflow.mechanics.return_tangent import ReturnTangent
from sacflow.solver.inputs import Material, SolverSettings
from sacflow.solver.nonlinear import (
    Evaluation,
    FixedPointError,
    difference_jacobian,
    solve_fixed_point,
)
from sacflow.solver.operators import Operators

if TYPE_CHECKING:
    from scipy.sparse.linalg import LinearOperator

    from sacflow.solver.inclusion import EquivalentInclusion

__all__ = ["FD_STEP", "TINY", "PlasticFixedPoint", "PlasticUpdate"]

#: Smallest scale of a relative residual (guards the division when everything is zero).
TINY = 1e-300
#: Relative step of the finite-difference Jacobian of the coupled fixed point
#: (:meth:`PlasticFixedPoint.solve`): ε = FD_STEP · max|x| / max|v|. Well above the noise of a
#: contact solve converged to 1e-10 (which then perturbs J v by about 1e-4 of its size, below
#: the loosest GMRES forcing term used, 1e-1 ... 1e-4 of the residual), well below the plastic
#: increments' own variation.
FD_STEP = 1e-6

#: The elastic stress of an increment ``x`` and the residual-stress applications it took.
StressOf = Callable[[np.ndarray], tuple[np.ndarray, int]]


@dataclass(frozen=True)
class PlasticUpdate:
    """A converged plastic fixed point.

    ``plastic_strain`` Δεp and ``equivalent_plastic_strain`` Δp are the increments; the
    residual-stress ``applications`` it took, its final relative ``residual`` and, with
    kinematic hardening, the updated ``backstress``. With inhomogeneities ``plastic_strain``
    holds ``Δεp + ε*`` in the cells of their equivalent eigenstrain, and
    ``inclusion_plastic_strain`` the Δεp (m, 6) of those cells when some inhomogeneity has a
    hardening law of its own (None: all elastic, Δεp = 0 there).
    """

    plastic_strain: np.ndarray
    equivalent_plastic_strain: np.ndarray
    applications: int
    residual: float
    backstress: np.ndarray | None
    inclusion_plastic_strain: np.ndarray | None = None


class PlasticFixedPoint:
    """The plastic fixed point of an increment, for the body's material and operators.

    Parameters
    ----------
    operators : Operators
        The run's operators (the eigenstrain operator of the analytic Jacobian).
    material : Material
        Hardening law, kinematic law and shear modulus.
    settings : SolverSettings
        Plasticity tolerance, iteration limit and Anderson depth.
    depth : ndarray
        Depths of the cuboid layers [m] (depth-dependent laws).
    inclusion : EquivalentInclusion or None
        The body's inhomogeneities: no plastic flow of the body's law in their cells (their own
        law where they have one, :mod:`sacflow.solver.own_hardening`), and the iterate
        carries their equivalent eigenstrain there (:mod:`sacflow.solver.inclusion`).
    """

    def __init__(self, operators: Operators, material: Material, settings: SolverSettings,
                 depth: np.ndarray, inclusion: EquivalentInclusion | None = None) -> None:
        self.operators = operators
        self.inclusion = inclusion
        self.law = material.law
        self.kinematic = material.kinematic
        self.mu = material.shear_modulus
        self.settings = settings
        self.depth = depth

    def solve(
        self, sigma: StressOf, x: np.ndarray, step: int, converged: Callable[[float], bool],
        what: str, state: tuple[np.ndarray, np.ndarray, np.ndarray | None],
        coupled: bool = False, pressure_follows: bool | None = None,
        start_stress: np.ndarray | None = None,
    ) -> PlasticUpdate:
        """Solve ``x = G(x) = Δεp_return(σ(x) + 2μ x)`` from the start ``x`` (seed Fig. 4).

        ``sigma(x) -> (stress, applications)`` is the elastic stress for the increment ``x``;
        ``state`` the body's plastic strain, equivalent plastic strain and backstress before the
        increment; ``converged(res)`` decides on the relative residual
        ``max|G(x) − x| / max(|G(x)|, |x|, |εp_old|)`` (relative to the increment, or to the
        plastic strain already there when that is larger: a hold step, or a rolling step far
        from the load, changes the plastic strain by round-off).

        At a fixed pressure (the nested scheme) the Jacobian is ``I − T (A + 2μ)``, ``T`` the
        algorithmic tangent of the return and ``A`` the residual-stress operator, applied
        matrix-free. In the ``coupled`` scheme ``σ(x)`` re-solves the contact, so the pressure
        depends on ``x`` too; that Jacobian misses it, and where the contact reacts strongly to
        the residual displacement (large plastic zones) its Newton steps are no descent
        directions. There the Jacobian is a directional finite difference of ``G`` itself,
        ``J v = v − (G(x + εv) − G(x)) / ε`` (Jacobian-free Newton–Krylov: Knoll & Keyes,
        J. Comput. Phys. 193 (2004) 357; ε from :data:`FD_STEP`), at the cost of one
        evaluation (a residual-stress application and a warm-started contact solve) per
        product, as the analytic one costs one application. The increment returned is
        ``Δεp = G(x)`` or, ``coupled``, the converged iterate ``x`` itself (whose residual
        fields the last evaluation computed). ``pressure_follows`` (default: ``coupled``) says
        whether the pressure depends on ``x``; when the residual displacement is left out of
        the gap it does not, and the analytic Jacobian is exact in the coupled scheme too.

        ``start_stress`` is the converged stress σ_n at the start of the increment: given, and
        the settings' ``return_integration`` is ``"extrapolated"``, the return integrates the
        flow along the increment's straight trial path by step doubling
        (:func:`~sacflow.mechanics.return_extrapolation.extrapolated_return`, second order in
        the increment); otherwise by one backward-Euler step. The analytic Jacobian is then the
        one-step return's tangent at the extrapolated increments: an approximation of the
        map's, which Newton–Krylov allows (its steps are checked on ``G`` itself).

        With elastic inhomogeneities the return is masked in their cells and ``G`` there is the
        Krylov-corrected equivalent eigenstrain of the evaluated stress
        (:meth:`~sacflow.solver.inclusion.EquivalentInclusion.update`): the fixed point solves
        the plastic increment and Eshelby's equivalence together (the Jacobian is then always
        the finite-difference one). An inhomogeneity with a hardening law of its own returns
        with it and its own shear modulus, and ``G`` there is ``Δεp + ε*``
        (:mod:`sacflow.solver.own_hardening`; finite-difference Jacobian too).

        Raises
        ------
        ConvergenceError
            When the fixed point does not converge within the plasticity iteration limit.
        """
        from scipy.sparse.linalg import LinearOperator  # plastic runs only

        follows = coupled if pressure_follows is None else pressure_follows
        inclusion = self.inclusion
        follows = follows or (inclusion is not None and (inclusion.active
                                                         or inclusion.own is not None))
        plastic_strain, equivalent, backstress = state
        mu, shape, n = self.mu, x.shape, x.size
        applications = 0
        # The plastic strain already there bounds the scale from below: a hold step's increment
        # is round-off, and measured against itself it never converges.
        strain_scale = max(float(np.abs(plastic_strain).max()), TINY)
        from sacflow.solver.vector_passes import (  # compiled (numba): plastic runs only
            largest_magnitudes,
            trial_stress,
        )

        def evaluate(x: np.ndarray) -> Evaluation:
            nonlocal applications
            stress, apps = sigma(x)
            applications += apps
            trial = trial_stress(x, stress, 2.0 * mu)  # σ + 2μx
            ret, full = self._return(trial, equivalent, backstress, start_stress)
            gx = ret.plastic_strain_increment
            own = None
            if inclusion is not None:
                own = self._inclusion_part(ret, full, (x, stress, trial), step,
                                           (equivalent, backstress), start_stress)
            largest_x, largest_gx, largest_change = largest_magnitudes(x, gx)
            scale = max(largest_gx, largest_x, strain_scale)
            return Evaluation(gx, largest_change / scale, (trial, full, ret, own))

        def jacobian(x: np.ndarray, ev: Evaluation) -> LinearOperator:
            """``I − T (A + 2μ)``: ``T`` the return's algorithmic tangent, ``A`` residual stress."""
            if follows:
                operator: LinearOperator = difference_jacobian(
                    evaluate, x, ev, FD_STEP, max(float(np.abs(x).max()), strain_scale))
                return operator
            trial, full = ev.data[:2]
            tangent = self._tangent(trial, full, equivalent, backstress)

            def matvec(v: np.ndarray) -> np.ndarray:
                nonlocal applications
                applications += 1
                v = v.reshape(shape)
                residual = self.operators.residual_stress(v)
                response = tangent.apply(residual + 2.0 * mu * v)
                if inclusion is not None:
                    response[inclusion.elastic] = 0.0
                product: np.ndarray = (v - response).ravel()
                return product

            return LinearOperator((n, n), matvec=matvec, dtype=float)

        def accept(x: np.ndarray, ev: Evaluation) -> bool:
            if converged(ev.residual):
                return True
            elastic = not ev.data[1].plastic.any() and not x.any()
            return elastic and (inclusion is None or not inclusion.active)

        opts = self.settings
        try:
            out = solve_fixed_point(
                evaluate, x, accept, max_iterations=opts.plasticity_max_iterations,
                anderson_depth=opts.anderson_depth, jacobian=jacobian,
                label=f"step {step} {what}",
            )
        except FixedPointError as exc:
            raise ConvergenceError(what, step=step, residual=exc.residual,
                                   tolerance=opts.plasticity_tolerance,
                                   iterations=exc.iterations) from None
        ret, own = out.evaluation.data[2:]
        dx = out.x if coupled else ret.plastic_strain_increment
        return PlasticUpdate(dx, ret.equivalent_plastic_strain_increment, applications,
                             out.evaluation.residual, ret.backstress, own)

    def _inclusion_part(self, ret: ReturnResult, full: ReturnResult,
                        fields: tuple[np.ndarray, np.ndarray, np.ndarray], step: int,
                        state: tuple[np.ndarray, np.ndarray | None],
                        start_stress: np.ndarray | None) -> np.ndarray | None:
        """``G`` in the inhomogeneities' cells, in ``ret`` (in place); their Δεp if they harden.

        ``fields`` are the iterate ``x``, its stress σ and the trial stress ``σ + 2μ x``;
        ``state`` p and X before the increment. The body's return is masked there; those with
        a law of their own return with it (:mod:`sacflow.solver.own_hardening`); where they
        carry ε*, ``G`` is the Krylov-corrected ε* (plus their own Δεp, returned as (m, 6):
        None without own hardening).
        """
        inclusion = self.inclusion
        assert inclusion is not None
        x, stress, trial = fields
        self._mask(ret, state[1])
        if full is not ret:
            self._mask(full, state[1])
        own = inclusion.own
        if own is not None:
            extrapolated = self.settings.return_integration == "extrapolated"
            own.apply(ret, x, stress, trial, state, start_stress if extrapolated else None)
        if not inclusion.active:
            return None
        cells, gx = inclusion.cells, ret.plastic_strain_increment
        if own is None:
            gx[cells] = inclusion.update(x[cells], stress[cells], step)
            return None
        plastic: np.ndarray = gx[cells]  # Δεp of the ε* cells (zero where elastic): a copy
        gx[cells] = plastic + inclusion.update(x[cells] - plastic, stress[cells], step)
        return plastic

    def _mask(self, ret: ReturnResult, backstress: np.ndarray | None) -> None:
        """No plastic flow in the cells of the elastic inhomogeneities (in place)."""
        assert self.inclusion is not None
        elastic = self.inclusion.elastic
        ret.plastic_strain_increment[elastic] = 0.0
        ret.equivalent_plastic_strain_increment[elastic] = 0.0
        ret.plastic[elastic] = False
        if ret.backstress is not None and backstress is not None:
            ret.backstress[elastic] = backstress[elastic]

    def _return(self, trial: np.ndarray, equivalent: np.ndarray, backstress: np.ndarray | None,
                start_stress: np.ndarray | None) -> tuple[ReturnResult, ReturnResult]:
        """Return-map the trial stress with the body's law: isotropic, or with the backstress.

        Returns the return the fixed point uses (step-doubled from ``start_stress`` when the
        settings ask for it) and the one the Jacobian's tangent is built on: the one-step
        backward-Euler return, or with step doubling the same result (the tangent of one step
        at the extrapolated increments).
        """
        if self.kinematic is None:
            full = return_map(trial, equivalent, self.law, self.mu, self.depth,
                              with_stress=False)  # the increments are what it needs
        else:
            full = return_map(trial, equivalent, self.law, self.mu, self.depth,
                              kinematic=self.kinematic, backstress=backstress)
        if start_stress is None or self.settings.return_integration != "extrapolated":
            return full, full
        ret = extrapolated_return(start_stress, trial, equivalent, self.law, self.mu,
                                  self.depth, kinematic=self.kinematic, backstress=backstress,
                                  full=full)  # in place of the one-step increments
        return ret, ret

    def _tangent(self, trial: np.ndarray, ret: ReturnResult, equivalent: np.ndarray,
                 backstress: np.ndarray | None) -> ReturnTangent:
        """Return the derivative of the return w.r.t. the trial stress (Newton–Krylov)."""
        return ReturnTangent(trial, ret, equivalent, self.law, self.mu, self.depth,
                             kinematic=self.kinematic, backstress=backstress)
