"""Grid layout and step planning of a case: pure functions, no operators, no I/O.

A load path is expanded into increments (:func:`plan_steps`): load and unload segments change
the normal load in equal steps, hold segments repeat it, roll segments move it over the body at
constant load. The body-fixed grid (:func:`body_grid`) is the contact window swept along every
load position of the path, each placed on its nearest cell; its cuboid box is ``grid.depth``
deep, or as deep as the elastic (Hertz) von Mises stress at the maximum load reaches yield plus
a margin (:func:`auto_depth`). :class:`sacflow.solver.simulation.Simulation` and the memory
estimate (:mod:`sacflow.solver.memory_estimate`) both lay a run out through these functions; the
load path comes as plain segments (:class:`Ramp`, :class:`Hold`, :class:`Roll`), translated from
a case by :mod:`sacflow.config.solver_inputs`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np

from sacflow.errors import SacflowError
from sacflow.mechanics.hardening import HardeningLaw
from sacflow.mechanics.hertz import hertz_axis_stress

__all__ = [
    "BodyGrid",
    "Hold",
    "Ramp",
    "Roll",
    "Segment",
    "StepPlan",
    "auto_depth",
    "body_grid",
    "halfway",
    "layer_centres",
    "plan_steps",
]

#: Depths sampled (in Hertz contact radii) when sizing the cuboid box.
_DEPTH_SAMPLES = np.linspace(1e-3, 6.0, 3000)
#: Depth of an elastic body's box, in Hertz contact radii (the stored stress field).
ELASTIC_DEPTH = 2.0


@dataclass(frozen=True)
class StepPlan:
    """One increment of the load path: segment index, load [N] and load position [m].

    ``pass_index`` counts the rolling passes of the whole load path from 0 (the steps before the
    first pass and the unloading after a pass belong to that pass, the reloading before a pass
    to it); ``pass_end`` marks the last rolling step of a pass.
    """

    segment: int
    load: float
    position: tuple[float, float]
    pass_index: int = 0
    pass_end: bool = False


@dataclass(frozen=True)
class BodyGrid:
    """Cells of a run: contact ``window`` (nx, ny), ``body`` grid (n1, n2), ``nz`` layers.

    ``origin`` is the body index of the window's first cell when the load is at the origin.
    """

    window: tuple[int, int]
    body: tuple[int, int]
    nz: int
    origin: tuple[int, int] = (0, 0)


@dataclass(frozen=True)
class Ramp:
    """A load or unload segment: the normal load goes to ``to`` [N] in ``increments`` equal steps.

    ``at`` puts the load at a body-frame position [m] first (only while unloaded).
    """

    to: float
    increments: int
    at: tuple[float, float] | None = None


@dataclass(frozen=True)
class Hold:
    """A hold segment: the load stays, ``increments`` times."""

    increments: int


@dataclass(frozen=True)
class Roll:
    """A roll segment: ``pass_count`` passes over ``distance`` [m] along ``direction``.

    Each pass in ``steps`` increments at constant load; between passes the load is lifted
    (``"lift"``: unloaded and reloaded in ``lift_increments`` steps each, None for
    :data:`DEFAULT_LIFT_INCREMENTS`) or rolls back (``"reverse"``).
    """

    distance: float
    steps: int
    direction: tuple[float, float]
    pass_count: int = 1
    between: Literal["lift", "reverse"] | None = None
    lift_increments: int | None = None


#: A segment of the load path.
Segment = Ramp | Hold | Roll


def plan_steps(load_path: Sequence[Segment]) -> list[StepPlan]:
    """Expand load-path segments into increments (load positions exact, not snapped to cells).

    Raises
    ------
    SacflowError
        When a load segment moves the load (``at``) while it is loaded.
    """
    steps: list[StepPlan] = []
    load, pos = 0.0, (0.0, 0.0)
    passes = -1  # index of the last pass begun
    for index, seg in enumerate(load_path):
        if isinstance(seg, Roll):
            pos, load, passes = _roll_passes(steps, index, seg, pos, load, passes)
            continue
        current = max(passes, 0)
        if isinstance(seg, Ramp):
            if seg.at is not None:
                if load > 0.0 and tuple(seg.at) != pos:
                    raise SacflowError(
                        f"load_path.{index}.at: the load cannot jump while loaded; "
                        "use a roll segment to move it"
                    )
                pos = (float(seg.at[0]), float(seg.at[1]))
            load = _ramp(steps, index, load, seg.to, seg.increments, pos, current)
        else:
            steps.extend(StepPlan(index, load, pos, current) for _ in range(seg.increments))
    return steps


#: Increments of each unloading and reloading between lifted passes (``Roll.lift_increments``).
DEFAULT_LIFT_INCREMENTS = 2


def _ramp(steps: list[StepPlan], index: int, start: float, end: float, increments: int,
          pos: tuple[float, float], pass_index: int) -> float:
    """Append ``increments`` steps taking the load from ``start`` to ``end``; return ``end``."""
    for k in range(1, increments + 1):
        steps.append(StepPlan(index, start + (end - start) * k / increments, pos, pass_index))
    return end


def _roll_passes(steps: list[StepPlan], index: int, seg: Roll, pos: tuple[float, float],
                 load: float, passes: int) -> tuple[tuple[float, float], float, int]:
    """Append the passes of a roll segment; return the position, load and last pass index.

    Between passes the load is lifted (unloaded at the end of the track, moved back to its
    start unloaded, loaded again) or, with ``between = "reverse"``, the next pass rolls back.
    """
    start = pos
    lift = seg.lift_increments or DEFAULT_LIFT_INCREMENTS
    for k in range(seg.pass_count):
        passes += 1
        backwards = seg.between == "reverse" and k % 2 == 1
        if k > 0 and seg.between != "reverse":  # lift: unload, back to the start, reload
            _ramp(steps, index, load, 0.0, lift, pos, passes - 1)
            pos = start
            _ramp(steps, index, 0.0, load, lift, pos, passes)
        first = pos
        sign = -1.0 if backwards else 1.0
        for i in range(1, seg.steps + 1):
            frac = sign * i / seg.steps
            pos = (first[0] + seg.distance * seg.direction[0] * frac,
                   first[1] + seg.distance * seg.direction[1] * frac)
            steps.append(StepPlan(index, load, pos, passes, i == seg.steps))
    return pos, load, passes


def body_grid(window: tuple[int, int], cell: tuple[float, float], nz: int,
              steps: Sequence[StepPlan]) -> BodyGrid:
    """Return the body-fixed grid: the contact ``window`` (cells) swept along the load positions.

    Each position of ``steps`` (the expanded load path, :func:`plan_steps`) is placed on its
    nearest cell of size ``cell`` [m]; the origin is always covered. ``nz`` cuboid layers.
    """
    nx, ny = window
    positions = np.array([s.position for s in steps] + [(0.0, 0.0)])
    cells = np.rint(positions / np.array(cell)).astype(int)
    low, high = cells.min(axis=0), cells.max(axis=0)
    body = (int(nx + high[0] - low[0]), int(ny + high[1] - low[1]))
    return BodyGrid((nx, ny), body, int(nz), (int(-low[0]), int(-low[1])))


def auto_depth(law: HardeningLaw | None, a: float, p0: float, nu: float,
               plastic_margin: float) -> float:
    """Depth of the cuboid box: where the Hertz von Mises stress at max load falls below yield.

    Uses the on-axis Hertz field (the maximum of von Mises is on the axis for ν ≈ 0.3, Poisson's
    ratio ``nu``) at the maximum load (contact radius ``a``, peak pressure ``p0``), the initial
    yield stress of the hardening ``law`` (None for an elastic body) and the solver's
    ``plastic_margin``; never less than the contact radius. Elastic bodies get
    :data:`ELASTIC_DEPTH` ``a`` (the stored stress field).
    """
    if law is None:
        return ELASTIC_DEPTH * a
    z = _DEPTH_SAMPLES * a
    s_r, s_z = hertz_axis_stress(z, a, p0, nu)
    vm = np.abs(s_r - s_z)
    sy = law.yield_stress(np.zeros_like(z), z)
    above = np.nonzero(vm > sy * (1.0 - plastic_margin))[0]
    if above.size == 0:
        return a
    return max(a, float(z[above[-1]]) * (1.0 + plastic_margin))


def layer_centres(nz: int, thickness: float) -> np.ndarray:
    """Depths [m] of the centres of ``nz`` cuboid layers ``thickness`` thick: (k + ½) Δz."""
    return (np.arange(nz) + 0.5) * thickness


def halfway(start: StepPlan, end: StepPlan) -> StepPlan:
    """Return the plan halfway from ``start`` to ``end`` (a cutback's first half).

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
