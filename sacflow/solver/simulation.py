"""Incremental elastic-plastic contact solver (seed §1.6–1.7, Figs. 4–5). No I/O, no xarray.

A :class:`Simulation` lays a run out (:mod:`sacflow.solver.layout`), builds its operators once
(:mod:`sacflow.solver.operators`) and drives the load path: one increment at a time
(:mod:`sacflow.solver.increment`), cut into halves when it does not converge, its plastic update
committed to the body's state (:mod:`sacflow.solver.body`), each made a
:class:`~sacflow.solver.state.State` (:mod:`sacflow.solver.step_state`).

Load paths: ``load`` / ``unload`` segments change the normal load in equal increments, ``hold``
repeats it; ``roll`` moves the load over the body-fixed grid (the plastic strain,
hardening and residual fields stay with the body; the curvature term of the gap moves with the
load, dents and measured surfaces stay with the body: :mod:`sacflow.solver.geometry`).
"""

from __future__ import annotations

import logging
import math
import warnings
from collections.abc import Iterator, Mapping
from dataclasses import replace

import numpy as np

from sacflow.errors import BoxTooShallowError, ConvergenceError, SacflowError
from sacflow.machine.threads import single_threaded_blas
from sacflow.mechanics.initial_state import check_initial_yield, map_state
from sacflow.solver.body import BodyState, ContactHistory
from sacflow.solver.geometry import LoadGeometry
from sacflow.solver.inclusion import EquivalentInclusion, inclusion_for
from sacflow.solver.increment import Increment, IncrementSolver
from sacflow.solver.inputs import SolverInputs
from sacflow.solver.layout import StepPlan, body_grid, halfway, layer_centres
from sacflow.solver.operators import Operators
from sacflow.solver.state import GridCoords, State
from sacflow.solver.step_state import StateBuilder
from sacflow.solver.subcell_contact import subcell_contact

__all__ = ["MAX_CUTBACKS", "Simulation"]

log = logging.getLogger(__name__)

#: Factor by which a too shallow cuboid box is deepened (see Simulation._check_box), and the
#: fewest layers it adds.
GROWTH = 1.5
GROWTH_MIN_LAYERS = 2
#: Times an increment that does not converge is cut in two and solved again (Simulation.run):
#: at most 2**MAX_CUTBACKS sub-increments per stored step.
MAX_CUTBACKS = 3


