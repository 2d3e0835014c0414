"""Case description: frozen pydantic v2 models of one sacflow run (DESIGN §2, STYLE 9).

A :class:`Case` holds everything that defines a run: the elastic-plastic body (body 1) and its
hardening law, the counter-body, the surface (smooth, dented, measured), the grid, the load path,
the solver options and the output selection. Every model is frozen and rejects unknown keys; a
case is hashable and identified by :attr:`Case.case_id`, the hash of the canonical JSON of what
changes its numbers (not its name, description, thread count or compression level). Sweeps
are ``case.model_copy(update=...)``.

Units are SI everywhere: m, Pa, N. ``x3`` is depth, positive into the body. Sequences are stored
as tuples so that a case cannot be changed in place.
"""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator
from pydantic_core import PydanticCustomError

from sacflow.mechanics.hertz import HertzContact, composite_modulus, effective_radius, hertz_contact
from sacflow.solver.state import SCALAR_FIELDS, SURFACE_FIELDS, VOLUME_FIELDS

__all__ = [
    "Body",
    "Case",
    "Counterbody",
    "Dent",
    "Dented",
    "DepthProfile",
    "Elastic",
    "Friction",
    "KinematicHardening",
    "Grid",
    "HardeningLaw",
    "Hold",
    "Linear",
    "Load",
    "Measured",
    "Output",
    "PerfectlyPlastic",
    "Roll",
    "Segment",
    "Smooth",
    "SolverOptions",
    "Surface",
    "Swift",
    "Tabular",
    "Unload",
    "NOT_IN_IDENTITY",
    "OPTIONAL_TABLES",
    "PLASTIC_FIELDS",
    "FRICTION_FIELDS",
    "KINEMATIC_FIELDS",
    "case_json_schema",
    "identity_differences",
    "field_error",
]

#: Least number of surface cells across the Hertz contact diameter 2a at the maximum load.
MIN_CELLS_PER_DIAMETER = 8
#: Least window half-width, in Hertz contact radii at the maximum load.
MIN_HALF_WIDTH = 1.1
#: Largest Hertz contact radius over the effective radius of curvature at the maximum load.
#: Half-space theory, behind every influence coefficient, needs a << R (Johnson, Contact
#: Mechanics, §4.2; the shipped cases have a/R <= 0.15); beyond this it describes another
#: problem than the one asked (a load or radius off by orders of magnitude, usually).
MAX_CONTACT_TO_RADIUS = 0.5
#: Range of the cuboid layer thickness (grid.depth / grid.nz) over the smaller surface cell
#: size, when grid.depth is given. Measured on the 650 mN indentation at 16 x 16 cells: the
#: eigenstrain kernels lose their symmetry to round-off (RuntimeError) below 3e-4 and above
#: 1.7e4; the range keeps a factor of 30 and 17 from those.
MIN_LAYER_ASPECT, MAX_LAYER_ASPECT = 1e-2, 1e3
#: Error type of the case-level checks; its context names the offending field.
FIELD_ERROR = "sacflow_field"
#: Fields that do not change the stored numbers, left out of :attr:`Case.case_id`: the name
#: (the file name), free text, the FFT thread count and the lossless compression level.
NOT_IN_IDENTITY: tuple[str, ...] = (
    "name", "description", "solver.fft_threads", "output.compression",
)

#: Optional tables (dotted paths) added after runs were stored: left out of the identity when
#: absent, so the case_id of a case without them is the one it had before they existed.
OPTIONAL_TABLES: tuple[str, ...] = ("friction", "body.hardening.kinematic")
#: Options added after runs were stored, left out of the identity at their default value (the
#: case_id of a case that does not set them is the one it had before they existed).
DEFAULTS_LEFT_OUT: dict[str, Any] = {"output.volume_precision": "float64",
                                     "output.every_step": [],
                                     "solver.residual_displacement_in_gap": True}
#: Load-path segment options added after runs were stored, left out of the identity when unset.
OPTIONAL_SEGMENT_KEYS: tuple[str, ...] = ("passes", "between", "lift_increments")

PositiveFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]
NonNegativeFloat = Annotated[float, Field(ge=0, allow_inf_nan=False)]
FiniteFloat = Annotated[float, Field(allow_inf_nan=False)]
PositiveInt = Annotated[int, Field(ge=1)]
#: Most cells along one grid axis (nx, ny, nz): far above any grid a machine can hold (the
#: memory check refuses those with a size estimate), low enough that every index stays a
#: machine integer.
MAX_CELLS = 1 << 16
#: Most increments (or rolling steps) of one load-path segment: a run of that many steps takes
#: days; the bound keeps the expanded step plan small.
MAX_STEPS = 100_000
CellCount = Annotated[int, Field(ge=1, le=MAX_CELLS)]
#: Most FFT threads (``solver.fft_threads``): FFTW takes a C integer; no machine has more cores.
MAX_THREADS = 4096
StepCount = Annotated[int, Field(ge=1, le=MAX_STEPS)]
#: Most passes of one roll segment (a campaign of millions of cycles is not run pass by pass).
MAX_PASSES = 10000
#: Radius of curvature [m]; ``inf`` stands for a flat surface.
Radius = Annotated[float, Field(gt=0)]
PoissonRatio = Annotated[float, Field(gt=-1, lt=0.5)]
if TYPE_CHECKING:
    FieldName = str  # a Literal built at run time from the field tuples (pydantic checks it)
else:
    FieldName = Literal[SCALAR_FIELDS + SURFACE_FIELDS + VOLUME_FIELDS]
if TYPE_CHECKING:
    VolumeFieldName = str
else:
    VolumeFieldName = Literal[VOLUME_FIELDS]


