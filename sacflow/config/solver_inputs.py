"""A validated case translated into the solver's plain inputs (:mod:`sacflow.solver.inputs`).

The solver layer takes floats, arrays, tuples and mechanics objects, never the case schema:
this module is the one place that reads a :class:`~sacflow.config.schema.Case` for it. It builds
the hardening law objects, the contact modulus, effective radii and Hertz estimate, the friction
traction, the cell size and the box depth (given, or sized on the Hertz field:
:func:`~sacflow.config.inclusion_checks.box_depth`), the expanded load path, the initial profiles
on the cuboid layers, the elastic inhomogeneities of the body; :func:`simulation_for` makes the
ready :class:`~sacflow.solver.simulation.Simulation` of a case, :func:`estimate_case_memory`
the memory estimate of its grid.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from sacflow.config.hardening_laws import hardening_from_schema, kinematic_from_schema
from sacflow.config.inclusion_checks import box_depth
from sacflow.config.schema import Case, Elastic, Hold, Load, Roll, Unload
from sacflow.errors import SacflowError
from sacflow.mechanics.initial_state import (
    StoredState,
    initial_equivalent_plastic_strain,
    initial_stress,
)
from sacflow.solver import layout
from sacflow.solver.inputs import (
    ContactSpec,
    Dent,
    GridSpec,
    Inhomogeneity,
    InitialConditions,
    Material,
    OutputPlan,
    SolverInputs,
    SolverSettings,
)
from sacflow.solver.layout import BodyGrid, StepPlan, layer_centres, plan_steps
from sacflow.solver.memory_estimate import MemoryEstimate, check_memory, estimate_memory
from sacflow.solver.state import MeasuredSurface

if TYPE_CHECKING:
    from sacflow.solver.simulation import Simulation

__all__ = [
    "case_body_grid",
    "case_steps",
    "check_case_memory",
    "estimate_case_memory",
    "inhomogeneities",
    "load_path_segments",
    "simulation_for",
    "solver_inputs",
]


#: The cell centres of each inhomogeneity of a case, in order: a (k, 3) array [m] for
#: ``shape = "cells"``, None for the other shapes.
CellPoints = Sequence[np.ndarray | None]


def simulation_for(case: Case, surface: MeasuredSurface | None = None,
                   initial: StoredState | None = None,
                   cells: CellPoints | None = None) -> Simulation:
    """Return the ready :class:`~sacflow.solver.simulation.Simulation` of ``case``.

    Parameters
    ----------
    case : Case
        The validated case.
    surface : MeasuredSurface, optional
        The heights of a measured surface (``surface.kind = "measured"``), as arrays: read them
        with :func:`sacflow.storage.surface_file.load_surface`. Other surfaces need nothing.
    initial : StoredState, optional
        The stored state a chained case starts from (``initial_state``): read it with
        :func:`sacflow.storage.initial_state_file.read_initial_state`.
    cells : sequence, optional
        The cell centres of the case's inhomogeneities of ``shape = "cells"`` (one entry per
        inhomogeneity, None for the other shapes): read them with
        :func:`sacflow.storage.inclusion_cells_file.read_inclusion_cells`.
    """
    from sacflow.solver.simulation import Simulation  # the solver's kernels load lazily

    return Simulation(solver_inputs(case, surface, initial, cells))


def solver_inputs(case: Case, surface: MeasuredSurface | None = None,
                  initial: StoredState | None = None,
                  cells: CellPoints | None = None) -> SolverInputs:
    """Translate ``case`` into the solver's inputs (arguments as for :func:`simulation_for`).

    Raises
    ------
    SacflowError
        When the case has a measured surface and no ``surface``, an initial state and no
        ``initial``, or an inhomogeneity of cells and no ``cells``.
    """
    body, opts = case.body, case.solver
    law = hardening_from_schema(body.hardening)
    plastic = _plastic(case)
    material = Material(float(body.E), float(body.nu), law,
                        kinematic_from_schema(body.hardening) if plastic else None)
    steps = tuple(case_steps(case))
    nz = case.grid.nz
    grid = GridSpec((case.grid.nx, case.grid.ny), case.cell_size(), nz, box_depth(case))
    x3 = layer_centres(nz, grid.layer_thickness)
    settings = SolverSettings(
        contact_tolerance=opts.contact_tolerance,
        contact_max_iterations=opts.contact_max_iterations,
        plasticity_tolerance=opts.plasticity_tolerance,
        plasticity_max_iterations=opts.plasticity_max_iterations,
        coupling_tolerance=opts.coupling_tolerance,
        coupling_max_iterations=opts.coupling_max_iterations,
        scheme=opts.scheme,
        anderson_depth=_anderson_depth(case),
        fft_threads=opts.fft_threads,
        residual_displacement_in_gap=opts.residual_displacement_in_gap,
        return_integration=opts.return_integration,
        inclusion_tolerance=opts.inclusion_tolerance,
        inclusion_max_iterations=opts.inclusion_max_iterations,
        stress_sampling=opts.stress_sampling,
        surface_correction=opts.surface_correction,
        traction_beyond_box=opts.traction_beyond_box,
        contact_subcells=opts.contact_subcells,
    )
    output = OutputPlan(case.output.volume_every, tuple(case.output.every_step))
    conditions = InitialConditions(
        initial_stress(body.initial_residual_stress, x3),
        initial_equivalent_plastic_strain(body.initial_hardening, x3),
        *_stored_state(case, initial),
    )
    return SolverInputs(material, grid, _contact(case, surface), settings, output, steps,
                        conditions, inhomogeneities(case, cells))


def inhomogeneities(case: Case, cells: CellPoints | None = None) -> tuple[Inhomogeneity, ...]:
    """Return the inhomogeneities of the body of ``case`` as the solver's (own hardening too).

    A sphere gets its radius as its three semi-axes, a cuboid its half-sides; an inhomogeneity
    of ``shape = "cells"`` takes its points from ``cells`` (its centre and
    semi-axes: the middle and the half-extent of their span along x1, x2, x3).

    Raises
    ------
    SacflowError
        When an inhomogeneity of cells has no points in ``cells``.
    """
    found = []
    for index, item in enumerate(case.body.inhomogeneity):
        E, nu = float(item.E), float(item.nu)
        own = item.hardening  # None: elastic
        law = None if own is None else hardening_from_schema(own)
        kinematic = None if own is None else kinematic_from_schema(own)
        if item.shape != "cells":
            assert item.centre is not None  # guaranteed by validation
            centre = (float(item.centre[0]), float(item.centre[1]), float(item.centre[2]))
            found.append(Inhomogeneity(item.shape, centre, item.semi_axes_m(), E, nu,
                                       law=law, kinematic=kinematic))
            continue
        points = None if cells is None or index >= len(cells) else cells[index]
        if points is None:
            raise SacflowError(
                f"body.inhomogeneity.{index}.cells: the cell centres are needed: build the "
                "simulation with simulation_for(case, cells=sacflow.storage."
                "inclusion_cells_file.read_inclusion_cells(case)), or use sacflow.run"
            )
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        low, high = points.min(axis=0), points.max(axis=0)
        mid, half = 0.5 * (low + high), 0.5 * (high - low)
        found.append(Inhomogeneity(
            "cells", (float(mid[0]), float(mid[1]), float(mid[2])),
            (float(half[0]), float(half[1]), float(half[2])), E, nu, points, law, kinematic))
    return tuple(found)


def _contact(case: Case, surface: MeasuredSurface | None) -> ContactSpec:
    """Return the contact of ``case``: E*, radii, Hertz, friction, the surface of body 1."""
    friction = case.friction
    traction = None  # μ = 0 included: the run is then the frictionless one, bit for bit
    if friction is not None and _friction(case):
        traction = (friction.coefficient * friction.direction[0],
                    friction.coefficient * friction.direction[1])
    dents = tuple(Dent(d.depth, d.width, d.decay, d.x1, d.x2)
                  for d in getattr(case.surface, "dents", ()))
    measured = case.surface.kind == "measured"
    if measured and surface is None:
        raise SacflowError(
            "surface: a measured surface needs its heights: build the simulation with "
            "simulation_for(case, surface=sacflow.storage.surface_file.load_surface(case)), "
            "or use sacflow.run"
        )
    return ContactSpec(case.contact_modulus(), case.effective_radii(), case.hertz(), traction,
                       friction is not None, dents, surface if measured else None)


def _stored_state(case: Case, stored: StoredState | None
                  ) -> tuple[StoredState | None, tuple[float, float]]:
    """Return the stored state a chained case starts from and its offset [m] (or None, 0)."""
    spec = case.initial_state
    if spec is None:
        return None, (0.0, 0.0)
    if stored is None:
        raise SacflowError(
            "initial_state: the stored state is needed: build the simulation with "
            "simulation_for(case, initial=sacflow.storage.initial_state_file."
            "read_initial_state(case)), "
            "or use sacflow.run"
        )
    return stored, (float(spec.offset[0]), float(spec.offset[1]))


def _plastic(case: Case) -> bool:
    """Whether the body of ``case`` can yield (its hardening law is not elastic)."""
    return not isinstance(case.body.hardening, Elastic)


def _anderson_depth(case: Case) -> int:
    """Anderson history depth of the plastic fixed point, 0 without acceleration."""
    opts = case.solver
    return opts.anderson_depth if opts.acceleration == "anderson" else 0


def load_path_segments(load_path: Sequence[Load | Unload | Hold | Roll]
                       ) -> tuple[layout.Segment, ...]:
    """Return the schema's load-path segments as the solver's (:mod:`sacflow.solver.layout`)."""
    segments: list[layout.Segment] = []
    for seg in load_path:
        if isinstance(seg, Roll):
            direction = (seg.direction[0], seg.direction[1])
            segments.append(layout.Roll(seg.distance, seg.steps, direction, seg.pass_count,
                                        seg.between, seg.lift_increments))
        elif isinstance(seg, Hold):
            segments.append(layout.Hold(seg.increments))
        else:
            at = seg.at if isinstance(seg, Load) else None
            segments.append(layout.Ramp(seg.to, seg.increments,
                                        None if at is None else (at[0], at[1])))
    return tuple(segments)


def case_steps(case: Case) -> list[StepPlan]:
    """Return the increments of the case's load path (:func:`~sacflow.solver.layout.plan_steps`)."""
    return plan_steps(load_path_segments(case.load_path))