class Simulation:
    """Solver inputs turned into grids and operators, run increment by increment.

    Parameters
    ----------
    inputs : SolverInputs
        Everything the run needs (:func:`sacflow.config.solver_inputs.simulation_for` makes the
        simulation of a case).

    Attributes
    ----------
    coords : GridCoords
        Body-fixed cell centres (x1, x2 surface; x3 cuboid layers).
    total_steps : int
        Number of increments of the load path.
    body : BodyState
        The body's plastic state and residual fields after the last increment.
    inclusion : EquivalentInclusion or None
        The phase field and the equivalent-eigenstrain solver of the body's elastic
        inhomogeneities (:mod:`sacflow.solver.inclusion`), None without any.
    """

    def __init__(self, inputs: SolverInputs) -> None:
        self.inputs = inputs
        material, spec = inputs.material, inputs.grid
        self.hertz = inputs.contact.hertz
        self.steps = list(inputs.steps)
        self.total_steps = len(self.steps)
        self.multi_pass = any(s.pass_index > 0 for s in self.steps)
        # Body grid: the contact window swept along the rolled track.
        grid = body_grid(spec.window, spec.cell, spec.nz, self.steps)
        nx, ny = grid.window
        self.body_shape = grid.body
        dx1, dx2 = spec.cell
        x1 = (np.arange(self.body_shape[0]) - grid.origin[0] - nx / 2 + 0.5) * dx1
        x2 = (np.arange(self.body_shape[1]) - grid.origin[1] - ny / 2 + 0.5) * dx2
        self.nz = spec.nz
        self.dz = spec.depth / self.nz
        self.coords = GridCoords(x1, x2, layer_centres(self.nz, self.dz))
        self.geometry = LoadGeometry(inputs.contact, self.coords, spec.cell, grid.window,
                                     grid.origin)
        with single_threaded_blas():
            self.inclusion: EquivalentInclusion | None = inclusion_for(inputs, self.coords)
        eigenstrains = material.plastic or (self.inclusion is not None and self.inclusion.active)
        with single_threaded_blas():  # the kernels' set-up: see sacflow.machine.threads
            self.operators = Operators(
                grid.window, self.body_shape, spec.cell, self.nz, self.dz, material.E,
                material.nu, inputs.contact.e_star, inputs.contact.traction, eigenstrains,
                inputs.settings.fft_threads, inputs.settings.stress_sampling,
                inputs.settings.surface_correction == "quadrature",
                inputs.settings.traction_beyond_box, inputs.settings.contact_subcells)
        initial = inputs.initial
        self.increments = IncrementSolver(
            self.operators, self.geometry, material, inputs.settings, self.coords.x3,
            initial.stress, self.inclusion, subcell_contact(self.geometry, inputs))
        self.states = StateBuilder(inputs, self.coords, self.increments)
        self.body = self._initial_body()
        self.history = ContactHistory()
        # the residual displacement the contact sees when this run's own is left out of the gap
        self.fixed_gap_displacement = (None if inputs.settings.residual_displacement_in_gap
                                       else self.body.residual_displacement.copy())

    def _initial_body(self) -> BodyState:
        """Return the body before the first increment: initial hardening, or a stored state.

        A stored state (chained cases) is mapped onto this grid; its residual stress and
        residual displacement are those of the mapped plastic strain on this grid (one operator
        application), as after a resume.
        """
        inputs, x3 = self.inputs, self.coords.x3
        initial = inputs.initial
        shape = (*self.body_shape, self.nz)
        if inputs.material.plastic and initial.stress is not None:
            check_initial_yield(inputs.material.law, initial.stress,
                                initial.equivalent_plastic_strain, x3)
        equivalent = np.broadcast_to(initial.equivalent_plastic_strain, shape).copy()
        kinematic = inputs.material.kinematic is not None
        body = BodyState(
            plastic_strain=np.zeros((*shape, 6)),
            equivalent_plastic_strain=equivalent,
            initial_equivalent_plastic_strain=initial.equivalent_plastic_strain,
            backstress=np.zeros((*shape, 6)) if kinematic else None,
            residual_stress=np.zeros((*shape, 6)),
            residual_displacement=np.zeros(self.body_shape),
        )
        if initial.stored is None:
            return body
        c = self.coords
        mapped = map_state(initial.stored, c.x1, c.x2, c.x3, initial.offset)
        body.plastic_strain = mapped.plastic_strain
        body.equivalent_plastic_strain = mapped.equivalent_plastic_strain
        if body.backstress is not None and mapped.backstress is not None:
            body.backstress = mapped.backstress  # else zero: the source had no kinematic law
        body.initial_equivalent_plastic_strain = body.equivalent_plastic_strain.copy()
        if body.plastic_strain.any():
            with single_threaded_blas():
                body.residual_stress, body.residual_displacement = (
                    self.operators.residual_fields(body.plastic_strain))
        return body

    # ------------------------------------------------------------------ the body's state
    @property
    def plastic_strain(self) -> np.ndarray:
        """Plastic strain tensor εp on the body grid, (n1, n2, nz, 6)."""
        return self.body.plastic_strain

    @property
    def equivalent_plastic_strain(self) -> np.ndarray:
        """Equivalent plastic strain p on the body grid, (n1, n2, nz)."""
        return self.body.equivalent_plastic_strain

    @property
    def residual_stress(self) -> np.ndarray:
        """Residual stress of εp [Pa], (n1, n2, nz, 6) (without a chained case's initial one)."""
        return self.body.residual_stress

    @property
    def residual_displacement(self) -> np.ndarray:
        """Residual normal surface displacement of εp [m], (n1, n2)."""
        return self.body.residual_displacement

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
        for step, plan in enumerate(self.steps[start:], start):
            with single_threaded_blas():  # lifted while the caller holds the state
                state = self._advance(step, plan)
            yield state

    def restore(
        self, step: int, restart: Mapping[str, np.ndarray], first_contact_offset: float | None
    ) -> None:
        """Take the state stored with step ``step`` to go on with ``run(start=step + 1)``.

        ``restart`` holds the arrays of :data:`~sacflow.solver.state.RESTART_FIELDS` on the body
        grid and ``first_contact_offset`` the origin of the approach, as :meth:`run` put them
        in that step's :class:`~sacflow.solver.state.State`. The residual stress is recomputed
        from the plastic strain (one operator application); the contact pressure of the step
        becomes the warm start of the next contact solve, as in an uninterrupted run (on
        sub-cells, whose pressure is not stored, the step's contact is solved on them again).

        Raises
        ------
        SacflowError
            When the arrays do not fit this run's grid (the stored run is of another grid).
        """
        tensor = (*self.body_shape, self.nz, 6)
        arrays = _restart_arrays(restart, tensor)
        body = self.body
        body.plastic_strain = arrays["plastic_strain"]
        body.equivalent_plastic_strain = arrays["equivalent_plastic_strain"]
        if body.backstress is not None:
            stored = restart.get("backstress")
            if stored is None:
                raise SacflowError("the stored steps hold no backstress, which this case's "
                                   "kinematic hardening needs: run with --restart")
            body.backstress = np.asarray(stored, dtype=float).reshape(tensor).copy()
        body.residual_displacement = arrays["residual_displacement"]
        if (inclusion := self.increments.inclusion) is not None:  # ε* (zero: re-solved)
            body.equivalent_eigenstrain = inclusion.restored(restart.get("equivalent_eigenstrain"))
        eigenstrain = self.increments.eigenstrain(body)
        if self.operators.eigen is not None and eigenstrain.any():
            with single_threaded_blas():
                body.residual_stress = self.operators.residual_stress(eigenstrain)
        else:
            body.residual_stress = np.zeros_like(body.plastic_strain)
        plan = self.steps[step]
        slices = self.geometry.window_slices(plan.position)
        window = arrays["pressure"][slices]
        self.history.pressure = window.copy() if plan.load > 0.0 and window.any() else None
        self.history.remember(window.copy(), slices, plan.load)
        self.history.first_contact_offset = first_contact_offset
        if (subcells := self.increments.subcells) is not None:  # their pressure is not stored
            self.history.converged_subcells = subcells.restored_pressure(
                plan, self.history, body.residual_displacement, self.increments.settings, step)

    def solve_increment(self, step: int, plan: StepPlan) -> Increment:
        """Solve the increment to ``plan`` from the body's state (not committed).

        The fault-injection seam of the cutback tests: replaced by one that raises
        :class:`~sacflow.errors.ConvergenceError`, it makes :meth:`run` cut back.
        """
        return self.increments.solve(step, plan, self.body, self.history,
                                     self.fixed_gap_displacement)

    def _advance(self, step: int, plan: StepPlan) -> State:
        """Solve increment ``step`` of the load path and return its state."""
        start = self.steps[step - 1] if step > 0 else replace(plan, load=0.0)
        inc, substeps = self._solve_cutting_back(step, start, plan, 0)
        output = self.inputs.output
        every = output.volume_every
        volume = {}
        pass_end = plan.pass_end and self.multi_pass  # repeated rolling: every pass's end
        if step % every == every - 1 or step == self.total_steps - 1 or pass_end:
            volume = self.states.volume_fields(self.body, inc.contact, inc.window)
        elif output.every_step:  # these at every step, the others every k
            volume = self.states.volume_fields(self.body, inc.contact, inc.window,
                                               output.every_step)
        return self.states.state(step, plan, inc, self.body, self.history.first_contact_offset,
                                 volume, substeps)

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
        history = self.history
        saved = (None if history.pressure is None else history.pressure.copy(),
                 history.first_contact_offset)
        try:
            return self._solve_and_commit(step, end), 1
        except ConvergenceError as exc:
            if level >= MAX_CUTBACKS:
                raise
            history.pressure, history.first_contact_offset = saved  # as before the attempt
            log.info("step %d: %s; cutting the increment in two (level %d)", step, exc, level + 1)
        middle = halfway(start, end)
        first, n_first = self._solve_cutting_back(step, start, middle, level + 1)
        last, n_last = self._solve_cutting_back(step, middle, end, level + 1)
        merged = replace(
            last,
            contact_iterations=first.contact_iterations + last.contact_iterations,
            plasticity_iterations=first.plasticity_iterations + last.plasticity_iterations,
            inclusion_iterations=first.inclusion_iterations + last.inclusion_iterations,
        )
        return merged, n_first + n_last

    def _solve_and_commit(self, step: int, plan: StepPlan) -> Increment:
        """Solve the increment to ``plan`` and take its plastic update into the body's state."""
        if plan.load <= 0.0:
            self.history.pressure = None
        inc = self.solve_increment(step, plan)
        self.history.remember(inc.contact.pressure, inc.window, plan.load, inc.stress,
                              inc.contact.subcell_pressure)
        body = self.body
        plastic = inc.update is not None and inc.update[0].any()
        if plastic:
            assert inc.update is not None
            deps, dp = inc.update
            body.plastic_strain += deps
            body.equivalent_plastic_strain += dp
            if body.backstress is not None and inc.backstress is not None:
                body.backstress = inc.backstress
        eps_star = inc.equivalent_eigenstrain
        if eps_star is not None:
            body.equivalent_eigenstrain = eps_star
        if plastic or eps_star is not None:
            # residual fields of the converged εp (+ ε*): known from the last evaluation
            if inc.residual_fields is not None:
                body.residual_stress, body.residual_displacement = inc.residual_fields
            else:
                body.residual_stress, body.residual_displacement = (
                    self.operators.residual_fields(self.increments.eigenstrain(body)))
        if plastic:
            self._check_box(step)
        return inc

    def _check_box(self, step: int) -> None:
        """Stop when plastic strain reaches the bottom of the box; warn when it reaches a side.

        Raises
        ------
        BoxTooShallowError
            With a depth :data:`GROWTH` times larger (same layer thickness): the runner grows
            the box and runs the case again. The sides cannot grow (they are the contact
            window).
        """
        body = self.body
        # flowed in this run (the initial hardening aside)
        plastic = body.equivalent_plastic_strain > body.initial_equivalent_plastic_strain
        if plastic[..., -1].any():
            new_nz = max(self.nz + GROWTH_MIN_LAYERS, math.ceil(GROWTH * self.nz))
            raise BoxTooShallowError(step, self.nz * self.dz, self.nz, new_nz * self.dz, new_nz)
        if plastic[[0, -1]].any() or plastic[:, [0, -1]].any():
            warnings.warn(
                f"step {step}: plastic strain reached the side of the grid; "
                "increase grid.half_width", RuntimeWarning, stacklevel=2,
            )


def _restart_arrays(restart: Mapping[str, np.ndarray], tensor: tuple[int, ...]
                    ) -> dict[str, np.ndarray]:
    """Return copies of the stored state's arrays, checked against the run's ``tensor`` shape.

    The plastic strain (n1, n2, nz, 6), the equivalent plastic strain (n1, n2, nz), and the
    residual displacement and contact pressure on the body's surface (n1, n2).
    """
    shapes = {
        "plastic_strain": tensor,
        "equivalent_plastic_strain": tensor[:3],
        "residual_displacement": tensor[:2],
        "pressure": tensor[:2],
    }
    return {name: _stored(restart, name, shape) for name, shape in shapes.items()}


def _stored(restart: Mapping[str, np.ndarray], name: str,
            shape: tuple[int, ...]) -> np.ndarray:
    """Return a copy of the stored array ``name``, checked to be of the run's grid ``shape``."""
    array = np.asarray(restart[name], dtype=float)
    if array.shape != shape:
        raise SacflowError(
            f"stored state {name!r} has shape {array.shape}, this case's grid needs "
            f"{shape}: the stored steps are of another grid; run with --restart"
        )
    return array.copy()