def field_error(field: str, message: str) -> PydanticCustomError:
    """Return a validation error for a cross-field check that names ``field`` (dotted path).

    ``field`` is relative to the model that raises it; :mod:`sacflow.storage.case_file` appends it
    to the
    error location. ``message`` must not contain braces.
    """
    return PydanticCustomError(FIELD_ERROR, message, {"field": field})


def _drop(data: dict[str, Any], dotted: str, when: Any) -> None:
    """Delete the entry at the dotted path of nested dicts ``data`` if present and ``when(it)``."""
    *parents, leaf = dotted.split(".")
    table: Any = data
    for key in parents:
        table = table.get(key) if isinstance(table, dict) else None
    if isinstance(table, dict) and leaf in table and when(table[leaf]):
        del table[leaf]


def _strictly_increasing(values: tuple[float, ...]) -> bool:
    return all(b > a for a, b in zip(values, values[1:], strict=False))


class Model(BaseModel):
    """Base of every sacflow model: immutable, hashable, unknown keys rejected."""

    model_config = ConfigDict(frozen=True, extra="forbid", ser_json_inf_nan="strings")


# --------------------------------------------------------------------------- hardening laws
class DepthProfile(Model):
    """Depth dependence of the yield stress: σ_Y(εp, x3) = factor(x3) · σ_Y(εp).

    Linear interpolation between the points, constant beyond the first and last depth.
    """

    depth: tuple[NonNegativeFloat, ...] = Field(
        min_length=1, description="depths x3 of the profile points [m], strictly increasing"
    )
    factor: tuple[PositiveFloat, ...] = Field(
        min_length=1, description="yield-stress factors at those depths (1 = unchanged)"
    )

    @model_validator(mode="after")
    def _check_points(self) -> DepthProfile:
        if len(self.factor) != len(self.depth):
            raise field_error("factor", "must have one value per depth")
        if not _strictly_increasing(self.depth):
            raise field_error("depth", "must be strictly increasing")
        return self


#: Stress components an initial residual stress profile may not have: with σ(x3) alone, the
#: equilibrium ∂σ_i3/∂x3 = 0 and the free surface σ_i3(0) = 0 force σ33 = σ13 = σ23 = 0.
_NOT_INITIAL_STRESS = ("s33", "s13", "s23")


class InitialResidualStress(Model):
    """An initial residual stress varying with depth only (case hardening, shot peening).

    ``σ11(x3)``, ``σ22(x3)`` interpolated linearly between the points, constant beyond the first
    and last depth; every other component 0. Laterally uniform, it is in equilibrium with a free
    surface exactly when σ33 = σ13 = σ23 = 0 (∂σ_i3/∂x3 = 0 and σ_i3 = 0 at x3 = 0); it adds to
    the stress of the yield check at every step and to the stored ``stress`` and
    ``residual_stress``, and displaces no surface point (no change of the contact geometry).
    """

    depth: tuple[NonNegativeFloat, ...] = Field(
        min_length=1, description="depths x3 of the profile points [m], strictly increasing"
    )
    s11: tuple[FiniteFloat, ...] = Field(
        min_length=1, description="residual stress σ11 at those depths [Pa] (compression < 0)"
    )
    s22: tuple[FiniteFloat, ...] = Field(
        min_length=1, description="residual stress σ22 at those depths [Pa] (compression < 0)"
    )

    @model_validator(mode="before")
    @classmethod
    def _only_in_plane(cls, data: Any) -> Any:
        if isinstance(data, dict):
            for key in _NOT_INITIAL_STRESS:
                if key in data:
                    raise ValueError(
                        f"{key} is not allowed: a stress varying with depth only is in "
                        "equilibrium with the free surface only if σ33 = σ13 = σ23 = 0; "
                        "give s11 and s22 only"
                    )
            if "s12" in data:
                raise ValueError("s12 is not supported: give the profile in its principal "
                                 "axes x1, x2 (s11, s22)")
        return data

    @model_validator(mode="after")
    def _check_points(self) -> InitialResidualStress:
        for name in ("s11", "s22"):
            if len(getattr(self, name)) != len(self.depth):
                raise field_error(name, "must have one value per depth")
        if not _strictly_increasing(self.depth):
            raise field_error("depth", "must be strictly increasing")
        return self


class InitialHardening(Model):
    """An initial equivalent plastic strain varying with depth: a work-hardened layer.

    It raises the yield stress through the hardening law (σ_Y(p0(x3))) without a plastic strain
    tensor, hence without residual stress of its own; linear between the points, constant beyond
    the first and last depth.
    """

    depth: tuple[NonNegativeFloat, ...] = Field(
        min_length=1, description="depths x3 of the profile points [m], strictly increasing"
    )
    equivalent_plastic_strain: tuple[NonNegativeFloat, ...] = Field(
        min_length=1, description="equivalent plastic strain p at those depths (plain strain)"
    )

    @model_validator(mode="after")
    def _check_points(self) -> InitialHardening:
        if len(self.equivalent_plastic_strain) != len(self.depth):
            raise field_error("equivalent_plastic_strain", "must have one value per depth")
        if not _strictly_increasing(self.depth):
            raise field_error("depth", "must be strictly increasing")
        return self


class Elastic(Model):
    """No plasticity: the body stays elastic."""

    law: Literal["elastic"] = "elastic"


