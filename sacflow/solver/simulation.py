"""Incremental elastic-plastic contact solver (seed §1.6–1.7, Figs. 4–5). No I/O, no xarray.

Per load increment the solver finds the plastic strain increment ``Δεp`` that is a fixed point of

    Δεp = R( σ^pr(p) + σ^r(εp_old + Δεp) + 2μ Δεp ),
    p   = elastic contact on the gap  h_geometry + u3^r(εp_old + Δεp),

where ``R`` is the fully implicit J2 return mapping
(:func:`sacflow.mechanics.return_mapping.return_map`),
``σ^pr`` the stress of the contact pressure, ``σ^r`` the residual stress and ``u3^r`` the
residual surface displacement of the plastic strain (:mod:`sacflow.kernels.eigenstrain`). The
seed nests two loops (contact ↔ plastic strain); here both are one fixed point
(:mod:`sacflow.solver.nonlinear`: Anderson mixing, semismooth Newton when it stalls), the contact
being
re-solved (warm-started) at every evaluation (``solver.scheme = "nested"`` runs the seed's two
loops instead; both converge to the same increment, the single loop with fewer residual-stress
applications: ``benchmarks/elastic_plastic.py`` prints both counts). At convergence the seed's
two criteria hold: the plastic strain increment and the residual displacement increment have
stopped changing, and von Mises = σ_Y on plastic points.

Load paths: ``load`` / ``unload`` segments change the normal load in equal increments, ``hold``
repeats it; ``roll`` moves the load over the body-fixed grid (the plastic strain,
hardening and residual fields stay with the body; the curvature term of the gap moves with the
load, dents and measured surfaces stay with the body). Load positions are exact (a roll step may
be a fraction of a cell): the gap is evaluated at the exact position, only the contact window is
placed on the nearest whole cell of the body grid.
"""

from __future__ import annotations

import logging
import math
import warnings
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from sacflow.config.hardening_laws import hardening_from_schema, kinematic_from_schema
from sacflow.errors import BoxTooShallowError, ConvergenceError, SacflowError
from sacflow.kernels.convolution import Convolution
from sacflow.kernels.shear import surface_load_stress_coefficients
from sacflow.kernels.surface import rectangle_displacement
from sacflow.machine.threads import single_threaded_blas
from sacflow.mechanics.contact import ContactResult, solve_contact
from sacflow.mechanics.hardening import NoPlasticity
from sacflow.mechanics.initial_state import (
    StoredState,
    check_initial_yield,
    initial_equivalent_plastic_strain,
    initial_stress,
    map_state,
)
from sacflow.mechanics.return_mapping import return_map
from sacflow.mechanics.return_tangent import ReturnTangent
from sacflow.mechanics.stress_measures import von_mises
from sacflow.mechanics.surface_gap import curvature_gap, features_gap
from sacflow.solver.anderson import AndersonMixer
from sacflow.solver.layout import StepPlan, auto_depth, body_grid, plan_steps
from sacflow.solver.nonlinear import (
    Evaluation,
    FixedPointError,
    difference_jacobian,
    solve_fixed_point,
)
from sacflow.solver.state import VOLUME_FIELDS, GridCoords, MeasuredSurface, State

if TYPE_CHECKING:
    from sacflow.kernels.eigenstrain import HalfSpaceEigenstrain

__all__ = ["Simulation", "StepPlan", "plan_steps"]  # the last two re-exported from layout

log = logging.getLogger(__name__)

#: Factor by which a too shallow cuboid box is deepened (see Simulation._check_box).
_GROWTH = 1.5
#: Smallest scale of a relative residual (guards the division when everything is zero).
_TINY = 1e-300
#: Version of the pressure-to-stress kernels in the disk cache: bump it when their code changes.
CONTACT_STRESS_VERSION = 1
#: Relative step of the finite-difference Jacobian of the coupled fixed point (see
#: Simulation._fixed_point): ε = FD_STEP · max|x| / max|v|. Well above the noise of a contact
#: solve converged to 1e-10 (which then perturbs J v by about 1e-4 of its size, below the
#: loosest GMRES forcing term used, 1e-1 ... 1e-4 of the residual), well below the plastic
#: increments' own variation.
FD_STEP = 1e-6
#: Times an increment that does not converge is cut in two and solved again (Simulation.run):
#: at most 2**MAX_CUTBACKS sub-increments per stored step.
MAX_CUTBACKS = 3


