"""Run settings: the grid, the solver options and the output selection of a case.

``[grid]`` sets the surface cells of the contact window and the cuboid layers of the plastic box;
``[solver]`` the tolerances, iteration limits and acceleration of the three nested loops;
``[output]`` what the run file stores.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Literal

from pydantic import Field, model_validator

from sacflow.config.base import (
    MAX_CELLS,
    MAX_THREADS,
    CellCount,
    Model,
    PositiveFloat,
    PositiveInt,
    field_error,
)
from sacflow.kernels.cell_average import MAX_SAMPLING
from sacflow.solver.inputs import MAX_CONTACT_SUBCELLS
from sacflow.solver.state import (
    INCLUSION_FIELDS,
    INCLUSION_SCALARS,
    SCALAR_FIELDS,
    SURFACE_FIELDS,
    VOLUME_FIELDS,
)

__all__ = [
    "FRICTION_FIELDS",
    "INHOMOGENEITY_FIELDS",
    "KINEMATIC_FIELDS",
    "PLASTIC_FIELDS",
    "Grid",
    "Output",
    "SolverOptions",
]

if TYPE_CHECKING:
    FieldName = str  # a Literal built at run time from the field tuples (pydantic checks it)
else:
    FieldName = Literal[SCALAR_FIELDS + SURFACE_FIELDS + VOLUME_FIELDS + INCLUSION_SCALARS
                        + INCLUSION_FIELDS]
if TYPE_CHECKING:
    VolumeFieldName = str
else:
    VolumeFieldName = Literal[VOLUME_FIELDS]


class Grid(Model):
    """Surface grid of the contact window and cuboid layers of the plastic box."""

    nx: int = Field(ge=8, le=MAX_CELLS, description="number of surface cells along x1")
    ny: int = Field(ge=8, le=MAX_CELLS, description="number of surface cells along x2")
    nz: CellCount = Field(description="number of cuboid layers in depth")
    half_width: PositiveFloat = Field(
        1.5, description="window half-size in Hertz contact radii at the maximum load"
    )
    extent: tuple[PositiveFloat, PositiveFloat] | None = Field(
        None, description="full window size (L1, L2) [m]; overrides half_width"
    )
    depth: PositiveFloat | None = Field(
        None, description="depth of the cuboid box [m]; omit to let the solver size it"
    )



class SolverOptions(Model):
    """Tolerances, iteration limits and acceleration of the three nested loops."""

    contact_tolerance: PositiveFloat = Field(1e-10, description="relative gap error, contact")
    contact_max_iterations: PositiveInt = Field(2000, description="contact iteration limit")
    plasticity_tolerance: PositiveFloat = Field(1e-6, description="plastic strain tolerance")
    plasticity_max_iterations: PositiveInt = Field(500, description="plasticity iteration limit")
    coupling_tolerance: PositiveFloat = Field(1e-6, description="contact-plasticity tolerance")
    coupling_max_iterations: PositiveInt = Field(200, description="coupling iteration limit")
    scheme: Literal["coupled", "nested"] = Field(
        "coupled",
        description="'coupled': one fixed point on the plastic strain increment, the contact "
        "re-solved at every evaluation; 'nested': the seed's loops (contact <-> plasticity)",
    )
    acceleration: Literal["anderson", "none"] = Field(
        "anderson", description="fixed-point acceleration"
    )
    anderson_depth: PositiveInt = Field(5, description="Anderson mixing history depth")
    plastic_margin: float = Field(
        0.1, gt=0, lt=1,
        description="relative margin below yield used to size the plastic box, in (0, 1): the "
        "box reaches where the Hertz von Mises stress exceeds (1 - margin) σ_Y, times (1 + margin)",
    )
    fft_threads: Annotated[int, Field(ge=1, le=MAX_THREADS)] | None = Field(
        None, description="FFT threads (default: all cores)"
    )
    residual_displacement_in_gap: bool = Field(
        True,
        description="true: the residual surface displacement of the plastic strain enters the "
        "contact gap, so the pressure follows the deformed surface (the seed's model); false: "
        "the gap stays that of the surface the run starts from (what this run's plastic strain "
        "adds is left out), so the pressure is that of elastic contact, the load of classical "
        "shakedown analyses (Melan's theorem)",
    )
    return_integration: Literal["extrapolated", "backward_euler"] = Field(
        "extrapolated",
        description="how the return mapping integrates the plastic flow over an increment: "
        "'extrapolated' (default), backward Euler in one step and in two half steps along the "
        "increment's straight strain path, extrapolated to second order in the increment "
        "(step doubling); 'backward_euler', one fully implicit step (first order: the results "
        "of sacflow before this option)",
    )
    inclusion_tolerance: PositiveFloat = Field(
        1e-8,
        description="relative residual of the Krylov solve of the inhomogeneities' equivalent "
        "eigenstrain ([[body.inhomogeneity]])",
    )
    inclusion_max_iterations: PositiveInt = Field(
        1000, description="iteration limit of the equivalent-eigenstrain solve"
    )
    stress_sampling: Annotated[int, Field(ge=1, le=MAX_SAMPLING)] = Field(
        1,
        description="points per axis of a cell at which the stresses (residual and contact) "
        "are averaged: 1 (default), the value at the cell centre, as the seed; more, the "
        "mean over the cell (stress_sampling³ points), the energy-consistent operator, "
        "which rules out the spurious checkerboard solutions that centre values allow "
        "under weak hardening (docs/convergence.md); the kernel set-up evaluates "
        "stress_sampling³ times more closed forms, an iteration costs the same",
    )
    surface_correction: Literal["centre", "quadrature"] = Field(
        "centre",
        description="how the residual stress removes the normal traction that the cuboids "
        "leave on the free surface: 'centre' (default, as the seed) samples it at each surface "
        "cell's centre and removes it as a uniform pressure over the cell; 'quadrature' adds "
        "Boussinesq's response to its variation within the cells (Gauss points) for the "
        "first layers' cuboids, which the centre value misses near the surface (a top-layer "
        "ε13 cuboid's traction is odd about the centre, where it is sampled); worth it when "
        "the plastic strain reaches the surface (a press, a dent), where it moves the first "
        "layers' residual stress by hundreds of MPa; the stencil is set up in 0.1 to 2 s "
        "and each application adds a pass over the first layers (the cost: "
        "docs/convergence.md); needs stress_sampling = 1",
    )

    traction_beyond_box: bool = Field(
        False,
        description="whether the residual stress also removes the surface traction that the "
        "cuboids leave beyond the box's footprint: false (default, as the seed) removes it "
        "over the footprint only, so the contact window must reach well beyond the plastic "
        "zone (at the shipped windows the rest costs the residual stress on the axis up to "
        "a few per cent, docs/convergence.md); true adds Love's stresses of the "
        "traction over a footprint three times as wide, computed by a coarse operator of "
        "super-cells and interpolated to the cells (docs/convergence.md); an iteration "
        "costs more (docs/performance.md)",
    )
    contact_subcells: Annotated[int, Field(ge=1, le=MAX_CONTACT_SUBCELLS)] = Field(
        1,
        description="sub-cells per surface cell along each axis on which the contact is "
        "solved: 1 (default, as the seed) solves it on the surface cells, so that the "
        "contact's edge jumps from cell to cell; 2 or more resolve the edge to a sub-cell "
        "(the gap at the sub-cells' centres, the residual displacement interpolated to them, "
        "each cell's pressure the mean of its sub-cells', the body's stress that of the "
        "sub-cells' pressure itself), which removes the sawtooth that the edge's place inside "
        "its cell puts on the print depth and the near-surface stresses, and the error of a "
        "pressure smeared over the cells at the contact's edge (docs/convergence.md); the "
        "contact's arrays and FFTs grow with its square, and the pressure-stress operator "
        "gains its square of kernels (`sacflow validate` counts them in its memory estimate)",
    )

    @model_validator(mode="after")
    def _quadrature_with_centre_values(self) -> SolverOptions:
        if self.surface_correction == "quadrature" and self.stress_sampling != 1:
            raise field_error("surface_correction", "the quadrature correction is made for "
                              "centre values: set solver.stress_sampling = 1 or "
                              "solver.surface_correction = 'centre'")
        return self


#: Fields that hold no information for an elastic body (zeros, an infinite yield stress): not
#: stored for it unless ``output.fields`` names them.
PLASTIC_FIELDS: tuple[str, ...] = (
    "residual_displacement",
    "plastic_strain",
    "equivalent_plastic_strain",
    "residual_stress",
    "yield_stress",
)
#: Fields of a case with a shear traction (``[friction]``): not stored, and refused in
#: ``output.fields``, without one.
FRICTION_FIELDS: tuple[str, ...] = ("shear_traction",)
#: Fields of a body with kinematic hardening: not stored, and refused in ``output.fields``,
#: without it.
KINEMATIC_FIELDS: tuple[str, ...] = ("backstress",)
#: Fields of a body with elastic inhomogeneities (``[[body.inhomogeneity]]``): the equivalent
#: eigenstrain, the phase of each cell, the Krylov iterations per step. Stored only for such a
#: body (a homogeneous run's file is as before), and refused in ``output.fields`` without one.
INHOMOGENEITY_FIELDS: tuple[str, ...] = INCLUSION_SCALARS + INCLUSION_FIELDS


class Output(Model):
    """What the store writes: which variables, how often the volume fields, compression.

    Per-step scalars and surface fields are stored at every step; volume fields every
    ``volume_every`` steps and at the last step (NaN at the other steps).
    """

    fields: tuple[FieldName, ...] | None = Field(
        None,
        description="variables to store (default: all, except for an elastic body the plastic "
        "ones, which would hold zeros: residual_displacement, plastic_strain, "
        "equivalent_plastic_strain, residual_stress, yield_stress; and inclusion_iterations, "
        "equivalent_eigenstrain, phase for a body with inhomogeneities only)",
    )
    volume_every: PositiveInt = Field(
        1, description="store volume fields every k steps (and at the last step)"
    )
    compression: int = Field(
        1, ge=0, le=9, description="zlib compression level of the run file (lossless; 0: none)"
    )
    volume_precision: Literal["float64", "float32"] = Field(
        "float64",
        description="number type of the stored volume fields: float32 halves their size and "
        "rounds each value to 6e-8 of itself (2^-24); the solver always runs in float64 and an "
        "interrupted run resumes exactly",
    )
    every_step: tuple[VolumeFieldName, ...] = Field(
        (),
        description="volume fields stored at every step even when volume_every > 1 (e.g. "
        "['equivalent_plastic_strain'] to follow the plastic zone, the stress only every k)",
    )

    @model_validator(mode="after")
    def _every_step_is_stored(self) -> Output:
        missing = [name for name in self.every_step
                   if self.fields is not None and name not in self.fields]
        if missing:
            raise field_error("every_step", f"{', '.join(missing)} not among output.fields: "
                              "add them there or remove them from every_step")
        return self