class KinematicHardening(Model):
    """Kinematic hardening: a backstress X that moves the yield surface (Armstrong–Frederick).

    dX = 2/3 C dεp − γ X dp (Armstrong & Frederick 1966; Chaboche 1989 for its combination with
    isotropic hardening); γ = 0 is linear kinematic hardening (Prager 1956, Ziegler 1959). Under
    uniaxial plastic flow the uniaxial backstress 3/2 X11 saturates at C/γ. The yield function
    becomes sqrt(3/2 (s − X):(s − X)) − σ_Y(p): the isotropic law still sets the surface's size.
    """

    modulus: NonNegativeFloat = Field(description="kinematic hardening modulus C [Pa]")
    recall: NonNegativeFloat = Field(
        0.0, description="dynamic recall γ (dimensionless); 0: linear (Prager–Ziegler)"
    )


class _Plastic(Model):
    """Base of the plastic laws: the rules every law shares.

    The hardening-law models are the one place where a law's rules live: whatever they accept,
    :func:`sacflow.mechanics.plasticity.hardening_from_schema` builds and the radial return runs
    with
    (σ_Y finite, positive and non-decreasing in εp). The runtime classes of
    :mod:`sacflow.mechanics.plasticity` validate their arguments through these models.
    """

    depth_profile: DepthProfile | None = Field(
        None, description="optional depth dependence of the yield stress (surface hardening)"
    )
    kinematic: KinematicHardening | None = Field(
        None, description="optional kinematic hardening (backstress) combined with the law"
    )

    def initial_yield_stress(self) -> float:
        """σ_Y(εp = 0) [Pa], before any depth factor."""
        raise NotImplementedError

    @model_validator(mode="after")
    def _check_scaled_yield(self) -> _Plastic:
        profile, y0 = self.depth_profile, self.initial_yield_stress()
        if profile is None or not 0.0 < y0 < math.inf:  # the law's own check reports y0
            return self
        if not (0.0 < y0 * min(profile.factor) and y0 * max(profile.factor) < math.inf):
            raise field_error(
                "depth_profile.factor",
                f"factor times the initial yield stress ({y0:g} Pa) must stay a finite "
                "positive stress; use factors of order 1",
            )
        return self


class Swift(_Plastic):
    """Swift law σ_Y = B (C + εp)^n, εp in ``strain_unit`` (the seed uses micro-strain).

    The initial yield stress σ_Y(0) = B C^n must be a finite positive stress, so C > 0 (C = 0
    would mean yield at zero stress with an infinite initial hardening slope).
    """

    law: Literal["swift"] = "swift"
    B: PositiveFloat = Field(description="Swift stress coefficient B [Pa]")
    C: PositiveFloat = Field(
        description="Swift strain offset C, in strain_unit (> 0: σ_Y(0) = B C^n is the initial "
        "yield stress)"
    )
    n: float = Field(gt=0, lt=1, description="Swift hardening exponent n")
    strain_unit: Literal["strain", "microstrain"] = Field(
        description='unit of εp and C in the Swift law ("microstrain": σ_Y = B (C + 1e6 εp)^n)'
    )

    def initial_yield_stress(self) -> float:
        """σ_Y(0) = B C^n [Pa]."""
        return self.B * self.C**self.n

    @model_validator(mode="after")
    def _check_initial_yield(self) -> Swift:
        y0 = self.initial_yield_stress()
        if not 0.0 < y0 < math.inf:
            raise field_error(
                "B",
                f"the initial yield stress B C^n = {y0:g} Pa is not a finite positive stress; "
                "check the magnitudes of B [Pa] and C",
            )
        return self


class Linear(_Plastic):
    """Linear hardening σ_Y = σ_Y0 + H εp."""

    law: Literal["linear"] = "linear"
    yield_stress: PositiveFloat = Field(description="initial yield stress σ_Y0 [Pa]")
    modulus: NonNegativeFloat = Field(description="plastic hardening modulus H [Pa]")

    def initial_yield_stress(self) -> float:
        """σ_Y0 [Pa]."""
        return self.yield_stress


class PerfectlyPlastic(_Plastic):
    """No hardening: σ_Y constant."""

    law: Literal["perfectly_plastic"] = "perfectly_plastic"
    yield_stress: PositiveFloat = Field(description="yield stress σ_Y [Pa]")

    def initial_yield_stress(self) -> float:
        """σ_Y [Pa]."""
        return self.yield_stress


class Tabular(_Plastic):
    """Piecewise-linear measured hardening curve σ_Y(εp) through the given points.

    Beyond the last point the curve stays at the last stress (``beyond_last = "constant"``,
    the default: no hardening past what was measured, hardening modulus 0 there) or continues
    with the slope of the last segment (``"extrapolate"``).
    """

    law: Literal["tabular"] = "tabular"
    plastic_strain: tuple[NonNegativeFloat, ...] = Field(
        min_length=2, description="equivalent plastic strains, from 0, strictly increasing"
    )
    stress: tuple[PositiveFloat, ...] = Field(
        min_length=2, description="yield stresses at those strains [Pa], non-decreasing"
    )
    beyond_last: Literal["constant", "extrapolate"] = Field(
        "constant",
        description='yield stress beyond the last point: "constant" (default) keeps the last '
        'stress (hardening modulus 0); "extrapolate" continues the last segment\'s slope',
    )

    def initial_yield_stress(self) -> float:
        """σ_Y(0), the first stress [Pa]."""
        return self.stress[0]

    @model_validator(mode="after")
    def _check_curve(self) -> Tabular:
        if len(self.stress) != len(self.plastic_strain):
            raise field_error("stress", "must have one value per plastic_strain point")
        if self.plastic_strain[0] != 0.0:
            raise field_error("plastic_strain", "must start at 0 (the initial yield point)")
        if not _strictly_increasing(self.plastic_strain):
            raise field_error("plastic_strain", "must be strictly increasing")
        if any(b < a for a, b in zip(self.stress, self.stress[1:], strict=False)):
            raise field_error("stress", "must be non-decreasing (no softening)")
        e, sig = self.plastic_strain, self.stress
        for i in range(len(e) - 1):
            if not (sig[i + 1] - sig[i]) / (e[i + 1] - e[i]) < math.inf:
                raise field_error(
                    "plastic_strain",
                    f"points {i} and {i + 1} are too close for their stress rise: the "
                    "hardening slope is not a finite number; space them further apart",
                )
        return self