@dataclass(frozen=True)
class Increment:
    """A converged increment.

    Window slices, its initial gap, the contact solution, the plastic update ``(Δεp, Δp)``
    (None when elastic), iteration counts, the final residuals of the plasticity and coupling
    loops (0 when elastic) and, when the solver already has them, the residual stress and
    surface displacement of ``εp_old + Δεp``.
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


def _largest_magnitude(a: np.ndarray) -> float:
    """``max |a|`` without a box-size temporary (NaN if ``a`` holds one, as ``np.abs(a).max()``)."""
    return float(np.maximum(a.max(), -a.min()))


class Simulation:
    """A case turned into grids and operators, run increment by increment.

    Parameters
    ----------
    case : Case
        The validated case.
    surface : MeasuredSurface, optional
        The heights of a measured surface (``surface.kind = "measured"``), as arrays: read them
        with :func:`sacflow.storage.run_file.load_surface`. Other surfaces need nothing.

    Attributes
    ----------
    coords : GridCoords
        Body-fixed cell centres (x1, x2 surface; x3 cuboid layers).
    total_steps : int
        Number of increments of the load path.
    """

    def __init__(self, case, surface: MeasuredSurface | None = None,
                 initial: StoredState | None = None):
        self.case = case
        body = case.body
        self.law = hardening_from_schema(body.hardening)
        self.plastic = not isinstance(self.law, NoPlasticity)
        self.kinematic = kinematic_from_schema(body.hardening) if self.plastic else None
        self.E, self.nu = float(body.E), float(body.nu)
        self.mu = self.E / (2.0 * (1.0 + self.nu))
        self.e_star = case.contact_modulus()
        self.radii = case.effective_radii()
        hertz = case.hertz()
        self.hertz = hertz
        # Shear traction q = μ p d (schema Friction): the traction per unit pressure, or None
        # when there is none (μ = 0 included: the run is then the frictionless one, bit for bit).
        friction = case.friction
        self.traction: tuple[float, float] | None = None
        if friction is not None and friction.coefficient > 0.0:
            self.traction = (friction.coefficient * friction.direction[0],
                             friction.coefficient * friction.direction[1])
        self.cell = case.cell_size()
        self.steps = plan_steps(case.load_path)
        self.total_steps = len(self.steps)
        self.multi_pass = any(s.pass_index > 0 for s in self.steps)
        # Body grid: the contact window swept along the rolled track.
        grid = body_grid(case, self.steps)
        nx, ny = self.window = grid.window
        self.body_shape = grid.body
        self._origin_cells = np.array(grid.origin)  # window corner when the load is at 0
        dx1, dx2 = self.cell
        x1 = (np.arange(self.body_shape[0]) - grid.origin[0] - nx / 2 + 0.5) * dx1
        x2 = (np.arange(self.body_shape[1]) - grid.origin[1] - ny / 2 + 0.5) * dx2
        law = None if isinstance(self.law, NoPlasticity) else self.law
        depth = case.grid.depth or auto_depth(case, law, hertz.a, hertz.p0)
        self.nz = case.grid.nz
        self.dz = depth / self.nz
        x3 = (np.arange(self.nz) + 0.5) * self.dz
        self.coords = GridCoords(x1, x2, x3)
        self.threads = case.solver.fft_threads
        self._heights = _measured_heights(case, surface)
        with single_threaded_blas():  # the kernels' set-up: see sacflow.machine.threads
            self._build_operators()
        shape = (*self.body_shape, self.nz)
        self.plastic_strain = np.zeros((*shape, 6))
        # Initial state (schema: body.initial_residual_stress, body.initial_hardening).
        self._initial_stress = initial_stress(body.initial_residual_stress, x3)
        self._eqps0 = initial_equivalent_plastic_strain(body.initial_hardening, x3)
        if self.plastic and self._initial_stress is not None:
            check_initial_yield(self.law, self._initial_stress, self._eqps0, x3)
        self.eqps = np.broadcast_to(self._eqps0, shape).copy()
        # backstress X (kinematic hardening only): an internal variable like εp
        self.backstress = None if self.kinematic is None else np.zeros((*shape, 6))
        self._last_backstress: np.ndarray | None = None
        self.residual_displacement = np.zeros(self.body_shape)
        self.residual_stress = np.zeros((*shape, 6))
        self.source: StoredState | None = None
        if case.initial_state is not None:
            self._start_from(case.initial_state, initial)
        self._pressure: np.ndarray | None = None
        self._h_offset: float | None = None
        # the residual displacement the contact sees when this run's own is left out of the gap
        self._fixed_gap_displacement = (
            None if case.solver.residual_displacement_in_gap
            else self.residual_displacement.copy()
        )

    def _start_from(self, spec, stored: StoredState | None) -> None:
        """Take the plastic state of a stored run (``initial_state``), mapped onto this grid.

        The residual stress and residual displacement are those of the mapped plastic strain on
        this grid (one operator application), as after a resume.
        """
        if stored is None:
            raise SacflowError(
                "initial_state: the stored state is needed: build the simulation with "
                "Simulation(case, initial=sacflow.storage.initial_state_file."
                "read_initial_state(case)), "
                "or use sacflow.run"
            )
        c = self.coords
        mapped = map_state(stored, c.x1, c.x2, c.x3, spec.offset)
        self.plastic_strain, self.eqps = mapped.plastic_strain, mapped.equivalent_plastic_strain
        if self.backstress is not None and mapped.backstress is not None:
            self.backstress = mapped.backstress  # else zero: the source had no kinematic law
        self._eqps0 = self.eqps.copy()
        self.source = stored
        if self.plastic_strain.any():
            with single_threaded_blas():
                self.residual_stress, self.residual_displacement = self._eigen.residual_stress(
                    self.plastic_strain, with_displacement=True)

    # ------------------------------------------------------------------ operators
    def _build_operators(self) -> None:
        """Kernel spectra for the window and the cuboid box (built once, reused every step)."""
        dx1, dx2 = self.cell
        h1, h2 = dx1 / 2, dx2 / 2
        e_star, nu, window = self.e_star, self.nu, self.window

        def love(d1, d2):
            return (rectangle_displacement(d1 * dx1, d2 * dx2, h1, h2) / (np.pi * e_star))[
                None, None
            ]

        self.compliance = Convolution(love, window, window, threads=self.threads)
        z = (np.arange(self.nz) + 0.5) * self.dz

        stresses = surface_load_stress_coefficients(self.cell, z, nu, self.traction)

        # Pressure (embedded in the body grid at the window's place) -> stress on the body grid:
        # one operator serves every load position. With a shear traction q = μ p d its kernel
        # adds the traction's stress per unit pressure: the same one convolution.
        self.pressure_stress_op = Convolution(
            stresses, self.body_shape, self.body_shape, threads=self.threads,
            block=6,  # one depth layer (six components) per inverse transform
            cache=("contact_stress", self._contact_stress_parameters()),
        )
        self.eigen: HalfSpaceEigenstrain | None = None
        if self.plastic:  # elastic runs do without it (and without numba)
            from sacflow.kernels.eigenstrain import HalfSpaceEigenstrain

            self.eigen = HalfSpaceEigenstrain(
                (*self.body_shape, self.nz), (dx1, dx2, self.dz), self.E, self.nu,
                threads=self.threads,
            )

    def _contact_stress_parameters(self) -> dict[str, Any]:
        """Everything the pressure-to-stress kernels depend on (their disk-cache key).

        Love's rectangles at the layer centres (cells, layer thickness, layers, ν) and, with
        friction, the traction per unit pressure; ``shape`` (body grid and layers) is what
        ``sacflow cache`` lists; the operator adds its own grid shapes.
        """
        traction = self.traction
        return {
            "version": CONTACT_STRESS_VERSION, "shape": [*self.body_shape, int(self.nz)],
            "cell": [float(c) for c in self.cell],
            "dz": float(self.dz), "nz": int(self.nz), "nu": float(self.nu),
            "traction": None if traction is None else [float(t) for t in traction],
        }

    @property
    def _eigen(self) -> HalfSpaceEigenstrain:
        """The eigenstrain operator (plastic bodies only)."""
        if self.eigen is None:
            raise RuntimeError("an elastic body has no eigenstrain operator")
        return self.eigen

    def _pressure_stress(self, pressure: np.ndarray, sl) -> np.ndarray:
        """Stress [Pa] on the body grid, (nbx, nby, nz, 6), of the window pressure at ``sl``."""
        embedded = np.zeros(self.body_shape)
        embedded[sl] = pressure
        return self._pressure_stress_op_apply(embedded)

    def _pressure_stress_op_apply(self, pressure: np.ndarray) -> np.ndarray:
        """Stress [Pa] (nbx, nby, nz, 6) of a pressure given on the whole body grid."""
        out = self.pressure_stress_op(pressure[None])  # (6 nz, nbx, nby)
        out = out.reshape(self.nz, 6, *self.body_shape)
        return np.moveaxis(out, (0, 1), (2, 3))

    def _load_stress(self, pressure: np.ndarray, sl) -> np.ndarray:
        """Stress that does not come from this run's plastic strain: pressure + initial [Pa]."""
        return self._with_initial_stress(self._pressure_stress(pressure, sl))

    def _with_initial_stress(self, stress: np.ndarray) -> np.ndarray:
        """``stress`` plus the initial stress of a chained case, if any (in place)."""
        if self._initial_stress is not None:
            stress += self._initial_stress
        return stress

    # ------------------------------------------------------------------ geometry
    def _window_slices(self, position: tuple[float, float]) -> tuple[slice, slice]:
        """Slices of the body grid covered by the contact window centred on ``position``."""
        c = np.rint(np.array(position) / np.array(self.cell)).astype(int) + self._origin_cells
        return (slice(int(c[0]), int(c[0]) + self.window[0]),
                slice(int(c[1]), int(c[1]) + self.window[1]))

    def _initial_gap(self, position: tuple[float, float], x1, x2) -> np.ndarray:
        """Return the initial gap at body-frame points: curvature about the load, features."""
        dents = getattr(self.case.surface, "dents", ())
        h = curvature_gap(x1, x2, position[0], position[1], self.radii)
        return h + features_gap(x1, x2, dents, self._heights)

    def _geometry(self, position: tuple[float, float], sl) -> np.ndarray:
        """Return the initial gap on the contact window ``sl``."""
        return self._initial_gap(
            position, self.coords.x1[sl[0]][:, None], self.coords.x2[sl[1]][None, :]
        )

    # ------------------------------------------------------------------ one increment
    def _contact(self, h: np.ndarray, load: float, step: int) -> ContactResult:
        opts = self.case.solver
        return solve_contact(
            h, self.compliance, self.cell[0] * self.cell[1], load=load,
            initial_pressure=self._pressure, tol=opts.contact_tolerance,
            max_iter=opts.contact_max_iterations, step=step,
        )

    def _increment(self, step: int, plan: StepPlan) -> Increment:
        """Solve one increment (the fixed point of the module docstring)."""
        opts = self.case.solver
        sl = self._window_slices(plan.position)
        geometry = self._geometry(plan.position, sl)
        if self._h_offset is None:
            # first contact: the lowest point of the initial gap (cell centres or load point)
            at_load = self._initial_gap(plan.position, *np.array(plan.position)[:, None])[0]
            self._h_offset = float(min(geometry.min(), at_load))
        geometry = geometry - self._h_offset
        contact_iterations = 0

        fixed = self._fixed_gap_displacement
        fixed_result: ContactResult | None = None

        def solve(u_r: np.ndarray) -> ContactResult:
            nonlocal contact_iterations, fixed_result
            if fixed is not None:
                if fixed_result is not None:  # the gap does not change within the increment
                    return fixed_result
                u_r = fixed
            result = self._contact(geometry + u_r[sl], plan.load, step)
            contact_iterations += result.iterations
            self._pressure = result.pressure
            if fixed is not None:
                fixed_result = result
            return result

        if not self.plastic:
            result = solve(self.residual_displacement)
            return Increment(sl, geometry, result, None, contact_iterations, 0)
        fields = None
        if opts.scheme == "coupled":
            result, update, applications, fields, residuals = self._coupled(solve, sl, step)
        else:
            result, update, applications, residuals = self._nested(solve, sl, step)
        return Increment(sl, geometry, result, update, contact_iterations, applications, fields,
                         *residuals)

    def _coupled(self, solve, sl, step: int):
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
        needs no further application. Returns ``(contact, (Δεp, Δp), residual-stress
        applications, (residual stress, residual displacement), (plastic residual, coupling
        residual))``.
        """
        opts = self.case.solver
        u_old = self.residual_displacement
        u_floor = max(float(np.abs(u_old).max()), _TINY)  # a hold step moves u by round-off
        last: dict[str, Any] = {"u": None, "result": None, "du": np.inf}

        # Without friction the eigenstrain operator adds the contact pressure's stress in the
        # transforms of the residual stress (its traction correction applies Love's stresses of
        # a surface pressure): one application per evaluation, no pressure-stress convolution.
        fused = self.traction is None

        def sigma(x):
            apps = 0 if not x.any() else 1  # the fields of εp_old are known: no application
            stress, u = self.residual_stress, u_old
            if apps and fused:
                traction, surface_u = self._eigen.surface_fields(self.plastic_strain + x)
                u = np.asarray(surface_u)
            elif apps:
                stress, u = self._eigen.residual_stress(self.plastic_strain + x,
                                                        with_displacement=True)
            result = solve(u)
            if last["u"] is not None:
                scale = max(float(np.abs(u - u_old).max()), u_floor)
                last["du"] = float(np.abs(u - last["u"]).max()) / scale
            last["u"], last["result"] = u, result
            if apps and fused:
                pressure = np.zeros(self.body_shape)
                pressure[sl] = result.pressure
                total = self._eigen.stress(traction, pressure)
                # the residual stress alone, if this is the last evaluation: made at the end
                last["fields"] = (total, u, pressure)
                return self._with_initial_stress(total), apps
            last["fields"] = (stress, u, None)
            return self._load_stress(result.pressure, sl) + stress, apps

        def converged(res: float) -> bool:
            return res < opts.plasticity_tolerance and last["du"] < opts.coupling_tolerance

        x = np.zeros(self.plastic_strain.shape)  # a moved copy of the last increment: worse
        try:
            dx, dp, applications, res = self._fixed_point(
                sigma, x, step, converged, "plasticity", coupled=True,
                pressure_follows=self._fixed_gap_displacement is None)
        except ConvergenceError as exc:
            if exc.residual < opts.plasticity_tolerance:  # the residual displacement still moved
                raise ConvergenceError("coupling", step=step, residual=last["du"],
                                       tolerance=opts.coupling_tolerance,
                                       iterations=exc.iterations) from None
            raise
        coupling = 0.0 if not np.isfinite(last["du"]) else last["du"]
        stress, u, pressure = last["fields"]
        if pressure is not None:  # fused: take the contact pressure's stress out again
            stress = stress - self._pressure_stress_op_apply(pressure)
        return last["result"], (dx, dp), applications, (stress, u), (res, coupling)

    def _nested(self, solve, sl, step: int):
        """Run the seed's nested loops (Fig. 5): contact ↔ plastic fixed point at fixed pressure.

        The outer loop runs on the residual displacement (Anderson-accelerated); each inner
        plastic solve is inexact (a tenth of the last coupling change, never looser than 1e-2)
        until the coupling has converged. Returns ``(contact, (Δεp, Δp), residual-stress
        applications, (plastic residual, coupling residual))``.
        """
        opts = self.case.solver
        x = np.zeros(self.plastic_strain.shape)
        u_old = self.residual_displacement
        u_used: np.ndarray = u_old
        applications = 0
        u_floor = max(float(np.abs(u_old).max()), _TINY)  # as in _coupled
        depth = opts.anderson_depth if opts.acceleration == "anderson" else 0
        mixer = AndersonMixer(depth)  # on the residual displacement (the seed's loop variable)
        inner_tol = 1e-2
        change = np.inf
        for _ in range(opts.coupling_max_iterations):
            result = solve(u_used)
            sig_pr = self._load_stress(result.pressure, sl)
            tol = max(inner_tol, opts.plasticity_tolerance)

            def sigma(x, sig_pr=sig_pr):
                return sig_pr + self._eigen.residual_stress(self.plastic_strain + x), 1

            x, dp, n_apps, res = self._fixed_point(
                sigma, x, step, lambda res, tol=tol: res < tol, "plasticity")
            applications += n_apps
            if not dp.any():
                return result, (x, dp), applications, (res, 0.0)
            u_new = self._eigen.residual_displacement(self.plastic_strain + x)
            scale = max(float(np.abs(u_new - u_old).max()), u_floor)
            change = float(np.abs(u_new - u_used).max() / scale)
            log.debug("step %d coupling: residual displacement change %.3e", step, change)
            if change < opts.coupling_tolerance and inner_tol <= opts.plasticity_tolerance:
                return result, (x, dp), applications, (res, change)
            inner_tol = 0.0 if change < opts.coupling_tolerance else min(inner_tol, 0.1 * change)
            u_used = mixer.step(u_used.ravel(), u_new.ravel()).reshape(u_new.shape)
        raise ConvergenceError("coupling", step=step, residual=change,
                               tolerance=opts.coupling_tolerance,
                               iterations=opts.coupling_max_iterations)

    def _fixed_point(
        self, sigma, x: np.ndarray, step: int, converged, what: str, coupled: bool = False,
        pressure_follows: bool | None = None,
    ):
        """Plastic strain increment ``x = G(x) = Δεp_return(σ(x) + 2μ x)`` (seed Fig. 4).

        ``sigma(x) -> (stress, applications)`` is the elastic stress for the increment ``x``
        (pressure stress plus residual stress of ``εp_old + x``); ``converged(res)`` decides on
        the relative residual ``max|G(x) − x| / max(|G(x)|, |x|, |εp_old|)`` (relative to the
        increment, or to the plastic strain already there when that is larger: a hold step, or a
        rolling step far from the load, changes the plastic strain by round-off). Solved by
        :func:`sacflow.solver.nonlinear.solve_fixed_point`: sweeps accelerated by Anderson mixing
        (plain sweeps without acceleration) and, when they stall, semismooth Newton–Krylov.

        At a fixed pressure (the nested scheme) the Jacobian is ``I − T (A + 2μ)``, ``T`` the
        algorithmic tangent of the return and ``A`` the residual-stress operator, applied
        matrix-free. In the ``coupled`` scheme ``σ(x)`` re-solves the contact, so the pressure
        depends on ``x`` too; that Jacobian misses it, and where the contact reacts strongly to
        the residual displacement (large plastic zones) its Newton steps are no descent
        directions. There the Jacobian is a directional finite difference of ``G`` itself,
        ``J v = v − (G(x + εv) − G(x)) / ε`` (Jacobian-free Newton–Krylov: Knoll & Keyes,
        J. Comput. Phys. 193 (2004) 357; ε from :data:`FD_STEP`), at the cost of one
        evaluation (a residual-stress application and a warm-started contact solve) per
        product, as the analytic one costs one application. Returns ``(Δεp, Δp,
        residual-stress applications, final residual)`` with ``Δεp = G(x)``, or, ``coupled``,
        the converged iterate ``x`` itself (whose residual fields the last evaluation computed).
        ``pressure_follows`` (default: ``coupled``) says whether the pressure depends on ``x``;
        when the residual displacement is left out of the gap it does not, and the analytic
        Jacobian is exact in the coupled scheme too.
        """
        from scipy.sparse.linalg import LinearOperator  # plastic runs only

        follows = coupled if pressure_follows is None else pressure_follows

        opts = self.case.solver
        depth, mu, eqps = self.coords.x3, self.mu, self.eqps
        shape = x.shape
        n = x.size
        applications = 0
        # The plastic strain already there bounds the scale from below: a hold step's increment
        # is round-off, and measured against itself it never converges.
        strain_scale = max(float(np.abs(self.plastic_strain).max()), _TINY)

        def evaluate(x: np.ndarray) -> Evaluation:
            nonlocal applications
            stress, apps = sigma(x)
            applications += apps
            trial = np.multiply(x, 2.0 * mu)  # σ + 2μx: box-size arrays, one temporary
            trial += stress
            ret = self._return(trial, eqps, depth)
            gx = ret.plastic_strain_increment
            scale = max(_largest_magnitude(gx), _largest_magnitude(x), strain_scale)
            return Evaluation(gx, _largest_magnitude(gx - x) / scale, (trial, ret))

        def jacobian(x: np.ndarray, ev: Evaluation) -> LinearOperator:
            """``I − T (A + 2μ)``: ``T`` the return's algorithmic tangent, ``A`` residual stress."""
            if follows:
                return difference_jacobian(evaluate, x, ev, FD_STEP,
                                           max(float(np.abs(x).max()), strain_scale))
            trial, ret = ev.data
            tangent = self._tangent(trial, ret, eqps, depth)

            def matvec(v: np.ndarray) -> np.ndarray:
                nonlocal applications
                applications += 1
                v = v.reshape(shape)
                return (v - tangent.apply(self._eigen.residual_stress(v) + 2.0 * mu * v)).ravel()

            return LinearOperator((n, n), matvec=matvec, dtype=float)

        def accept(x: np.ndarray, ev: Evaluation) -> bool:
            return converged(ev.residual) or (not ev.data[1].plastic.any() and not x.any())

        depth_anderson = opts.anderson_depth if opts.acceleration == "anderson" else 0
        try:
            out = solve_fixed_point(
                evaluate, x, accept, max_iterations=opts.plasticity_max_iterations,
                anderson_depth=depth_anderson, jacobian=jacobian, label=f"step {step} {what}",
            )
        except FixedPointError as exc:
            raise ConvergenceError(what, step=step, residual=exc.residual,
                                   tolerance=opts.plasticity_tolerance,
                                   iterations=exc.iterations) from None
        ret = out.evaluation.data[1]
        self._last_backstress = getattr(ret, "backstress", None)
        dx = out.x if coupled else ret.plastic_strain_increment
        return dx, ret.equivalent_plastic_strain_increment, applications, out.evaluation.residual

    def _return(self, trial: np.ndarray, eqps: np.ndarray, depth: np.ndarray):
        """Return-map the trial stress with the body's law: isotropic, or with the backstress."""
        if self.kinematic is None:
            return return_map(trial, eqps, self.law, self.mu, depth=depth,
                              with_stress=False)  # the increments are what it needs
        return return_map(trial, eqps, self.law, self.mu, depth=depth, kinematic=self.kinematic,
                          backstress=self.backstress)

    def _tangent(self, trial: np.ndarray, ret, eqps: np.ndarray, depth: np.ndarray):
        """Return the derivative of the return w.r.t. the trial stress (Newton–Krylov)."""
        return ReturnTangent(trial, ret, eqps, self.law, self.mu, depth,
                             kinematic=self.kinematic, backstress=self.backstress)

    # ------------------------------------------------------------------ driver
    def run(self, start: int = 0) -> Iterator[State]:
        """Yield one :class:`~sacflow.solver.state.State` per increment of the load path.

        Parameters
        ----------
        start : int
            First increment to solve; the state after increment ``start - 1`` must have been
            given to :meth:`restore` (true resume of an interrupted run).

        Raises
        ------
        ConvergenceError
            When an increment does not converge even cut into ``2**MAX_CUTBACKS``
            sub-increments (the states already yielded stay valid).
        """
        every = self.case.output.volume_every
        for step, plan in enumerate(self.steps[start:], start):
            with single_threaded_blas():  # lifted while the caller holds the state
                state = self._advance(step, plan, every)
            yield state

    def restore(
        self, step: int, restart: Mapping[str, np.ndarray], first_contact_offset: float | None
    ) -> None:
        """Take the state stored with step ``step`` to go on with ``run(start=step + 1)``.

        ``restart`` holds the arrays of :data:`~sacflow.solver.state.RESTART_FIELDS` on the body
        grid
        and ``first_contact_offset`` the origin of the approach, as :meth:`run` put them in that
        step's :class:`~sacflow.solver.state.State`. The residual stress is recomputed from the
        plastic
        strain (one operator application); the contact pressure of the step becomes the warm
        start of the next contact solve, as in an uninterrupted run.

        Raises
        ------
        SacflowError
            When the arrays do not fit this case's grid (the stored run is of another grid).
        """
        shapes = {
            "plastic_strain": (*self.body_shape, self.nz, 6),
            "equivalent_plastic_strain": (*self.body_shape, self.nz),
            "residual_displacement": self.body_shape,
            "pressure": self.body_shape,
        }
        arrays = {}
        for name, shape in shapes.items():
            array = np.asarray(restart[name], dtype=float)
            if array.shape != shape:
                raise SacflowError(
                    f"stored state {name!r} has shape {array.shape}, this case's grid needs "
                    f"{shape}: the stored steps are of another grid; run with --restart"
                )
            arrays[name] = array.copy()
        self.plastic_strain = arrays["plastic_strain"]
        self.eqps = arrays["equivalent_plastic_strain"]
        if self.backstress is not None:
            stored = restart.get("backstress")
            if stored is None:
                raise SacflowError("the stored steps hold no backstress, which this case's "
                                   "kinematic hardening needs: run with --restart")
            self.backstress = np.asarray(stored, dtype=float).reshape(
                (*self.body_shape, self.nz, 6)).copy()
        self.residual_displacement = arrays["residual_displacement"]
        if self.eigen is not None and self.plastic_strain.any():
            with single_threaded_blas():
                self.residual_stress = self._eigen.residual_stress(self.plastic_strain)
        else:
            self.residual_stress = np.zeros_like(self.plastic_strain)
        plan = self.steps[step]
        window = arrays["pressure"][self._window_slices(plan.position)]
        self._pressure = window.copy() if plan.load > 0.0 and window.any() else None
        self._h_offset = first_contact_offset

    def _advance(self, step: int, plan: StepPlan, every: int) -> State:
        """Solve increment ``step`` of the load path and return its state."""
        start = self.steps[step - 1] if step > 0 else replace(plan, load=0.0)
        inc, substeps = self._solve_cutting_back(step, start, plan, 0)
        volume = {}
        pass_end = plan.pass_end and self.multi_pass  # repeated rolling: every pass's end
        if step % every == every - 1 or step == self.total_steps - 1 or pass_end:
            volume = self._volume_fields(inc.contact, inc.window)
        elif self.case.output.every_step:  # these at every step, the others every k
            volume = self._volume_fields(inc.contact, inc.window, self.case.output.every_step)
        return self._state(step, plan, inc, volume, substeps)

    def _solve_cutting_back(
        self, step: int, start: StepPlan, end: StepPlan, level: int
    ) -> tuple[Increment, int]:
        """Go from ``start`` to ``end``; when that does not converge, in two halves, and so on.

        Automatic cutback, as finite-element codes do it: an increment whose fixed point does not
        converge (a large change of the plastic zone or of the contact in one step, typically an
        elastic-perfectly plastic body far above its shakedown limit) is solved again as two
        half increments (load and, while loaded, position halfway), each of them cut again if
        needed, up to :data:`MAX_CUTBACKS` times. The state stored is the one at ``end``, as
        without cutback; the step records how many sub-increments it took. Returns the last
        sub-increment (iteration counts summed over all) and their number.
        """
        saved = (None if self._pressure is None else self._pressure.copy(), self._h_offset)
        try:
            return self._solve_and_commit(step, end), 1
        except ConvergenceError as exc:
            if level >= MAX_CUTBACKS:
                raise
            self._pressure, self._h_offset = saved  # as before the failed attempt
            log.info("step %d: %s; cutting the increment in two (level %d)", step, exc, level + 1)
        middle = _halfway(start, end)
        first, n_first = self._solve_cutting_back(step, start, middle, level + 1)
        last, n_last = self._solve_cutting_back(step, middle, end, level + 1)
        merged = replace(
            last,
            contact_iterations=first.contact_iterations + last.contact_iterations,
            plasticity_iterations=first.plasticity_iterations + last.plasticity_iterations,
        )
        return merged, n_first + n_last

    def _solve_and_commit(self, step: int, plan: StepPlan) -> Increment:
        """Solve the increment to ``plan`` and take its plastic update into the body's state."""
        if plan.load <= 0.0:
            self._pressure = None
        inc = self._increment(step, plan)
        if inc.update is not None and inc.update[0].any():
            deps, dp = inc.update
            self.plastic_strain += deps
            self.eqps += dp
            if self.kinematic is not None and self._last_backstress is not None:
                self.backstress = self._last_backstress
            # residual fields of the converged plastic strain (known from the last evaluation)
            if inc.residual_fields is not None:
                self.residual_stress, self.residual_displacement = inc.residual_fields
            else:
                self.residual_stress, self.residual_displacement = self._eigen.residual_stress(
                    self.plastic_strain, with_displacement=True)
            self._check_box(step)
        return inc

    def _check_box(self, step: int) -> None:
        """Stop when plastic strain reaches the bottom of the box; warn when it reaches a side.

        Raises
        ------
        BoxTooShallowError
            With a depth ``_GROWTH`` times larger (same layer thickness): the runner grows the
            box and runs the case again. The sides cannot grow (they are the contact window).
        """
        plastic = self.eqps > self._eqps0  # flowed in this run (the initial hardening aside)
        if plastic[..., -1].any():
            new_nz = max(self.nz + 2, math.ceil(_GROWTH * self.nz))
            raise BoxTooShallowError(step, self.nz * self.dz, self.nz, new_nz * self.dz, new_nz)
        if plastic[[0, -1]].any() or plastic[:, [0, -1]].any():
            warnings.warn(
                f"step {step}: plastic strain reached the side of the grid; "
                "increase grid.half_width", RuntimeWarning, stacklevel=2,
            )

    def _volume_fields(self, result: ContactResult, sl,
                       names: Sequence[str] | None = None) -> dict[str, np.ndarray]:
        """Volume fields of the state (all, or those in ``names``: only what they need)."""
        wanted = set(VOLUME_FIELDS if names is None else names)
        out: dict[str, np.ndarray] = {}
        if wanted & {"stress", "von_mises"}:
            stress = self._load_stress(result.pressure, sl) + self.residual_stress
            out["stress"] = stress
            out["von_mises"] = von_mises(stress)
        if "residual_stress" in wanted:
            residual = self.residual_stress.copy()
            if self._initial_stress is not None:
                residual += self._initial_stress
            out["residual_stress"] = residual
        if "yield_stress" in wanted:
            yield_stress = (self.law.yield_stress(self.eqps, self.coords.x3) if self.plastic
                            else np.full(self.eqps.shape, np.inf))
            out["yield_stress"] = np.asarray(yield_stress, dtype=float)
        out["plastic_strain"] = self.plastic_strain.copy()
        out["equivalent_plastic_strain"] = self.eqps.copy()
        if self.backstress is not None:
            out["backstress"] = self.backstress.copy()
        return {name: array for name, array in out.items() if name in wanted}

    def _shear_traction(self, pressure: np.ndarray) -> dict[str, np.ndarray]:
        """``{"shear_traction": μ p d}`` (nx1, nx2, 2) [Pa] with a ``[friction]`` table, else {}."""
        if self.case.friction is None:
            return {}
        t1, t2 = self.traction or (0.0, 0.0)
        return {"shear_traction": np.stack((t1 * pressure, t2 * pressure), axis=-1)}

    def _state(
        self, step: int, plan: StepPlan, inc: Increment, volume: dict, substeps: int = 1
    ) -> State:
        shape, sl, result, geometry = self.body_shape, inc.window, inc.contact, inc.geometry
        n_contact, n_plastic = inc.contact_iterations, inc.plasticity_iterations
        pressure = np.zeros(shape)
        pressure[sl] = result.pressure
        gap = np.full(shape, np.nan)
        gap[sl] = result.gap
        geom = np.full(shape, np.nan)
        geom[sl] = geometry
        elastic_share = self.e_star * (1.0 - self.nu**2) / self.E
        surface_displacement = self.residual_displacement.copy()
        surface_displacement[sl] += elastic_share * result.displacement
        cell_area = self.cell[0] * self.cell[1]
        opts = self.case.solver
        keep = np.copy if self.plastic else np.asarray  # an elastic body's zeros never change
        restart = {
            "plastic_strain": keep(self.plastic_strain),
            "equivalent_plastic_strain": keep(self.eqps),
            "residual_displacement": keep(self.residual_displacement),
            "pressure": pressure,
            **({} if self.backstress is None else {"backstress": self.backstress.copy()}),
        }
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
            contact_area=float(np.count_nonzero(result.pressure > 0) * cell_area),
            max_pressure=float(result.pressure.max(initial=0.0)),
            contact_iterations=int(n_contact),
            plasticity_iterations=int(n_plastic),
            converged=contact_ok and plastic_ok and coupling_ok,
            contact_converged=contact_ok,
            plasticity_converged=plastic_ok,
            coupling_converged=coupling_ok,
            contact_residual=float(result.error),
            plasticity_residual=float(inc.plasticity_residual),
            coupling_residual=float(inc.coupling_residual),
            restart=restart,
            first_contact_offset=self._h_offset,
            surface={
                "pressure": pressure,
                "gap": gap,
                "geometry": geom,
                "residual_displacement": self.residual_displacement.copy(),
                "surface_displacement": surface_displacement,
                **self._shear_traction(pressure),
            },
            volume=volume,
        )


