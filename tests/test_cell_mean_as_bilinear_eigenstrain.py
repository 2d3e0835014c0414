"""The lateral cell mean of a cuboid's stress is the stress of a bilinear eigenstrain.

The half-space is invariant under lateral translation, so averaging the stress of a cell's
uniform eigenstrain over the target cell's lateral extent, ``(1/dx²) ∫∫ K(x + t) dt``, is the
stress at the target's centre of the cell convolved with a box of its own size: a pyramid
``(1 − |u1|/dx)(1 − |u2|/dx)`` that reaches the centres of the eight neighbouring cells.
Summed over the cells, the operator with the cell mean (``stress_sampling`` > 1, laterally)
collocates at the centres the plastic strain interpolated bilinearly between them, an
eigenstrain varying inside each cell.
docs/convergence.md uses this to read the press's runs with 2³ and 3³ stress points.

Independent check: the pyramid built directly from thin cuboids (Chiu's closed form, each
weighted by the pyramid at its centre) against the mean of the whole cell's closed form over
target points; both rules are second order, so their difference falls fourfold a halving.
"""

from __future__ import annotations

import numpy as np
import pytest

from sacflow.kernels.cuboid import cuboid_stress

E, NU = 219e9, 0.3
MU = E / (2 * (1 + NU))
#: Lateral cell size and layer thickness [m] (the aspect ratio of the shipped grids' cells).
DX, DZ = 2e-6, 1e-6
#: Quadrature levels: (target points per axis of the cell mean, thin cuboids per axis of the
#: pyramid). The thin cuboids are an odd number so that no target lies on one's face.
COARSE, FINE = (8, 11), (32, 41)


def lateral_cell_mean(target: tuple[int, int, int], points: int) -> np.ndarray:
    """Mean of the cell's stress (6 × 6) over ``points²`` lateral points of the target cell."""
    offsets = ((np.arange(points) + 0.5) / points - 0.5) * DX
    t1, t2 = np.meshgrid(offsets, offsets, indexing="ij")
    x3 = np.full_like(t1, target[2] * DZ)
    field = cuboid_stress(target[0] * DX + t1, target[1] * DX + t2, x3,
                          DX / 2, DX / 2, DZ / 2, NU, MU)
    mean: np.ndarray = field.mean(axis=(0, 1))
    return mean


def pyramid_stress(target: tuple[int, int, int], cuboids: int) -> np.ndarray:
    """Stress (6 × 6) at the target's centre of the pyramid eigenstrain of thin cuboids."""
    width = 2 * DX / cuboids
    centres = -DX + (np.arange(cuboids) + 0.5) * width
    heights = 1.0 - np.abs(centres) / DX
    c1, c2 = np.meshgrid(centres, centres, indexing="ij")
    x3 = np.full_like(c1, target[2] * DZ)
    field = cuboid_stress(target[0] * DX - c1, target[1] * DX - c2, x3,
                          width / 2, width / 2, DZ / 2, NU, MU)
    total: np.ndarray = (field * np.outer(heights, heights)[..., None, None]).sum(axis=(0, 1))
    return total


@pytest.mark.parametrize("target", [(0, 0, 0), (1, 0, 1), (1, 2, 1), (2, 0, 0), (0, 0, 2),
                                    (3, 2, 1)])
def test_lateral_cell_mean_is_the_centre_stress_of_the_bilinear_eigenstrain(target):
    scale = float(np.abs(lateral_cell_mean(target, FINE[0])).max())
    misses = [float(np.abs(lateral_cell_mean(target, points) - pyramid_stress(target, cuboids))
                    .max()) / scale for points, cuboids in (COARSE, FINE)]
    assert misses[1] < 3e-3
    assert misses[1] < misses[0] / 8  # second order: 16 × for 4 × the points
    # Not an identity of the kernel: the centre value, the cell's own, is another operator.
    centre = cuboid_stress(target[0] * DX, target[1] * DX, target[2] * DZ,
                           DX / 2, DX / 2, DZ / 2, NU, MU)
    assert float(np.abs(centre - pyramid_stress(target, FINE[1])).max()) / scale > 1e-2