HardeningLaw = Annotated[
    Elastic | Swift | Linear | PerfectlyPlastic | Tabular, Field(discriminator="law")
]


# --------------------------------------------------------------------------- bodies
class Body(Model):
    """The elastic-plastic half-space (body 1)."""

    E: PositiveFloat = Field(description="Young's modulus of the body [Pa]")
    nu: PoissonRatio = Field(description="Poisson's ratio of the body")
    radii: tuple[Radius, Radius] = Field(
        (math.inf, math.inf),
        description="principal radii of curvature along x1, x2 [m] (inf = flat)",
    )
    hardening: HardeningLaw = Field(description="hardening law of the body, chosen by 'law'")
    initial_residual_stress: InitialResidualStress | None = Field(
        None, description="residual stress before any contact, σ11 and σ22 vs depth"
    )
    initial_hardening: InitialHardening | None = Field(
        None, description="equivalent plastic strain before any contact vs depth"
    )

    @model_validator(mode="after")
    def _check_initial(self) -> Body:
        if self.initial_hardening is not None and self.hardening.law == "elastic":
            raise field_error("initial_hardening", "an elastic body has no hardening; remove it "
                              "or give a plastic law")
        return self


class Counterbody(Model):
    """The counter-body: rigid or elastic, a sphere (``radius``) or an ellipsoid (``radii``)."""

    kind: Literal["rigid", "elastic"] = Field(description="rigid or elastic counter-body")
    E: PositiveFloat | None = Field(None, description="Young's modulus of the counterbody [Pa]")
    nu: PoissonRatio | None = Field(None, description="Poisson's ratio of the counterbody")
    radius: Radius | None = Field(None, description="sphere radius [m]")
    radii: tuple[Radius, Radius] | None = Field(
        None, description="principal radii of curvature along x1, x2 [m] (ellipsoid)"
    )

    @model_validator(mode="after")
    def _check_counterbody(self) -> Counterbody:
        if (self.radius is None) == (self.radii is None):
            raise field_error("radius", "give exactly one of radius (sphere) or radii (ellipsoid)")
        for name in ("E", "nu"):
            given = getattr(self, name) is not None
            if self.kind == "elastic" and not given:
                raise field_error(name, f'required when kind = "elastic"; add counterbody.{name}')
            if self.kind == "rigid" and given:
                raise field_error(
                    name,
                    f'not allowed when kind = "rigid"; remove counterbody.{name} '
                    'or set kind = "elastic"',
                )
        return self

    @property
    def principal_radii(self) -> tuple[float, float]:
        """Principal radii of curvature (R1, R2) along x1, x2 [m]."""
        if self.radii is not None:
            return self.radii
        assert self.radius is not None  # guaranteed by validation
        return (self.radius, self.radius)


# --------------------------------------------------------------------------- surfaces
class Smooth(Model):
    """Smooth surfaces: the gap is the quadratic Hertz geometry only."""

    kind: Literal["smooth"] = "smooth"


class Dent(Model):
    """A dent on body 1: profile A cos(2π r/w) exp(-decay r²/w²), a hollow of depth A."""

    depth: PositiveFloat = Field(description="dent amplitude A [m]")
    width: PositiveFloat = Field(description="dent width w [m]")
    decay: PositiveFloat = Field(13.0, description="decay coefficient of the envelope")
    x1: FiniteFloat = Field(0.0, description="dent centre along x1 [m] (body frame)")
    x2: FiniteFloat = Field(0.0, description="dent centre along x2 [m] (body frame)")


class Dented(Model):
    """A smooth surface with one or more dents."""

    kind: Literal["dented"] = "dented"
    dents: tuple[Dent, ...] = Field(min_length=1, description="the dents on body 1")


class Measured(Model):
    """A measured surface read from a file (x1, x2, height grid)."""

    kind: Literal["measured"] = "measured"
    path: Path = Field(description="surface file (relative to the config file)")
    format: Literal["auto", "netcdf", "text"] = Field(
        "auto", description="file format; auto: netCDF for .nc files, else x1 x2 height columns"
    )
    variable: str = Field("height", description="name of the height variable in a netCDF file")


Surface = Annotated[Smooth | Dented | Measured, Field(discriminator="kind")]


# --------------------------------------------------------------------------- grid
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


# --------------------------------------------------------------------------- load path
class Load(Model):
    """Raise the normal load to ``to`` in ``increments`` equal steps."""

    kind: Literal["load"] = "load"
    to: PositiveFloat = Field(description="normal load at the end of the segment [N]")
    increments: StepCount = Field(description="number of load increments")
    at: tuple[FiniteFloat, FiniteFloat] | None = Field(
        None,
        description="load position (x1, x2) in the body frame [m] for this segment; "
        "default: where the load already is (initially the origin)",
    )


class Unload(Model):
    """Lower the normal load to ``to`` (default: full unload)."""

    kind: Literal["unload"] = "unload"
    to: NonNegativeFloat = Field(0.0, description="normal load at the end of the segment [N]")
    increments: StepCount = Field(description="number of unload increments")


class Hold(Model):
    """Keep the load constant (re-converge the coupled problem)."""

    kind: Literal["hold"] = "hold"
    increments: StepCount = Field(1, description="number of hold steps")