def case_body_grid(case: Case) -> BodyGrid:
    """Return the body-fixed grid of ``case``: its window swept along its load positions."""
    return layout.body_grid((case.grid.nx, case.grid.ny), case.cell_size(), case.grid.nz,
                            case_steps(case))


def _eigenstrain_operator(case: Case) -> bool:
    """Whether a run of ``case`` builds the eigenstrain operator.

    A plastic body does, and so does one with inhomogeneities (the stress of their equivalent
    eigenstrain), counted as a plastic body's.
    """
    return _plastic(case) or bool(case.body.inhomogeneity)


def estimate_case_memory(case: Case) -> MemoryEstimate:
    """Estimated peak resident memory of running ``case`` (:func:`estimate_memory`).

    A body with inhomogeneities is counted as a plastic one (the eigenstrain operator and
    volume state), whatever its hardening.
    """
    return estimate_memory(case_body_grid(case), _eigenstrain_operator(case),
                           _anderson_depth(case), _far_traction(case),
                           case.solver.contact_subcells, _friction(case))


def check_case_memory(case: Case, available: int | None = None) -> MemoryEstimate:
    """Refuse ``case`` when this machine has not the memory it needs (:func:`check_memory`).

    Raises
    ------
    GridTooLargeError
        When the estimate exceeds the available memory (default: available now).
    """
    return check_memory(case_body_grid(case), _eigenstrain_operator(case), _anderson_depth(case),
                        available, _far_traction(case), case.solver.contact_subcells,
                        _friction(case))


def _friction(case: Case) -> bool:
    """Whether the contact of ``case`` carries a shear traction (a friction coefficient > 0)."""
    return case.friction is not None and case.friction.coefficient > 0.0


def _far_traction(case: Case) -> tuple[float, float] | None:
    """Return the surface cells' sizes if ``case`` builds the far-traction operator, else None.

    That coarse operator of the traction beyond the box has margins that depend on them.
    """
    if _eigenstrain_operator(case) and case.solver.traction_beyond_box:
        return case.cell_size()
    return None
