"""Everything the solver needs, as plain typed values: no case schema, no pydantic.

A :class:`SolverInputs` gathers the material (elastic constants, hardening law objects), the
grid (contact window, cell size, cuboid layers, box depth), the contact (contact modulus E*,
effective radii, Hertz estimate, friction traction, surface features), the solver settings
(tolerances, iteration limits, scheme), the output plan, the expanded load path and the initial
state of the body. :func:`sacflow.config.solver_inputs.solver_inputs` makes one from a validated
case; :class:`sacflow.solver.simulation.Simulation` runs it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from sacflow.mechanics.hardening import HardeningLaw, KinematicLaw, NoPlasticity
from sacflow.mechanics.hertz import HertzContact
from sacflow.mechanics.initial_state import StoredState
from sacflow.solver.layout import StepPlan
from sacflow.solver.state import MeasuredSurface

__all__ = [
    "MAX_CONTACT_SUBCELLS",
    "ContactSpec",
    "Dent",
    "GridSpec",
    "Inhomogeneity",
    "InitialConditions",
    "Material",
    "OutputPlan",
    "SolverInputs",
    "SolverSettings",
]


@dataclass(frozen=True)
class Material:
    """The body's material: Young's modulus ``E`` [Pa], Poisson's ratio ``nu``, hardening.

    ``law`` is the isotropic hardening law (:class:`~sacflow.mechanics.hardening.NoPlasticity` for
    an elastic body) and ``kinematic`` the Armstrong–Frederick backstress law, or None.
    """

    E: float
    nu: float
    law: HardeningLaw
    kinematic: KinematicLaw | None = None

    @property
    def plastic(self) -> bool:
        """Whether the body can yield (its law is not elastic)."""
        return not isinstance(self.law, NoPlasticity)

    @property
    def shear_modulus(self) -> float:
        """Shear modulus μ = E / (2 (1 + ν)) [Pa]."""
        return self.E / (2.0 * (1.0 + self.nu))


@dataclass(frozen=True)
class GridSpec:
    """Cells of a run: contact ``window`` (nx, ny), ``cell`` size [m], ``nz`` layers ``depth`` deep.

    ``depth`` [m] is the cuboid box's (given, or sized by :func:`~sacflow.solver.layout.
    auto_depth`); the layers are ``depth / nz`` thick.
    """

    window: tuple[int, int]
    cell: tuple[float, float]
    nz: int
    depth: float

    @property
    def layer_thickness(self) -> float:
        """Thickness Δz of a cuboid layer [m]."""
        return self.depth / self.nz


@dataclass(frozen=True)
class Dent:
    """A damped-sinusoid dent of body 1 (:func:`~sacflow.mechanics.surface_gap.dent_profile`).

    Amplitude ``depth`` [m], ``width`` [m], envelope ``decay``, centre (``x1``, ``x2``) [m].
    """

    depth: float
    width: float
    decay: float
    x1: float
    x2: float


@dataclass(frozen=True)
class ContactSpec:
    """The two bodies in contact and the surface of body 1.

    Attributes
    ----------
    e_star : float
        Contact modulus E* of body and counter-body [Pa].
    radii : tuple of float
        Effective radii of curvature (R1, R2) along x1, x2 [m] (inf: flat).
    hertz : HertzContact
        Hertz estimate at the maximum load (contact radius, peak pressure).
    traction : tuple of float or None
        Shear traction per unit pressure ``μ d`` (q = μ p d), None without friction (μ = 0
        included: the run is then the frictionless one, bit for bit).
    friction : bool
        Whether the case has a friction table (the states then carry the shear traction).
    dents : tuple of Dent
        Dents of body 1 (body-fixed).
    surface : MeasuredSurface or None
        Heights of a measured surface of body 1 (body-fixed).
    """

    e_star: float
    radii: tuple[float, float]
    hertz: HertzContact
    traction: tuple[float, float] | None = None
    friction: bool = False
    dents: tuple[Dent, ...] = ()
    surface: MeasuredSurface | None = None


#: Shapes an inhomogeneity may have (:class:`Inhomogeneity`).
InhomogeneityShape = Literal["sphere", "ellipsoid", "cuboid", "cells"]


@dataclass(frozen=True)
class Inhomogeneity:
    """An inhomogeneity of body 1: a region with its own elastic constants (and hardening).

    Solved by Eshelby's equivalent inclusion method on the body's eigenstrain operators
    (Mura, *Micromechanics of Defects in Solids*, §22): the region's cells carry an equivalent
    eigenstrain ε* such that the homogeneous body with ε* has the inhomogeneous body's stress.

    Attributes
    ----------
    shape : {"sphere", "ellipsoid", "cuboid", "cells"}
        The region: a sphere or an ellipsoid with axes along x1, x2, x3 (cells whose centre is
        inside), a cuboid (cells whose centre is inside), or the listed ``cells``.
    centre : tuple of float
        Centre (x1, x2, x3) [m], body-fixed, x3 the depth below the surface (positive).
    semi_axes : tuple of float
        Semi-axes (a1, a2, a3) [m] along x1, x2, x3: the radius three times for a sphere, the
        half-sides for a cuboid; unused for ``cells``.
    E, nu : float
        Young's modulus [Pa] (a cavity: a vanishing one) and Poisson's ratio of the region.
    cells : ndarray or None
        For ``cells``: the centres (x1, x2, x3) [m] of the region's cells, shape (k, 3); each
        point marks the body cell that contains it.
    law : HardeningLaw or None
        Its own isotropic hardening law; None: it stays elastic
        (:mod:`sacflow.solver.own_hardening`).
    kinematic : KinematicLaw or None
        The backstress law of its own hardening, or None.
    """

    shape: InhomogeneityShape
    centre: tuple[float, float, float]
    semi_axes: tuple[float, float, float]
    E: float
    nu: float
    cells: np.ndarray | None = None
    law: HardeningLaw | None = None
    kinematic: KinematicLaw | None = None


@dataclass(frozen=True)
class SolverSettings:
    """Tolerances, iteration limits and choices of the increment's solvers.

    ``anderson_depth`` is the Anderson mixing history depth, 0 for plain sweeps;
    ``scheme`` the coupled single fixed point or the seed's nested loops; ``fft_threads``
    the FFT threads (None: the machine's); ``residual_displacement_in_gap`` whether the
    run's own residual surface displacement changes the contact gap;
    ``inclusion_tolerance`` and ``inclusion_max_iterations`` the relative residual and the
    iteration limit of the Krylov solve of the inhomogeneities' equivalent eigenstrain (a soft
    inhomogeneity needs many: a cavity's strain is defined up to compatible fields, and at a
    modulus ratio of 1e-3 the first solve takes about 300 GMRES iterations to 1e-8);
    ``return_integration`` how the return integrates the flow over an increment: by step
    doubling along its straight trial path (``"extrapolated"``, second order,
    :mod:`sacflow.mechanics.return_extrapolation`) or one backward-Euler step;
    ``stress_sampling`` the points per axis of a cell at which the stresses are averaged (1: the
    centre value; 2 or more: the cell mean, whose residual-stress operator is positive
    semi-definite like the elastic energy, :mod:`sacflow.kernels.cell_average`);
    ``surface_correction`` how the residual stress removes the surface traction of the cuboids:
    sampled at the surface cells' centres (``"centre"``) or with its variation within the cells
    of the first layers' cuboids integrated (``"quadrature"``,
    :mod:`sacflow.kernels.traction_stencil`); ``traction_beyond_box`` whether it also removes
    the traction beyond the box's footprint (:mod:`sacflow.kernels.far_traction`);
    ``contact_subcells`` the sub-cells per surface cell and axis on which the contact is solved
    (1: the surface cells; more: :mod:`sacflow.solver.subcell_contact`).
    """

    contact_tolerance: float = 1e-10
    contact_max_iterations: int = 2000
    plasticity_tolerance: float = 1e-6
    plasticity_max_iterations: int = 500
    coupling_tolerance: float = 1e-6
    coupling_max_iterations: int = 200
    scheme: Literal["coupled", "nested"] = "coupled"
    anderson_depth: int = 5
    fft_threads: int | None = None
    residual_displacement_in_gap: bool = True
    inclusion_tolerance: float = 1e-8
    inclusion_max_iterations: int = 1000
    return_integration: Literal["extrapolated", "backward_euler"] = "extrapolated"
    stress_sampling: int = 1
    surface_correction: Literal["centre", "quadrature"] = "centre"
    traction_beyond_box: bool = False
    contact_subcells: int = 1


#: Largest number of contact sub-cells per surface cell along an axis
#: (``solver.contact_subcells``, :mod:`sacflow.solver.subcell_contact`): the contact's arrays
#: grow with its square.
MAX_CONTACT_SUBCELLS = 4


@dataclass(frozen=True)
class OutputPlan:
    """Which volume fields each state carries.

    All of them every ``volume_every`` steps (and at the last step and, repeated rolling, at
    the end of every pass); those named in ``every_step`` at the other steps.
    """

    volume_every: int = 1
    every_step: tuple[str, ...] = ()


@dataclass(frozen=True)
class InitialConditions:
    """The body before the first increment.

    Attributes
    ----------
    stress : ndarray or None
        Initial residual stress of the layers, shape (nz, 6) [Pa], or None.
    equivalent_plastic_strain : ndarray
        Initial equivalent plastic strain of the layers, shape (nz,).
    stored : StoredState or None
        The plastic state of a stored run to start from (chained cases), mapped onto this grid
        shifted by ``offset`` [m].
    """

    stress: np.ndarray | None
    equivalent_plastic_strain: np.ndarray
    stored: StoredState | None = None
    offset: tuple[float, float] = (0.0, 0.0)


@dataclass(frozen=True)
class SolverInputs:
    """Everything a :class:`~sacflow.solver.simulation.Simulation` needs.

    ``steps`` is the expanded load path (:func:`~sacflow.solver.layout.plan_steps`);
    ``inhomogeneities`` the elastic inhomogeneities of body 1 (none: a homogeneous body).
    """

    material: Material
    grid: GridSpec
    contact: ContactSpec
    settings: SolverSettings
    output: OutputPlan
    steps: tuple[StepPlan, ...]
    initial: InitialConditions
    inhomogeneities: tuple[Inhomogeneity, ...] = ()