#: Passes of the rolling direction's normalisation towards its fixed point (two suffice: no
#: direction of 200 000 random ones needed more).
_NORMALISE_PASSES = 4


def unit_vector(value: tuple[float, float]) -> tuple[float, float]:
    """Return the unit vector of ``value``, a fixed point of the normalisation.

    Dividing by the norm once can change the last bit of a vector that is then divided again
    (about one direction in five): a case read back from its JSON would then have another
    ``case_id``. Normalising until nothing changes (one or two more passes) makes the stored
    direction read back as itself.

    Raises
    ------
    ValueError
        For a zero or non-finite vector.
    """
    norm = math.hypot(*value)
    if not (0.0 < norm < math.inf):
        raise ValueError("must be a non-zero vector (d1, d2)")
    unit = (value[0] / norm, value[1] / norm)
    for _ in range(_NORMALISE_PASSES):
        norm = math.hypot(*unit)
        again = (unit[0] / norm, unit[1] / norm)
        if again == unit:
            break
        unit = again
    return unit


class Roll(Model):
    """Move the load over the body at constant load."""

    kind: Literal["roll"] = "roll"
    distance: PositiveFloat = Field(description="rolled distance [m]")
    steps: StepCount = Field(description="number of rolling steps")
    direction: tuple[FiniteFloat, FiniteFloat] = Field(
        (1.0, 0.0), description="rolling direction (d1, d2) in the surface plane, normalised"
    )
    passes: Annotated[int, Field(ge=1, le=MAX_PASSES)] | None = Field(
        None, description="passes over the same track (default 1); each later pass starts as "
        "'between' says"
    )
    between: Literal["lift", "reverse"] | None = Field(
        None, description="between passes: 'lift' (default) unloads at the end, moves the "
        "counter-body back to the start and loads again; 'reverse' rolls back over the track"
    )
    lift_increments: StepCount | None = Field(
        None, description="increments of each unloading and reloading between lifted passes "
        "(default 2)"
    )

    @field_validator("direction")
    @classmethod
    def _normalise(cls, value: tuple[float, float]) -> tuple[float, float]:
        return unit_vector(value)

    @property
    def pass_count(self) -> int:
        """Number of passes (``passes``, default 1)."""
        return self.passes or 1


Segment = Annotated[Load | Unload | Hold | Roll, Field(discriminator="kind")]


# --------------------------------------------------------------------------- surface traction
class Friction(Model):
    """Shear traction q = μ p on the contact, along one direction (full sliding).

    The traction acts on the surface of body 1 (the half-space) along ``direction``: where the
    counter-body slides over body 1 with velocity v (relative to body 1), friction drags body
    1's surface along v, so ``direction`` = v / |v|. In rolling, μ is the traction
    coefficient Q/P and q = μ p everywhere in the contact (the full-slip limit of tractive
    rolling); ``direction`` along the rolling direction means the counter-body drags body 1's
    surface forward (its own surface moves faster than body 1's). The normal-tangential
    coupling is neglected: the tangential traction does not change the contact pressure,
    exact when the pair's Dundurs constant β is 0 (elastically similar bodies, as steel on
    steel; Johnson, Contact Mechanics, 1985, §5.1, §7.1); against a rigid counter-body
    (|β| = (1 − 2ν)/(2(1 − ν)) = 0.29 for ν = 0.3) an approximation.
    """

    coefficient: NonNegativeFloat = Field(
        description="friction (or traction) coefficient μ = q / p, >= 0"
    )
    direction: tuple[FiniteFloat, FiniteFloat] = Field(
        (1.0, 0.0),
        description="direction (d1, d2) of the shear traction on body 1 in the surface plane, "
        "normalised",
    )

    @field_validator("direction")
    @classmethod
    def _normalise(cls, value: tuple[float, float]) -> tuple[float, float]:
        return unit_vector(value)


# --------------------------------------------------------------------------- options
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