def _halfway(start: StepPlan, end: StepPlan) -> StepPlan:
    """Return the plan halfway from ``start`` to ``end``.

    Half the load change; half the way while loaded at both ends (a roll), otherwise at
    ``end``'s position (a load or unload in place, or the ball put down at the start of a new
    pass after being lifted).
    """
    loaded = start.load > 0.0 and end.load > 0.0
    position = (
        (0.5 * (start.position[0] + end.position[0]), 0.5 * (start.position[1] + end.position[1]))
        if loaded else end.position
    )
    return replace(end, load=0.5 * (start.load + end.load), position=position, pass_end=False)


def _measured_heights(case, surface: MeasuredSurface | None):
    """Height function of a measured surface (linear interpolation), or None.

    The heights come as arrays (:func:`sacflow.storage.run_file.load_surface` reads the file): the
    numerical core does no I/O. Points outside the measured grid raise
    :class:`~sacflow.errors.SacflowError` naming the uncovered extent.
    """
    if getattr(case.surface, "kind", "smooth") != "measured":
        return None
    if surface is None:
        raise SacflowError(
            "surface: a measured surface needs its heights: build the simulation with "
            "Simulation(case, surface=sacflow.storage.run_file.load_surface(case)), "
            "or use sacflow.run"
        )
    from scipy.interpolate import RegularGridInterpolator

    data = surface
    interp = RegularGridInterpolator((data.x1, data.x2), data.height, bounds_error=False)

    def heights(x1: np.ndarray, x2: np.ndarray) -> np.ndarray:
        X1, X2 = np.broadcast_arrays(x1, x2)
        out = interp(np.stack([X1.ravel(), X2.ravel()], axis=-1)).reshape(X1.shape)
        if np.isnan(out).any():
            raise SacflowError(
                f"surface.path: the measured surface covers x1 in [{data.x1[0]:.4g}, "
                f"{data.x1[-1]:.4g}] m, x2 in [{data.x2[0]:.4g}, {data.x2[-1]:.4g}] m but the "
                f"grid needs x1 in [{X1.min():.4g}, {X1.max():.4g}], x2 in [{X2.min():.4g}, "
                f"{X2.max():.4g}] m: measure a larger area or shorten the track"
            )
        return out

    return heights
