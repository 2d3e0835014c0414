"""Where the lateral cells' error of the residual σ11 on the load axis comes from.

Two runs of one case differ in their lateral cells, a coarse lattice and a fine one whose cells
divide each coarse cell into ``r × r`` (same window and layers), or in their increments on one
lattice (``r = 1``: one operator, so no representation part). The residual
stress after unloading is a linear functional of the plastic strain (seed eq. 1.17:
σʳ = Σ_cells K·εp), so the difference of the σ11 on the axis between the runs splits exactly
into

* a **flow** part, ``K_c · (R εp_f − εp_c)``: the coarse operator ``K_c`` applied to the
  difference between the fine run's plastic strain averaged over each coarse cell (``R``) and
  the coarse run's own. It is what the coarse cells' flow, one point per cell, gets wrong about
  the plastic strain; being linear, it is a sum over any partition of the cells into regions,
  which says where in the body the strain that carries the error lies;
* a **representation** part, ``K_f · εp_f − K_c · (R εp_f)``: what representing the same
  plastic strain on the coarse cuboids (and reading the stress on the coarse cells) changes.

The attribution is to where the strain differs, not to why: a stress error anywhere during the
loading changes the flow elsewhere, and the split sees that change where it lands.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from sacflow.compare.fields import column_at, quadratic_at

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["Region", "LateralSplit", "block_average", "axis_s11", "regions_of", "split",
           "strain_change_by_region", "plot_strain_change"]

#: Index of σ11 in the stress's component axis (11, 22, 33, 12, 13, 23).
S11 = 0
#: Percentile of the plastic cells' |εp change| at which the plot's colours saturate.
CHANGE_PERCENTILE = 99.0


@dataclass(frozen=True)
class Region:
    """Cells whose centres lie at ``r_from ≤ r < r_to`` from the axis, ``z_from ≤ x3 < z_to``.

    Bounds in units of the profile's length (the Hertz radius); ``np.inf`` for no bound.
    """

    r_from: float
    r_to: float
    z_from: float
    z_to: float


@dataclass(frozen=True)
class LateralSplit:
    """The σ11 on the axis of two runs and the split of their difference [Pa].

    Each mapping is keyed by the profile depth (in units of the profile's length).
    ``by_region`` holds the flow part of each region; they add up to ``flow``.
    """

    coarse: dict[float, float]
    fine: dict[float, float]
    flow: dict[float, float]
    representation: dict[float, float]
    by_region: dict[Region, dict[float, float]]


def block_average(field: np.ndarray, ratio: int) -> np.ndarray:
    """Average a cell field over blocks of ``ratio × ratio`` lateral cells (leading two axes)."""
    n1, n2 = field.shape[0], field.shape[1]
    if ratio < 1 or n1 % ratio or n2 % ratio:
        raise ValueError(f"a fine lattice of {n1} x {n2} cells is not {ratio} x {ratio} "
                         "cells per coarse cell")
    shape = (n1 // ratio, ratio, n2 // ratio, ratio, *field.shape[2:])
    return field.reshape(shape).mean(axis=(1, 3))


def axis_s11(stress: np.ndarray, coords: Sequence[np.ndarray], axis: tuple[float, float],
             depths: Sequence[float]) -> dict[float, float]:
    """σ11 on the vertical line through ``axis`` at ``depths`` [m], keyed by depth.

    NaN below the deepest layer centre or above the first. The column is interpolated to the
    axis by :func:`~sacflow.compare.fields.quadratic_at` and along depth by
    :func:`~sacflow.compare.fields.column_at`, as the convergence study reads its profile.
    """
    x1, x2, x3 = coords
    column = quadratic_at(stress[..., S11], (x1, x2), axis)
    return dict(zip((float(z) for z in depths), column_at(column, x3, depths), strict=True))


def regions_of(coords: Sequence[np.ndarray], axis: tuple[float, float], length: float,
               regions: Sequence[Region]) -> dict[Region, np.ndarray]:
    """Boolean cell masks of ``regions`` (bounds times ``length`` [m]) on a lattice.

    Raises ``ValueError`` unless the regions partition the cells (each cell in exactly one).
    """
    x1, x2, x3 = coords
    radius = np.hypot(*np.meshgrid(x1 - axis[0], x2 - axis[1], indexing="ij"))[:, :, None]
    depth = x3[None, None, :]
    masks = [np.broadcast_to(
        (radius >= reg.r_from * length) & (radius < reg.r_to * length)
        & (depth >= reg.z_from * length) & (depth < reg.z_to * length),
        (len(x1), len(x2), len(x3))) for reg in regions]
    if not np.all(sum(mask.astype(int) for mask in masks) == 1):
        raise ValueError("the regions must cover every cell once")
    return dict(zip(regions, masks, strict=True))


def split(coarse: tuple[np.ndarray, np.ndarray], fine: tuple[np.ndarray, np.ndarray],
          operator: Callable[[np.ndarray], np.ndarray],
          coords: tuple[Sequence[np.ndarray], Sequence[np.ndarray]],
          axis: tuple[float, float], length: float, depths: Sequence[float],
          regions: Sequence[Region]) -> LateralSplit:
    """Split the fine-minus-coarse σ11 on the axis into flow and representation parts.

    Parameters
    ----------
    coarse, fine : (ndarray, ndarray)
        Each run's plastic strain ``[x1, x2, x3, 6]`` and residual stress ``[x1, x2, x3, 6]``
        (as the run computed it) at the same step.
    operator : callable
        The coarse lattice's plastic strain → residual stress operator, with the run's own
        settings (stress sampling, traction beyond the box).
    coords : (coarse, fine)
        Each lattice's cell-centre coordinates (x1, x2, x3) [m].
    axis : (float, float)
        The load axis (x1, x2) [m].
    length : float
        Unit of ``depths`` and of the regions' bounds [m] (the Hertz radius).
    depths : sequence of float
        Depths of the profile in units of ``length``.
    regions : sequence of Region
        A partition of the coarse cells.
    """
    eps_c, stress_c = coarse
    eps_f, stress_f = fine
    (c1, c2, c3), (f1, f2, f3) = eps_c.shape[:3], eps_f.shape[:3]
    ratio = f1 // c1
    if ratio < 1 or (f1, f2, f3) != (ratio * c1, ratio * c2, c3):
        raise ValueError(f"the fine run's {f1} x {f2} x {f3} cells are not the coarse run's "
                         f"{c1} x {c2} x {c3} with each lateral cell divided into r x r: give "
                         "the coarse run first, and runs whose cells per side are a whole "
                         "multiple of each other with the same layers")
    averaged = block_average(eps_f, ratio)
    points = [d * length for d in depths]

    def profile(stress: np.ndarray, lattice: Sequence[np.ndarray]) -> dict[float, float]:
        values = axis_s11(stress, lattice, axis, points)
        return {d: values[float(z)] for d, z in zip(depths, points, strict=True)}

    on_coarse = profile(stress_c, coords[0])
    on_fine = profile(stress_f, coords[1])
    of_averaged = profile(operator(averaged), coords[0])
    change = averaged - eps_c
    masks = regions_of(coords[0], axis, length, regions)
    by_region = {reg: profile(operator(np.where(mask[..., None], change, 0.0)), coords[0])
                 for reg, mask in masks.items()}
    return LateralSplit(
        coarse=on_coarse, fine=on_fine,
        flow={d: of_averaged[d] - on_coarse[d] for d in depths},
        representation={d: on_fine[d] - of_averaged[d] for d in depths},
        by_region=by_region)


def strain_change_by_region(coarse: np.ndarray, fine: np.ndarray, masks: dict[Region, np.ndarray],
                            cell_volume: float) -> dict[Region, tuple[float, float, float]]:
    """Per region: Σ (R εp_f − εp_c) V, the change of largest magnitude, and εp_c there.

    ``coarse`` and ``fine`` are the two runs' equivalent plastic strain ``[x1, x2, x3]``; a
    region without cells gives zeros.
    """
    change = block_average(fine, fine.shape[0] // coarse.shape[0]) - coarse
    out: dict[Region, tuple[float, float, float]] = {}
    for reg, mask in masks.items():
        cells = np.flatnonzero(mask)
        if cells.size == 0:
            out[reg] = (0.0, 0.0, 0.0)
            continue
        largest = cells[np.argmax(np.abs(change.flat[cells]))]
        out[reg] = (float(change.flat[cells].sum() * cell_volume), float(change.flat[largest]),
                    float(coarse.flat[largest]))
    return out


def plot_strain_change(coarse: np.ndarray, fine: np.ndarray, coords: Sequence[np.ndarray],
                       length: float, contact_radius: float, depths: Sequence[float],
                       reach: tuple[float, float] = (2.5, 3.0)) -> Figure:
    """Plot the coarse run's εp and the fine run's minus it on the section x2 = 0 (the axis).

    ``coarse`` and ``fine`` are the runs' equivalent plastic strain ``[x1, x2, x3]`` (the fine
    one averaged over each coarse cell); on an even lattice the section is the mean of the two
    rows beside the axis. Axes in units of ``length``, out to ``reach`` (half-width, depth);
    dashed lines at ± ``contact_radius``, markers at the profile ``depths`` on the axis.
    """
    from matplotlib.figure import Figure

    x1, x2, x3 = coords
    change = block_average(fine, fine.shape[0] // coarse.shape[0]) - coarse
    rows = np.argsort(np.abs(x2))[: 2 if len(x2) % 2 == 0 else 1]
    fig = Figure(figsize=(10.0, 4.2), layout="constrained")
    axes = fig.subplots(1, 2, sharey=True)
    # The change's colours saturate at its CHANGE_PERCENTILE over the plastic cells: the
    # largest changes, at the contact's edge, would otherwise hide the rest.
    plastic = np.abs(change[coarse > 0.0])
    clip = float(np.percentile(plastic, CHANGE_PERCENTILE)) if plastic.size else 1.0
    panels = ((coarse, "εp of the coarse cells", "viridis", 0.0, float(coarse.max())),
              (change, f"fine (averaged over each coarse cell) − coarse; colours clipped at "
               f"{clip:.2g}", "RdBu_r", -clip, clip))
    extent = (float(x1[0] - (x1[1] - x1[0]) / 2) / length,
              float(x1[-1] + (x1[1] - x1[0]) / 2) / length,
              float(x3[-1] + (x3[1] - x3[0]) / 2) / length, 0.0)
    for ax, (field, title, cmap, low, high) in zip(axes, panels, strict=True):
        section = field[:, rows, :].mean(axis=1).T
        image = ax.imshow(section, extent=extent, cmap=cmap, vmin=low, vmax=high,
                          aspect="auto", interpolation="nearest")
        fig.colorbar(image, ax=ax, shrink=0.9, extend="both" if low < 0.0 else "neither")
        for side in (-1.0, 1.0):
            ax.axvline(side * contact_radius / length, color="k", ls="--", lw=0.8)
        ax.plot([0.0] * len(depths), depths, "k+", ms=8)
        ax.set_xlim(-reach[0], reach[0])
        ax.set_ylim(reach[1], 0.0)
        ax.set_title(title, fontsize="small")
        ax.set_xlabel("x1 / a")
    axes[0].set_ylabel("x3 / a")
    return fig