class Output(Model):
    """What the store writes: which variables, how often the volume fields, compression.

    Per-step scalars and surface fields are stored at every step; volume fields every
    ``volume_every`` steps and at the last step (NaN at the other steps).
    """

    fields: tuple[FieldName, ...] | None = Field(
        None,
        description="variables to store (default: all, except for an elastic body the plastic "
        "ones, which would hold zeros: residual_displacement, plastic_strain, "
        "equivalent_plastic_strain, residual_stress, yield_stress)",
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


class InitialState(Model):
    """Start from a state stored by another run (a dent made by an indentation, then rolled).

    The plastic strain tensor and the equivalent plastic strain of the stored step are taken
    (interpolated onto this case's body grid when the grids differ); the residual stress and the
    residual surface displacement follow from them on this grid. The run file records the
    source's case id and step.
    """

    run: Path = Field(description="run file of the source (relative to the case file)")
    step: int = Field(
        -1, description="which stored step: 0, 1, ... from the first, -1, -2, ... from the last"
    )
    offset: tuple[FiniteFloat, FiniteFloat] = Field(
        (0.0, 0.0), description="shift of the source's body frame in this case's frame [m]"
    )


# --------------------------------------------------------------------------- case
class Case(Model):
    """One run: bodies, surface, grid, load path, solver options, output."""

    name: str = Field(
        pattern=r"^[A-Za-z0-9][A-Za-z0-9_.-]*$",
        description="case name: letters, digits, '-', '_' and '.' (the output file name)",
    )
    description: str = Field("", description="free text")
    body: Body = Field(description="the elastic-plastic body (table [body])")
    counterbody: Counterbody = Field(description="the counter-body (table [counterbody])")
    surface: Surface = Field(Smooth(), description="surface of body 1, chosen by 'kind'")
    grid: Grid = Field(description="surface cells and cuboid layers (table [grid])")
    load_path: tuple[Segment, ...] = Field(
        min_length=1, description="load path segments ([[load_path]]), each chosen by 'kind'"
    )
    solver: SolverOptions = Field(SolverOptions(), description="tolerances and iteration limits")
    output: Output = Field(Output(), description="what the run file stores")
    initial_state: InitialState | None = Field(
        None, description="start from a stored run's state (table initial_state)"
    )
    friction: Friction | None = Field(
        None, description="shear traction q = μ p on the contact (table [friction])"
    )

    # -- derived quantities ------------------------------------------------------------------
    def stored_fields(self) -> tuple[str, ...]:
        """Return the variables the run file stores: ``output.fields`` or the default (Output)."""
        if self.output.fields is not None:
            return tuple(self.output.fields)
        every = SCALAR_FIELDS + SURFACE_FIELDS + VOLUME_FIELDS
        if self.friction is None:
            every = tuple(name for name in every if name not in FRICTION_FIELDS)
        if getattr(self.body.hardening, "kinematic", None) is None:
            every = tuple(name for name in every if name not in KINEMATIC_FIELDS)
        if isinstance(self.body.hardening, Elastic):
            return tuple(name for name in every if name not in PLASTIC_FIELDS)
        return every

    def canonical_json(self) -> str:
        """Return the case as JSON with sorted keys and no spaces (non-finite as strings)."""
        return json.dumps(json.loads(self.model_dump_json()), sort_keys=True, separators=(",", ":"))

    def identity(self) -> dict[str, Any]:
        """Return the fields that determine the stored numbers (:data:`NOT_IN_IDENTITY` left out).

        Nested dict of the case's JSON form without its name, description, thread count and
        compression level, and with a measured surface's file named by the SHA-256 of its
        contents rather than by its path: two cases with the same identity write the same
        numbers.
        """
        data = json.loads(self.model_dump_json())
        for dotted in NOT_IN_IDENTITY:
            _drop(data, dotted, lambda value: True)
        for segment in data.get("load_path", ()):  # options added later, absent when unset
            for key in OPTIONAL_SEGMENT_KEYS:
                if segment.get(key, ...) is None:
                    del segment[key]
        for dotted in OPTIONAL_TABLES:  # absent: the id of a case written before they existed
            _drop(data, dotted, lambda value: value is None)
        for dotted, default in DEFAULTS_LEFT_OUT.items():  # the same, for options at default
            _drop(data, dotted, lambda value, default=default: value == default)
        if isinstance(self.surface, Measured) and (digest := _file_digest(self.surface.path)):
            # the heights are what count: the same file moved keeps the id, an edited one not
            data["surface"]["path"] = f"sha256:{digest}"
        if self.initial_state is not None and (source := _run_case_id(self.initial_state.run)):
            # the source's identity counts, not where its file lies
            data["initial_state"]["run"] = f"case_id:{source}"
        return data

    @property
    def case_id(self) -> str:
        """First 12 hex digits of the SHA-256 of the canonical JSON of :meth:`identity`.

        It names the run in its file and in campaign manifests; a stored run of another id is
        never overwritten unless asked (``sacflow run --overwrite``).
        """
        text = json.dumps(self.identity(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()[:12]

    @property
    def max_load(self) -> float:
        """Largest target load of the load segments [N]."""
        return max((s.to for s in self.load_path if isinstance(s, Load)), default=0.0)

    def hertz(self) -> HertzContact:
        """Hertz estimate at :attr:`max_load`.

        Contact modulus of body and counter-body; effective radius per direction from both
        bodies' principal radii, and their geometric mean when the two differ.
        """
        r1, r2 = self.effective_radii()
        return hertz_contact(self.max_load, math.sqrt(r1 * r2), self.contact_modulus())

    def contact_modulus(self) -> float:
        """Contact modulus E* of body and counter-body [Pa] (rigid counter-body: E, ν only)."""
        cb = self.counterbody
        return composite_modulus(self.body.E, self.body.nu, cb.E, cb.nu or 0.0)

    def effective_radii(self) -> tuple[float, float]:
        """Effective radii of curvature (R1, R2) along x1, x2 of the two bodies [m]."""
        r1, r2 = (
            effective_radius(rb, rc)
            for rb, rc in zip(self.body.radii, self.counterbody.principal_radii, strict=True)
        )
        return (r1, r2)

    def window_extent(self) -> tuple[float, float]:
        """Full size (L1, L2) of the contact window [m]."""
        if self.grid.extent is not None:
            return self.grid.extent
        size = 2.0 * self.grid.half_width * self.hertz().a
        return (size, size)

    def cell_size(self) -> tuple[float, float]:
        """Surface cell size (dx1, dx2) [m]."""
        l1, l2 = self.window_extent()
        return (l1 / self.grid.nx, l2 / self.grid.ny)

    # -- case-level checks -------------------------------------------------------------------
    @model_validator(mode="after")
    def _check_load_path(self) -> Case:
        current = 0.0
        for i, seg in enumerate(self.load_path):
            where = f"load_path.{i}"
            if i == 0 and not isinstance(seg, Load):
                raise field_error(f"{where}.kind", 'the first segment must be kind = "load"')
            if isinstance(seg, Load) and seg.to <= current:
                raise field_error(
                    f"{where}.to", f"a load segment must raise the load above {current:g} N"
                )
            if isinstance(seg, Unload) and seg.to >= current:
                raise field_error(
                    f"{where}.to", f"an unload segment must lower the load below {current:g} N"
                )
            if isinstance(seg, Hold | Roll) and current <= 0.0:
                raise field_error(
                    f"{where}.kind", f"a {seg.kind} segment needs a positive load; load first"
                )
            current = getattr(seg, "to", current)
        return self

    @model_validator(mode="after")
    def _check_friction_fields(self) -> Case:
        asked = set(self.output.fields or ()) & set(FRICTION_FIELDS)
        if self.friction is None and asked:
            raise field_error("output.fields", f"{', '.join(sorted(asked))} needs a [friction] "
                              "table (a shear traction); add one or remove the field")
        asked = set(self.output.fields or ()) & set(KINEMATIC_FIELDS)
        if getattr(self.body.hardening, "kinematic", None) is None and asked:
            raise field_error("output.fields", f"{', '.join(sorted(asked))} needs kinematic "
                              "hardening ([body.hardening.kinematic]); add it or remove the field")
        return self

    @model_validator(mode="after")
    def _check_initial_state(self) -> Case:
        if self.initial_state is not None and self.body.initial_hardening is not None:
            raise field_error("body.initial_hardening", "not with initial_state: the hardening "
                              "comes from the stored run; remove one of them")
        if self.initial_state is not None and self.body.hardening.law == "elastic":
            raise field_error("initial_state", "an elastic body keeps no plastic state; give a "
                              "plastic hardening law or remove initial_state")
        return self

    @model_validator(mode="after")
    def _check_grid(self) -> Case:
        a = self._contact_radius()
        radius = self.hertz().radius
        if a > MAX_CONTACT_TO_RADIUS * radius:
            raise field_error(
                "counterbody.radius",
                f"the Hertz contact radius at the largest load ({self.max_load:.4g} N) is "
                f"a = {1e6 * a:.4g} µm, {a / radius:.3g} times the effective radius of "
                f"curvature R = {1e6 * radius:.4g} µm: half-space contact theory needs a small "
                f"against R (a/R <= {MAX_CONTACT_TO_RADIUS}); check the radii (in m) and the "
                "load (in N)",
            )
        l1, l2 = self.window_extent()
        if min(l1, l2) < 2.0 * MIN_HALF_WIDTH * a:
            raise self._window_error(a)
        for field, n, length in (("grid.nx", self.grid.nx, l1), ("grid.ny", self.grid.ny, l2)):
            cells = 2.0 * a * n / length
            if cells < MIN_CELLS_PER_DIAMETER:
                n_min = math.ceil(MIN_CELLS_PER_DIAMETER * length / (2.0 * a) * (1 - 1e-12))
                raise field_error(
                    field,
                    f"only {cells:.3g} cells across the Hertz contact diameter "
                    f"2a = {2e6 * a:.4g} µm (need {MIN_CELLS_PER_DIAMETER}); "
                    f"use {field} >= {n_min} or a smaller window",
                )
        self._check_layers()
        self._check_track()
        return self

    def _check_track(self) -> None:
        """Check that the body grid, which covers every load position, stays within MAX_CELLS.

        The positions are those :func:`sacflow.solver.layout.plan_steps` gives at the segments' ends
        (a roll's direction is normalised by its model; passes stay on the same track).
        """
        cell = self.cell_size()
        position = [0.0, 0.0]
        low, high = list(position), list(position)
        for i, seg in enumerate(self.load_path):
            field = f"load_path.{i}.at"
            if isinstance(seg, Roll):
                position = [x + seg.distance * d
                            for x, d in zip(position, seg.direction, strict=True)]
                field = f"load_path.{i}.distance"
            elif (at := getattr(seg, "at", None)) is not None:
                position = [float(at[0]), float(at[1])]
            for axis in (0, 1):
                low[axis], high[axis] = min(low[axis], position[axis]), max(high[axis],
                                                                            position[axis])
                cells = (high[axis] - low[axis]) / cell[axis]
                if not cells <= MAX_CELLS:
                    raise field_error(
                        field,
                        f"the load travels {high[axis] - low[axis]:.3g} m along x{axis + 1}, "
                        f"{cells:.3g} surface cells of {cell[axis]:.3g} m; the body grid covers "
                        f"the whole track and holds at most {MAX_CELLS} cells along an axis: "
                        "shorten the track or coarsen the grid",
                    )

    def _check_layers(self) -> None:
        """Check that a given box depth makes cuboid layers of a usable shape (MIN_LAYER_ASPECT)."""
        if self.grid.depth is None:
            return
        cell = min(self.cell_size())
        thickness = self.grid.depth / self.grid.nz
        if not MIN_LAYER_ASPECT <= thickness / cell <= MAX_LAYER_ASPECT:
            low, high = (k * cell * self.grid.nz for k in (MIN_LAYER_ASPECT, MAX_LAYER_ASPECT))
            raise field_error(
                "grid.depth",
                f"cuboid layers {thickness:.3g} m thick (grid.depth / grid.nz) for "
                f"{cell:.3g} m surface cells: the influence coefficients lose their accuracy; "
                f"use grid.depth between {low:.3g} and {high:.3g} m for grid.nz = "
                f"{self.grid.nz}, or omit grid.depth",
            )

    def _contact_radius(self) -> float:
        """Hertz contact radius at max load, or a field error when it cannot be estimated."""
        try:
            a = self.hertz().a
        except ValueError:
            raise field_error(
                "counterbody.radius",
                "both bodies are flat in some direction; give a finite radius to "
                "counterbody.radius/radii or body.radii",
            ) from None
        except ArithmeticError:
            a = math.nan
        if not (0.0 < a < math.inf) or not math.isfinite(max(self.window_extent()) / a):
            raise field_error(
                "load_path",
                f"the Hertz contact radius at the maximum load is not usable (a = {a:g} m); "
                "check loads, moduli and radii",
            )
        return a

    def _window_error(self, a: float) -> PydanticCustomError:
        where = f"Hertz contact radius a = {1e6 * a:.4g} µm at {self.max_load:g} N"
        if self.grid.extent is None:
            return field_error(
                "grid.half_width",
                f"the window half-width must be at least {MIN_HALF_WIDTH} a ({where}); "
                f"use grid.half_width >= {MIN_HALF_WIDTH}",
            )
        side = 2.0 * MIN_HALF_WIDTH * a
        return field_error(
            "grid.extent",
            f"the window must be at least {2 * MIN_HALF_WIDTH} a = {1e6 * side:.4g} µm wide "
            f"({where}); use grid.extent >= [{side:.3e}, {side:.3e}] or remove it",
        )


def _finite_json(value: Any) -> Any:
    """Replace non-finite floats by the strings pydantic accepts back ("Infinity", ...)."""
    if isinstance(value, dict):
        return {k: _finite_json(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_finite_json(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return "NaN" if math.isnan(value) else ("Infinity" if value > 0 else "-Infinity")
    return value


def _file_digest(path: Path) -> str | None:
    """SHA-256 of a file's contents (first 16 hex digits), or None when it cannot be read."""
    try:
        with open(path, "rb") as f:
            return hashlib.file_digest(f, "sha256").hexdigest()[:16]
    except OSError:
        return None


def _run_case_id(path: Path) -> str | None:
    """Return the ``case_id`` attribute of a run file, or None when it cannot be read."""
    try:
        import netCDF4  # only for cases that start from a stored run

        with netCDF4.Dataset(path) as nc:
            return str(nc.getncattr("case_id"))
    except (OSError, AttributeError, RuntimeError):
        return None


def identity_differences(stored: dict[str, Any], current: dict[str, Any]) -> list[str]:
    """Dotted paths where two case identities (:meth:`Case.identity`) differ, with both values.

    Returns lines such as ``"grid.nx: 128 -> 32"``, in path order.
    """
    from sacflow.config.dotted import flatten

    a, b = flatten(stored), flatten(current)
    missing = "(absent)"
    return [
        f"{key}: {json.dumps(a.get(key, missing))} -> {json.dumps(b.get(key, missing))}"
        for key in sorted(a.keys() | b.keys())
        if a.get(key, missing) != b.get(key, missing)
    ]


def case_json_schema() -> dict[str, Any]:
    """Return the JSON schema of :class:`Case`, strictly valid JSON (no bare Infinity)."""
    return _finite_json(Case.model_json_schema())


# --------------------------------------------------------------------------- campaign
#: Pattern shared by case and campaign names (they become file names).
NAME_PATTERN = r"^[A-Za-z0-9][A-Za-z0-9_.-]*$"


class Sweep(Model):
    """One sweep block: the ``product`` of its parameter lists, or their ``zip``.

    Keys are dotted case paths with the ``--set`` syntax (``"load_path.0.to"``,
    ``"grid.nx"``); values are lists of values for that field.
    """

    mode: Literal["product", "zip"] = Field(
        description='"product": every combination of the lists; "zip": the lists side by side'
    )
    parameters: dict[str, Annotated[tuple[Any, ...], Field(min_length=1)]] = Field(
        min_length=1, description='dotted case paths -> lists of values, e.g. "grid.nx" = [32, 48]'
    )

    @model_validator(mode="after")
    def _check_parameters(self) -> Sweep:
        for key in self.parameters:
            keys = key.split(".")
            if not all(k and k == k.strip() for k in keys):
                raise field_error(
                    "parameters", f'"{key}" is not a dotted path like "grid.nx" or "load_path.0.to"'
                )
        sizes = {key: len(values) for key, values in self.parameters.items()}
        if self.mode == "zip" and len(set(sizes.values())) > 1:
            got = ", ".join(f"{key}: {n}" for key, n in sizes.items())
            raise field_error(
                "parameters",
                f"zip needs lists of equal length (got {got}); make them equal "
                'or use mode = "product"',
            )
        return self


class Campaign(Model):
    """A parametric study: a base case and sweep blocks, combined as a product of blocks."""

    name: str = Field(
        pattern=NAME_PATTERN,
        description="campaign name: letters, digits, '-', '_', '.' (prefix of the case names)",
    )
    description: str = Field("", description="free text")
    base: str | dict[str, Any] = Field(
        description="base case: an inline table [base], or a case file path relative to "
        "the campaign file"
    )
    sweep: tuple[Sweep, ...] = Field(
        min_length=1, description="sweep blocks ([[sweep]]), combined as a product of blocks"
    )

    @model_validator(mode="after")
    def _check_sweep(self) -> Campaign:
        seen: list[tuple[int, str]] = []
        for index, block in enumerate(self.sweep):
            for key in block.parameters:
                if key.split(".")[0] == "name":
                    raise field_error(
                        f"sweep.{index}.parameters",
                        '"name" cannot be swept: each case is named from the campaign name '
                        "and its parameters",
                    )
                for other_index, other in seen:
                    if _overlap(key, other):
                        raise field_error(
                            f"sweep.{index}.parameters",
                            f'"{key}" overlaps "{other}" of sweep.{other_index}; '
                            "sweep each field in one place",
                        )
                seen.append((index, key))
        return self


def _overlap(a: str, b: str) -> bool:
    """Tell whether one dotted path is the other or contains it (``grid`` and ``grid.nx``)."""
    ka, kb = a.split("."), b.split(".")
    n = min(len(ka), len(kb))
    return ka[:n] == kb[:n]


__all__ += ["Campaign", "NAME_PATTERN", "Sweep"]
