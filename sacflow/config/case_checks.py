"""Case-level checks: the rules that tie several tables of a case together.

Each check takes a validated :class:`~sacflow.config.case.Case` (its tables already checked
one by one) and raises :func:`~sacflow.config.base.field_error` naming the field to fix; the
case's model validators call them in order. They refuse a load path in the wrong order, output
fields the case cannot have, an initial state that contradicts the body, and a grid that cannot
resolve the Hertz contact at the largest load (Johnson, Contact Mechanics, 1985, §4.2) or whose
cuboid layers or load track break the influence coefficients.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from pydantic_core import PydanticCustomError

from sacflow.config.base import MAX_CELLS, field_error
from sacflow.config.load_path import Hold, Load, Roll, Unload
from sacflow.config.settings import FRICTION_FIELDS, INHOMOGENEITY_FIELDS, KINEMATIC_FIELDS

if TYPE_CHECKING:
    from sacflow.config.case import Case

__all__ = [
    "MAX_CONTACT_TO_RADIUS",
    "MAX_LAYER_ASPECT",
    "MIN_CELLS_PER_DIAMETER",
    "MIN_HALF_WIDTH",
    "MIN_LAYER_ASPECT",
    "check_grid",
    "check_initial_state",
    "check_load_path",
    "check_output_fields",
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


def check_load_path(case: Case) -> None:
    """Check the order of the segments: load first, loads rise, unloads fall, hold/roll loaded."""
    current = 0.0
    for i, seg in enumerate(case.load_path):
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


def check_output_fields(case: Case) -> None:
    """Check that ``output.fields`` asks for no field the case cannot have.

    A shear traction needs friction, the backstress kinematic hardening, the inclusion fields an
    inhomogeneity.
    """
    asked = set(case.output.fields or ()) & set(FRICTION_FIELDS)
    if case.friction is None and asked:
        raise field_error("output.fields", f"{', '.join(sorted(asked))} needs a [friction] "
                          "table (a shear traction); add one or remove the field")
    asked = set(case.output.fields or ()) & set(KINEMATIC_FIELDS)
    if getattr(case.body.hardening, "kinematic", None) is None and asked:
        raise field_error("output.fields", f"{', '.join(sorted(asked))} needs kinematic "
                          "hardening ([body.hardening.kinematic]); add it or remove the field")
    asked = set(case.output.fields or ()) & set(INHOMOGENEITY_FIELDS)
    if not case.body.inhomogeneity and asked:
        raise field_error("output.fields", f"{', '.join(sorted(asked))} needs an elastic "
                          "inhomogeneity ([[body.inhomogeneity]]); add one or remove the field")


def check_initial_state(case: Case) -> None:
    """Check that a chained case has a plastic body and no initial hardening of its own."""
    if case.initial_state is not None and case.body.initial_hardening is not None:
        raise field_error("body.initial_hardening", "not with initial_state: the hardening "
                          "comes from the stored run; remove one of them")
    if case.initial_state is not None and case.body.hardening.law == "elastic":
        raise field_error("initial_state", "an elastic body keeps no plastic state; give a "
                          "plastic hardening law or remove initial_state")


def check_grid(case: Case) -> None:
    """Check the grid against the Hertz contact at the largest load, the layers and the track."""
    a = _contact_radius(case)
    radius = case.hertz().radius
    if a > MAX_CONTACT_TO_RADIUS * radius:
        raise field_error(
            "counterbody.radius",
            f"the Hertz contact radius at the largest load ({case.max_load:.4g} N) is "
            f"a = {1e6 * a:.4g} µm, {a / radius:.3g} times the effective radius of "
            f"curvature R = {1e6 * radius:.4g} µm: half-space contact theory needs a small "
            f"against R (a/R <= {MAX_CONTACT_TO_RADIUS}); check the radii (in m) and the "
            "load (in N)",
        )
    l1, l2 = case.window_extent()
    if min(l1, l2) < 2.0 * MIN_HALF_WIDTH * a:
        raise _window_error(case, a)
    for field, n, length in (("grid.nx", case.grid.nx, l1), ("grid.ny", case.grid.ny, l2)):
        cells = 2.0 * a * n / length
        if cells < MIN_CELLS_PER_DIAMETER:
            n_min = math.ceil(MIN_CELLS_PER_DIAMETER * length / (2.0 * a) * (1 - 1e-12))
            raise field_error(
                field,
                f"only {cells:.3g} cells across the Hertz contact diameter "
                f"2a = {2e6 * a:.4g} µm (need {MIN_CELLS_PER_DIAMETER}); "
                f"use {field} >= {n_min} or a smaller window",
            )
    _check_layers(case)
    _check_track(case)


def _check_track(case: Case) -> None:
    """Check that the body grid, which covers every load position, stays within MAX_CELLS.

    The positions are those :func:`sacflow.solver.layout.plan_steps` gives at the segments' ends
    (a roll's direction is normalised by its model; passes stay on the same track).
    """
    cell = case.cell_size()
    position = [0.0, 0.0]
    low, high = list(position), list(position)
    for i, seg in enumerate(case.load_path):
        field = f"load_path.{i}.at"
        if isinstance(seg, Roll):
            position = [x + seg.distance * d for x, d in zip(position, seg.direction, strict=True)]
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


def _check_layers(case: Case) -> None:
    """Check that a given box depth makes cuboid layers of a usable shape (MIN_LAYER_ASPECT)."""
    if case.grid.depth is None:
        return
    cell = min(case.cell_size())
    thickness = case.grid.depth / case.grid.nz
    if not MIN_LAYER_ASPECT <= thickness / cell <= MAX_LAYER_ASPECT:
        low, high = (k * cell * case.grid.nz for k in (MIN_LAYER_ASPECT, MAX_LAYER_ASPECT))
        raise field_error(
            "grid.depth",
            f"cuboid layers {thickness:.3g} m thick (grid.depth / grid.nz) for "
            f"{cell:.3g} m surface cells: the influence coefficients lose their accuracy; "
            f"use grid.depth between {low:.3g} and {high:.3g} m for grid.nz = "
            f"{case.grid.nz}, or omit grid.depth",
        )


def _contact_radius(case: Case) -> float:
    """Hertz contact radius at max load, or a field error when it cannot be estimated."""
    try:
        a = case.hertz().a
    except ValueError:
        raise field_error(
            "counterbody.radius",
            "both bodies are flat in some direction; give a finite radius to "
            "counterbody.radius/radii or body.radii",
        ) from None
    except ArithmeticError:
        a = math.nan
    if not (0.0 < a < math.inf) or not math.isfinite(max(case.window_extent()) / a):
        raise field_error(
            "load_path",
            f"the Hertz contact radius at the maximum load is not usable (a = {a:g} m); "
            "check loads, moduli and radii",
        )
    return a


def _window_error(case: Case, a: float) -> PydanticCustomError:
    """Return the error of a window narrower than 2 MIN_HALF_WIDTH a, naming its setting."""
    where = f"Hertz contact radius a = {1e6 * a:.4g} µm at {case.max_load:g} N"
    if case.grid.extent is None:
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
