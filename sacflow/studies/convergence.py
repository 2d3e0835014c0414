"""Convergence study of elastic-plastic indentation runs: cases, refinement sequences, quantities.

The study (``pipelines/convergence.py``, ``docs/convergence.md``, issue #32) runs a case at
levels of a discretisation refined by a constant ratio and reads off each level's results; the
observed orders and limits come from :mod:`sacflow.studies.richardson`. Here:

* :data:`STUDY_CASES`: the cases (case file + overrides; one with its hardening law replaced by
  perfect plasticity at the same initial yield stress);
* :class:`Discretisation`: the numbers a level is made of (surface cells, layers, box depth, the
  increments of each load-path segment), as ``--set`` overrides. The box depth is always given
  explicitly (the shipped case's automatic depth), so that it does not move with the layers;
* :data:`SEQUENCES`: what each sequence refines (lateral cells, layers at a fixed box depth, box
  depth at a fixed layer thickness, increments, everything together) and by which ratio;
* :func:`measure`: the quantities of one finished simulation.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from sacflow.compare.fields import column_at, quadratic_at, refined_peak
from sacflow.config.schema import Case, Elastic
from sacflow.config.solver_inputs import solver_inputs
from sacflow.errors import SacflowError
from sacflow.solver.state import COMPONENTS, State
from sacflow.storage.case_file import load_case

if TYPE_CHECKING:
    from sacflow.solver.simulation import Simulation

__all__ = [
    "PROFILE_DEPTHS",
    "SEQUENCES",
    "STUDY_CASES",
    "UNITS",
    "WITHOUT_FAR_TRACTION",
    "WITHOUT_SUBCELLS",
    "ConvergenceError",
    "Discretisation",
    "Refinement",
    "StudyCase",
    "base_case",
    "case_overrides",
    "measure",
    "shipped_discretisation",
    "source_fingerprint",
    "study_base",
    "top_layer_quantities",
    "unit_of",
]

ROOT = Path(__file__).resolve().parent.parent.parent
PACKAGE = Path(__file__).resolve().parent.parent
#: Depths (in Hertz contact radii at the maximum load) where the residual σ11 axis profile is
#: read (linear interpolation between layer centres), each one quantity of the study.
PROFILE_DEPTHS: tuple[float, ...] = (0.25, 0.5, 1.0, 1.5, 2.0)
#: Top layers whose residual σ33 and hydrostatic stress are read (1 = the surface layer).
TOP_LAYERS: tuple[int, ...] = (1, 2)
#: Parts of the package whose code decides the numbers of a run (a run cached by an older
#: version of any of them is not reused): everything below the application layer, and this
#: module (the measurement).
NUMERICAL_SOURCES: tuple[str, ...] = ("errors.py", "machine", "kernels", "mechanics", "solver",
                                      "config", "studies/convergence.py")
I11, I33 = COMPONENTS.index("11"), COMPONENTS.index("33")
I13, I23 = COMPONENTS.index("13"), COMPONENTS.index("23")


class ConvergenceError(SacflowError):
    """A study that cannot be set up: an unknown case or sequence, a level of fractional cells."""


@dataclass(frozen=True)
class StudyCase:
    """One case of the study: a case file, overrides, optionally made perfectly plastic.

    ``perfectly_plastic`` replaces the hardening law by perfect plasticity at the law's own
    initial yield stress (``body.hardening`` with ``law = "perfectly_plastic"``).
    ``base_increments`` and ``base_grid`` (surface cells per side, layers), when given, are
    the increments and cells of the study's base level (the anchor of its ladders,
    :func:`study_base`) in place of the case file's: the nano-indentations ship 20 + 10
    increments and finer grids since issue #32 (chosen from the study's ``together`` limits),
    while their ladders stay those of the tables recorded at 64² × 24 cells and 10 + 5; the
    press ships 96² × 128 cells with 40 + 12 increments and its ladders stay at 48² × 16 with
    10 + 3.
    """

    name: str
    path: Path
    overrides: tuple[str, ...] = ()
    perfectly_plastic: bool = False
    base_increments: tuple[int, ...] | None = None
    base_grid: tuple[int, int] | None = None


#: The ladders' base increments of the nano-indentations (load + unload).
NANO_BASE_INCREMENTS = (10, 5)
#: The ladders' base grid of the nano-indentations: surface cells per side, layers.
NANO_BASE_GRID = (64, 24)
#: The press's ladders' base (load + unload increments; surface cells per side, layers): the
#: grid it shipped until issue #32 refined it (96² × 128 cells, 40 + 12 increments, the cell
#: mean), and the anchor of its recorded tables.
PRESS_BASE_INCREMENTS = (10, 3)
PRESS_BASE_GRID = (48, 16)
#: The perfectly plastic variant's stresses: the cell mean. With centre values its 48-layer
#: levels, the shipped 650 mN grid's among them, do not finish (a checkerboard that nothing
#: hardens against; docs/convergence.md).
PERFECT_SAMPLING = "solver.stress_sampling=2"
#: The override that reproduces a table or a run recorded before the configs removed the
#: residual stress's surface traction beyond the box (``solver.traction_beyond_box``, issue
#: #32): the scripts that rebuild such records pass it.
WITHOUT_FAR_TRACTION = "solver.traction_beyond_box=false"
#: The override that reproduces a record of the press made before it solved its contact on
#: sub-cells (``solver.contact_subcells = 2`` in its config, issue #32).
WITHOUT_SUBCELLS = "solver.contact_subcells=1"
STUDY_CASES: dict[str, StudyCase] = {
    case.name: case for case in (
        StudyCase("nanoindentation-190mN", ROOT / "configs" / "nanoindentation-190mN.toml",
                  base_increments=NANO_BASE_INCREMENTS, base_grid=NANO_BASE_GRID),
        StudyCase("nanoindentation-650mN", ROOT / "configs" / "nanoindentation-650mN.toml",
                  base_increments=NANO_BASE_INCREMENTS, base_grid=NANO_BASE_GRID),
        StudyCase("nanoindentation-linear-650mN",
                  ROOT / "configs" / "nanoindentation-linear-650mN.toml",
                  base_increments=NANO_BASE_INCREMENTS, base_grid=NANO_BASE_GRID),
        StudyCase("nanoindentation-perfect-650mN", ROOT / "configs" / "nanoindentation-650mN.toml",
                  ("name=\"nanoindentation-perfect-650mN\"", PERFECT_SAMPLING),
                  perfectly_plastic=True,
                  base_increments=NANO_BASE_INCREMENTS, base_grid=NANO_BASE_GRID),
        StudyCase("dent-from-indentation-press",
                  ROOT / "pipelines" / "dent-from-indentation-press.toml",
                  base_increments=PRESS_BASE_INCREMENTS, base_grid=PRESS_BASE_GRID),
    )
}


def case_overrides(study_case: StudyCase) -> tuple[str, ...]:
    """Return the overrides that make ``study_case`` of its case file (perfect plasticity too)."""
    if not study_case.perfectly_plastic:
        return study_case.overrides
    law = load_case(study_case.path, study_case.overrides).body.hardening
    if isinstance(law, Elastic):
        raise ConvergenceError(f"{study_case.name}: an elastic body has no yield stress")
    yield_stress = law.initial_yield_stress()
    return (*study_case.overrides,
            f"body.hardening={{law = \"perfectly_plastic\", yield_stress = {yield_stress!r}}}")


def base_case(study_case: StudyCase, overrides: Sequence[str] = ()) -> Case:
    """Return the validated case of ``study_case`` with further ``overrides`` (applied last)."""
    return load_case(study_case.path, [*case_overrides(study_case), *overrides])


@dataclass(frozen=True)
class Discretisation:
    """The numbers of one level of a sequence.

    ``nx`` = ``ny`` surface cells, ``nz`` layers over ``depth`` [m], and the increments of each
    load-path segment. ``half_width`` is the lateral window in Hertz radii when a level sets
    its own (the ``window`` sequence), None for the case's; ``case_half_width`` is the case's
    window (None when the case gives its window as ``grid.extent``), what ``window`` scales.
    """

    nx: int
    nz: int
    depth: float
    increments: tuple[int, ...]
    half_width: float | None = None
    case_half_width: float | None = None

    def overrides(self) -> list[str]:
        """Return the level as ``--set`` overrides (the box depth always explicit)."""
        window = [] if self.half_width is None else [f"grid.half_width={self.half_width!r}"]
        return [f"grid.nx={self.nx}", f"grid.ny={self.nx}", f"grid.nz={self.nz}",
                f"grid.depth={self.depth!r}", *window, *increments_overrides(self.increments)]

    @property
    def total_increments(self) -> int:
        """Increments of the whole load path."""
        return sum(self.increments)


def increments_overrides(increments: Sequence[int]) -> list[str]:
    """Return ``--set`` overrides giving each load-path segment its number of increments."""
    return [f"load_path.{i}.increments={n}" for i, n in enumerate(increments)]


def base_increments_overrides(study_case: StudyCase) -> list[str]:
    """Return overrides for the base increments of ``study_case`` (none if it has none of its own).

    The scripts that run one case at grids of their own (``pipelines/press_run.py``,
    ``pipelines/dent_hydrostatic.py``) keep the increments of their recorded numbers so.
    """
    return increments_overrides(study_case.base_increments or ())


def shipped_discretisation(case: Case) -> Discretisation:
    """Return the discretisation ``case`` runs with, its automatic box depth made explicit."""
    depth = solver_inputs(case).grid.depth
    window = None if case.grid.extent is not None else float(case.grid.half_width)
    return Discretisation(case.grid.nx, case.grid.nz, float(depth),
                          tuple(int(getattr(seg, "increments", 1)) for seg in case.load_path),
                          case_half_width=window)


#: Override keys that set the cells of the grid (the whole table, or its counts).
CELL_KEYS = frozenset({"grid", "grid.nx", "grid.ny", "grid.nz"})


def study_base(study_case: StudyCase, shipped: Discretisation,
               overrides: Sequence[str] = ()) -> Discretisation:
    """Return the base level of ``study_case``'s ladders: ``shipped`` with its base numbers.

    The case's :attr:`StudyCase.base_increments` replace the shipped increments unless an
    override sets the load path, and its :attr:`StudyCase.base_grid` the shipped cells unless
    an override sets the cells (``grid.nx``, ``grid.ny``, ``grid.nz``; the overridden numbers
    then make the base, as ``--quick``'s do). The box depth is always the shipped one.
    """
    keys = {o.split("=", 1)[0].strip() for o in overrides}
    base = shipped
    if study_case.base_increments is not None and not any(
            k == "load_path" or k.startswith("load_path.") for k in keys):
        base = replace(base, increments=study_case.base_increments)
    if study_case.base_grid is not None and not keys & CELL_KEYS:
        nx, nz = study_case.base_grid
        base = replace(base, nx=nx, nz=nz)
    return base


#: The discretisation parameters a sequence may refine.
PARAMETERS = ("nx", "nz", "depth", "window", "increments")


@dataclass(frozen=True)
class Refinement:
    """A refinement sequence: each named parameter multiplied by ``ratio`` per level.

    ``start`` maps the refined parameters (:data:`PARAMETERS`) to the exponent of ``ratio`` of
    the first level relative to the shipped discretisation (-1: the first level is one ratio
    coarser than the shipped one). ``depth`` scales the box depth and the layer count together
    (same layer thickness): its ``h`` is the inverse box depth. ``window`` scales the lateral
    window (``grid.half_width``) and the surface cells together (same cell size): its ``h`` is
    the inverse window. ``formal_order`` is the order the scheme should have in ``h`` (None when
    there is none to expect).
    """

    name: str
    ratio: float
    start: Mapping[str, int] = field(default_factory=dict)
    formal_order: float | None = 2.0
    description: str = ""

    def levels(self, base: Discretisation, count: int = 3) -> list[Discretisation]:
        """Return the ``count`` levels of this sequence around ``base`` (coarse to fine).

        Raises
        ------
        ConvergenceError
            When a level would need a fractional number of cells or increments.
        """
        return [self.level(base, k) for k in range(count)]

    def level(self, base: Discretisation, k: int) -> Discretisation:
        """Level ``k`` (0 the coarsest) of this sequence around ``base``."""
        return self._scaled(base, lambda start: self.ratio ** (start + k),
                            f"level {k}", f"choose a base divisible by the ratio {self.ratio:g}")

    def at_step(self, base: Discretisation, step: float) -> Discretisation:
        """Return the level at step ``step`` (h relative to the coarsest level: :meth:`step_size`).

        ``step`` = r⁻ᵏ gives :meth:`level` ``k``; any other (e.g. 1/3 between the levels 1/2
        and 1/4 of a ratio 2) is a level the sequence does not run, to check the extrapolation
        against (``pipelines/convergence.py --check``).
        """
        if not step > 0.0:
            raise ConvergenceError(f"sequence {self.name!r}: the step must be > 0, got {step}")
        return self._scaled(base, lambda start: self.ratio ** start / step, f"step {step:g}",
                            "choose a step that divides the coarsest level's numbers")

    def _scaled(self, base: Discretisation, factor: Callable[[int], float], label: str,
                advice: str) -> Discretisation:
        """Return ``base`` with each refined number multiplied by ``factor(its start exponent)``."""
        def scaled(name: str, value: int) -> int:
            if name not in self.start:
                return value
            exact = value * factor(self.start[name])
            if abs(exact - round(exact)) > 1e-9 * exact or round(exact) < 1:
                raise ConvergenceError(
                    f"sequence {self.name!r}: {label} would have {exact:g} {name} (from "
                    f"{value}): {advice}"
                )
            return int(round(exact))

        nz = scaled("depth", scaled("nz", base.nz))
        depth = base.depth * (factor(self.start["depth"]) if "depth" in self.start else 1.0)
        return replace(base, nx=scaled("window", scaled("nx", base.nx)), nz=nz, depth=depth,
                       half_width=self._window(base, factor),
                       increments=tuple(scaled("increments", n) for n in base.increments))

    def _window(self, base: Discretisation, factor: Callable[[int], float]) -> float | None:
        """Return the window of a level: ``base``'s, scaled when this sequence refines it.

        None when that is the case's own window, so that such a level is the base's run.
        """
        if "window" not in self.start:
            return base.half_width
        own = base.half_width if base.half_width is not None else base.case_half_width
        if own is None:
            raise ConvergenceError(
                f"sequence {self.name!r} scales grid.half_width, but the case sets its window "
                "as grid.extent: give it as grid.half_width (in Hertz radii) in the case file "
                "to refine the window")
        scale = factor(self.start["window"])
        return None if scale == 1.0 and base.half_width is None else own * scale

    def step_size(self, k: int) -> float:
        """Discretisation parameter h of level ``k`` relative to the coarsest level: r⁻ᵏ."""
        return float(self.ratio ** (-k))


SEQUENCES: dict[str, Refinement] = {
    seq.name: seq for seq in (
        Refinement("lateral", 2.0, {"nx": -1}, 2.0,
                   "surface cells nx = ny (same window), layers and increments fixed"),
        Refinement("layers", 2.0, {"nz": -1}, 2.0,
                   "layers nz over the same box depth, surface cells and increments fixed"),
        Refinement("depth", 1.5, {"depth": 0}, None,
                   "box depth and layers together (same layer thickness); h = 1 / depth"),
        Refinement("window", 1.5, {"window": 0}, None,
                   "lateral window and surface cells together (same cell size); h = 1 / window"),
        Refinement("increments", 2.0, {"increments": 0}, 2.0,
                   "load and unload increments together, grid fixed"),
        Refinement("together", 2.0, {"nx": -1, "nz": -1, "increments": 0}, 2.0,
                   "surface cells, layers and increments together"),
    )
}
#: Sequences whose formal order is that of the return's integration over an increment.
INCREMENT_SEQUENCES = ("increments", "together")


def sequences_for(case: Case) -> dict[str, Refinement]:
    """Return the sequences with the formal orders of ``case``'s return integration.

    The step-doubled return (``solver.return_integration = "extrapolated"``, the default) is
    second order in the increment, one backward-Euler step first order.
    """
    if case.solver.return_integration == "extrapolated":
        return dict(SEQUENCES)
    return {name: replace(seq, formal_order=1.0) if name in INCREMENT_SEQUENCES else seq
            for name, seq in SEQUENCES.items()}


#: Unit of the quantities of :func:`measure` (SI) by name prefix; names ending in ``_depth``
#: are depths [m].
UNITS: dict[str, str] = {"approach": "m", "print_depth": "m", "peak_pressure": "Pa",
                         "max_plastic_strain": "1", "residual": "Pa", "hydrostatic": "Pa"}


def unit_of(quantity: str) -> str:
    """Return the unit of ``quantity`` of :func:`measure`."""
    if quantity.endswith("_depth"):
        return "m"
    return next((unit for prefix, unit in UNITS.items() if quantity.startswith(prefix)), "")


def measure(sim: Simulation, states: Sequence[State], contact_radius: float
            ) -> tuple[dict[str, float], dict[str, list[float]]]:
    """Return the quantities of a finished simulation and its residual σ11 axis profile.

    Parameters
    ----------
    sim : Simulation
        The simulation after its run (its body holds the final plastic strain).
    states : sequence of State
        Every step of the run.
    contact_radius : float
        Hertz contact radius at the maximum load [m]: the unit of :data:`PROFILE_DEPTHS`.

    Returns
    -------
    quantities : dict
        Name -> value (SI): ``approach_at_peak_load``, ``print_depth`` (largest residual
        surface displacement of a cell at the end), ``print_depth_refined`` (the same refined
        below the cell size by :func:`~sacflow.compare.fields.refined_peak`: with an even
        number of cells the axis lies on a cell corner, and the largest cell value is the
        print's depth half a cell off the axis along each direction), ``peak_pressure``
        (over the run), ``max_plastic_strain`` (cell maximum) and its ``_depth``,
        ``max_plastic_strain_refined`` (:func:`~sacflow.compare.fields.refined_peak`) and its
        ``_depth``,
        ``residual_s11_axis_min`` and the axis profile at :data:`PROFILE_DEPTHS`
        (``residual_s11_axis_at_0.5a``...: the cell column nearest the axis, linear between
        layer centres), the same on the axis itself (``residual_s11_axis_min_refined`` and
        ``residual_s11_axis_refined_at_0.5a``...: the column interpolated to the load axis
        by :func:`~sacflow.compare.fields.quadratic_at`, its minimum refined by a parabola
        through the layer centres, the profile quadratic between them), and per top layer L
        (:data:`TOP_LAYERS`)
        ``residual_s33_layerL_axis`` / ``_extreme`` (signed value of largest magnitude over the
        layer), ``hydrostatic_layerL_axis`` / ``_extreme``, ``residual_shear_layerL_max``
        (largest √(σ13² + σ23²), which must vanish at the traction-free surface too).
    profile : dict
        ``x3`` (layer centres [m]) and ``residual_s11`` [Pa] in the column nearest the axis.
    """
    top = max(range(len(states)), key=lambda i: states[i].load)
    x1, x2, x3 = sim.coords.x1, sim.coords.x2, sim.coords.x3
    i = int(np.argmin(np.abs(x1 - states[top].load_x1)))
    j = int(np.argmin(np.abs(x2 - states[top].load_x2)))
    strain = np.asarray(sim.equivalent_plastic_strain, dtype=float)
    stress = np.asarray(sim.residual_stress, dtype=float)
    cell = np.unravel_index(int(np.nanargmax(strain)), strain.shape)
    refined, where = refined_peak(strain, (x1, x2, x3))
    residual = np.asarray(sim.residual_displacement, dtype=float)
    print_refined, _ = refined_peak(residual, (x1, x2))
    axis_s11 = stress[i, j, :, I11]
    out = {
        "approach_at_peak_load": float(states[top].approach),
        "print_depth": float(np.max(residual)),
        "print_depth_refined": float(print_refined),
        "peak_pressure": float(max(s.max_pressure for s in states)),
        "max_plastic_strain": float(strain[cell]),
        "max_plastic_strain_depth": float(x3[cell[2]]),
        "max_plastic_strain_refined": float(refined),
        "max_plastic_strain_refined_depth": float(where[2]),
        "residual_s11_axis_min": float(np.nanmin(axis_s11)),
    }
    load_point = (states[top].load_x1, states[top].load_x2)
    on_axis = quadratic_at(stress[..., I11], (x1, x2), load_point)
    out["residual_s11_axis_min_refined"] = -refined_peak(-on_axis, (x3,))[0]
    points = [depth * contact_radius for depth in PROFILE_DEPTHS]
    for depth, z, refined_s11 in zip(PROFILE_DEPTHS, points, column_at(on_axis, x3, points),
                                     strict=True):
        inside = x3[0] <= z <= x3[-1]
        out[f"residual_s11_axis_at_{depth:g}a"] = (float(np.interp(z, x3, axis_s11)) if inside
                                                   else math.nan)
        out[f"residual_s11_axis_refined_at_{depth:g}a"] = refined_s11
    out.update(top_layer_quantities(stress, i, j))
    return out, {"x3": [float(z) for z in x3], "residual_s11": [float(s) for s in axis_s11]}


def top_layer_quantities(stress: np.ndarray, i: int, j: int) -> dict[str, float]:
    """Residual σ33, hydrostatic and shear stress of the :data:`TOP_LAYERS` of ``stress``."""
    out: dict[str, float] = {}
    for layer in TOP_LAYERS:
        if layer > stress.shape[2]:
            continue
        sig = stress[:, :, layer - 1, :]
        fields = {"residual_s33": sig[..., I33],
                  "hydrostatic": (sig[..., 0] + sig[..., 1] + sig[..., 2]) / 3.0}
        for name, values in fields.items():
            out[f"{name}_layer{layer}_axis"] = float(values[i, j])
            out[f"{name}_layer{layer}_extreme"] = float(values.flat[np.nanargmax(np.abs(values))])
        out[f"residual_shear_layer{layer}_max"] = float(
            np.nanmax(np.hypot(sig[..., I13], sig[..., I23])))
    return out


def source_fingerprint(parts: Iterable[str] = NUMERICAL_SOURCES) -> str:
    """SHA-256 (16 hex digits) of the package sources that decide a run's numbers.

    A cached result is reused only by the same code: after a change of the solver, the study
    runs again (the old results stay in their files).
    """
    digest = hashlib.sha256()
    for part in parts:
        path = PACKAGE / part
        files = sorted(path.rglob("*.py")) if path.is_dir() else [path]
        for file in files:
            digest.update(str(file.relative_to(PACKAGE)).encode())
            digest.update(file.read_bytes())
    return digest.hexdigest()[:16]
