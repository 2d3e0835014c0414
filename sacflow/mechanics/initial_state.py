"""Initial states of the body before any contact: depth profiles to arrays, and their checks.

A body may start with a residual stress ``σ11(x3), σ22(x3)`` (case hardening) and an
equivalent plastic strain ``p0(x3)`` (a work-hardened layer): :class:`sacflow.config.schema.
InitialResidualStress` and :class:`sacflow.config.schema.InitialHardening`. Both are piecewise
linear
in depth, constant beyond their first and last points, and evaluated at the cuboid centres.
No I/O.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike

from sacflow.errors import SacflowError
from sacflow.mechanics.hardening import HardeningLaw
from sacflow.mechanics.stress_measures import von_mises

__all__ = [
    "InitialStateError",
    "InitialYieldError",
    "StoredState",
    "check_initial_yield",
    "initial_equivalent_plastic_strain",
    "initial_stress",
    "MappedState",
    "map_state",
]

#: Relative slack of the initial yield check (the profile may sit on the yield surface).
_YIELD_SLACK = 1e-12


class InitialYieldError(SacflowError):
    """The initial residual stress exceeds the yield stress somewhere in the box."""


class ResidualStressProfile(Protocol):
    """σ11(x3), σ22(x3) at the points ``depth`` (the schema's ``InitialResidualStress``)."""

    @property
    def depth(self) -> Sequence[float]:
        """Depths of the points [m], increasing."""

    @property
    def s11(self) -> Sequence[float]:
        """σ11 at the points [Pa]."""

    @property
    def s22(self) -> Sequence[float]:
        """σ22 at the points [Pa]."""


class HardeningProfile(Protocol):
    """p0(x3) at the points ``depth`` (the schema's ``InitialHardening``)."""

    @property
    def depth(self) -> Sequence[float]:
        """Depths of the points [m], increasing."""

    @property
    def equivalent_plastic_strain(self) -> Sequence[float]:
        """Equivalent plastic strain at the points."""


def _profile(depth: ArrayLike, values: ArrayLike, x3: np.ndarray) -> np.ndarray:
    """Linear interpolation in depth, constant beyond the ends (``np.interp``)."""
    out: np.ndarray = np.interp(x3, np.asarray(depth, dtype=float),
                                np.asarray(values, dtype=float))
    return out


def initial_stress(profile: ResidualStressProfile | None, x3: np.ndarray) -> np.ndarray | None:
    """Return the initial residual stress at the layers ``x3``, shape (nz, 6), or None.

    Parameters
    ----------
    profile : InitialResidualStress or None
        ``depth``, ``s11``, ``s22`` (the schema model).
    x3 : ndarray
        Depths of the cuboid centres [m].
    """
    if profile is None:
        return None
    out = np.zeros((np.size(x3), 6))
    out[:, 0] = _profile(profile.depth, profile.s11, x3)
    out[:, 1] = _profile(profile.depth, profile.s22, x3)
    return out


def initial_equivalent_plastic_strain(profile: HardeningProfile | None,
                                      x3: np.ndarray) -> np.ndarray:
    """Return the initial equivalent plastic strain at the layers ``x3`` (zeros if no profile)."""
    if profile is None:
        return np.zeros(np.size(x3))
    return _profile(profile.depth, profile.equivalent_plastic_strain, x3)


def check_initial_yield(law: HardeningLaw, stress: np.ndarray,
                        equivalent_plastic_strain: np.ndarray, x3: np.ndarray) -> None:
    """Refuse an initial residual stress above the initial yield stress of its layer.

    Raises
    ------
    InitialYieldError
        Naming the depth, the von Mises stress of the profile and the yield stress there.
    """
    q = von_mises(stress)
    yield_stress = np.asarray(law.yield_stress(equivalent_plastic_strain, x3), dtype=float)
    over = np.flatnonzero(q > yield_stress * (1.0 + _YIELD_SLACK))
    if over.size:
        k = int(over[0])
        raise InitialYieldError(
            f"body.initial_residual_stress: at depth {x3[k] * 1e6:.4g} µm its von Mises stress "
            f"{q[k] * 1e-6:.4g} MPa exceeds the yield stress {yield_stress[k] * 1e-6:.4g} MPa "
            "(with body.initial_hardening); a residual stress cannot exceed it: lower the "
            "profile or raise the initial hardening"
        )


@dataclass(frozen=True)
class StoredState:
    """The plastic state of a stored run at one step, on its own body grid.

    Attributes
    ----------
    x1, x2, x3 : ndarray
        Cell centres of the source's body grid [m].
    plastic_strain : ndarray, shape (n1, n2, n3, 6)
        Plastic strain tensor (tensor shears).
    equivalent_plastic_strain : ndarray, shape (n1, n2, n3)
        Equivalent plastic strain.
    case_id, step : str, int
        The source run's case id and the step number taken.
    backstress : ndarray, shape (n1, n2, n3, 6), optional
        Backstress tensor of a source with kinematic hardening [Pa]; None when the source has
        none (isotropic hardening: its backstress is zero).
    """

    x1: np.ndarray
    x2: np.ndarray
    x3: np.ndarray
    plastic_strain: np.ndarray
    equivalent_plastic_strain: np.ndarray
    case_id: str
    step: int
    backstress: np.ndarray | None = None


@dataclass(frozen=True)
class MappedState:
    """A stored plastic state on the new body grid (see :func:`map_state`)."""

    plastic_strain: np.ndarray
    equivalent_plastic_strain: np.ndarray
    backstress: np.ndarray | None


def map_state(state: StoredState, x1: np.ndarray, x2: np.ndarray, x3: np.ndarray,
              offset: tuple[float, float]) -> MappedState:
    """Return the stored internal variables (plastic strain, εp, backstress) on another grid.

    The source's frame is shifted by ``offset``. On the same cell centres (to
    :data:`_SAME_GRID_RTOL` of a cell) the arrays are copied; otherwise they are interpolated
    linearly between the source's cell centres in x1, x2 and x3, and taken as zero (virgin
    material) outside the source's box.

    Raises
    ------
    InitialStateError
        When a plastic cell of the source lies outside the new grid: its strain would be lost.
    """
    sx1, sx2 = state.x1 + offset[0], state.x2 + offset[1]
    _check_cover(state, (sx1, sx2, state.x3), (x1, x2, x3))
    parts = [state.plastic_strain, state.equivalent_plastic_strain[..., None]]
    if state.backstress is not None:
        parts.append(state.backstress)
    if _same(sx1, x1) and _same(sx2, x2) and _same(state.x3, x3):
        mapped = np.concatenate(parts, axis=-1)
    else:
        from scipy.interpolate import RegularGridInterpolator  # chained cases on another grid

        points = np.stack(np.meshgrid(x1, x2, x3, indexing="ij"), axis=-1)
        grid = (sx1, sx2, state.x3)
        mapped = RegularGridInterpolator(grid, np.concatenate(parts, axis=-1),
                                         bounds_error=False, fill_value=0.0)(points)
    backstress = None if state.backstress is None else mapped[..., 7:13].copy()
    return MappedState(mapped[..., :6].copy(), np.maximum(mapped[..., 6], 0.0), backstress)


#: Relative tolerance (of a cell) under which two grids' centres are the same.
_SAME_GRID_RTOL = 1e-9


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    if a.shape != b.shape:
        return False
    cell = float(np.min(np.diff(b))) if b.size > 1 else max(abs(float(b[0])), 1.0)
    return bool(np.all(np.abs(a - b) <= _SAME_GRID_RTOL * cell))


def _check_cover(state: StoredState, source: tuple[np.ndarray, ...],
                 target: tuple[np.ndarray, ...]) -> None:
    plastic = state.equivalent_plastic_strain > 0.0
    if not plastic.any():
        return
    for axis, (s, t, name) in enumerate(zip(source, target, ("x1", "x2", "x3"), strict=True)):
        other = tuple(i for i in range(3) if i != axis)
        used = s[plastic.any(axis=other)]
        half = 0.5 * (float(t[1] - t[0]) if t.size > 1 else 0.0)
        low, high = float(t[0]) - half, float(t[-1]) + half
        if used.min() < low - half or used.max() > high + half:
            raise InitialStateError(
                f"initial_state: the source's plastic zone spans {name} in "
                f"[{used.min():.4g}, {used.max():.4g}] m but this case's body grid covers "
                f"[{low:.4g}, {high:.4g}] m; widen the grid (grid.extent or half_width, "
                "grid.depth) or change initial_state.offset"
            )


class InitialStateError(SacflowError):
    """The stored state a case starts from cannot be mapped onto its grid."""
