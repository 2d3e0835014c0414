"""Phase field of elastic inhomogeneities, and the eigenstrain operator's stress convention."""

from __future__ import annotations

import numpy as np
import pytest

from sacflow.kernels.eigenstrain import HalfSpaceEigenstrain
from sacflow.solver.inputs import Inhomogeneity
from sacflow.solver.phase import MATRIX, phase_field, region_mask

E, NU = 210e9, 0.3
N, NZ = 16, 12
X = (np.arange(N) - N / 2 + 0.5) * 1.0  # unit cells, centred on 0
Z = (np.arange(NZ) + 0.5) * 1.0


def test_sphere_takes_the_cells_whose_centre_is_inside():
    sphere = Inhomogeneity("sphere", (0.0, 0.0, 6.0), (3.0, 3.0, 3.0), 2 * E, NU)
    mask = region_mask(sphere, X, X, Z)
    i, j, k = np.meshgrid(X, X, Z, indexing="ij")
    expected = i**2 + j**2 + (k - 6.0) ** 2 <= 9.0
    assert np.array_equal(mask, expected)
    assert mask.sum() == 136  # the 136-cell staircase sphere of radius 3 cells
    assert np.array_equal(mask, mask[::-1]) and np.array_equal(mask, mask.transpose(1, 0, 2))


def test_ellipsoid_and_cuboid_follow_their_axes():
    ellipsoid = Inhomogeneity("ellipsoid", (0.0, 0.0, 5.0), (4.0, 2.0, 1.0), E, NU)
    mask = region_mask(ellipsoid, X, X, Z)
    assert mask[:, N // 2].sum() > mask[N // 2, :].sum()  # longer along x1 than along x2
    assert set(np.nonzero(mask)[2]) == {4, 5}  # layers centred at 4.5, 5.5 only
    cuboid = Inhomogeneity("cuboid", (0.5, 0.5, 5.5), (1.0, 2.0, 0.5), E, NU)
    cells = np.nonzero(region_mask(cuboid, X, X, Z))
    assert sorted(set(X[cells[0]])) == [-0.5, 0.5, 1.5]
    assert sorted(set(X[cells[1]])) == [-1.5, -0.5, 0.5, 1.5, 2.5]
    assert set(Z[cells[2]]) == {5.5}


def test_listed_points_mark_their_cells_and_later_regions_win():
    points = np.array([[0.2, -0.3, 0.9], [3.9, 0.1, 11.99]])
    listed = Inhomogeneity("cells", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), E, NU, cells=points)
    sphere = Inhomogeneity("sphere", (0.0, 0.0, 1.0), (1.0, 1.0, 1.0), E, NU)
    phase = phase_field([sphere, listed], X, X, Z)
    assert phase.dtype == np.int8
    assert phase[8, 7, 0] == 2 and phase[11, 8, 11] == 2
    assert (phase == 1).any() and (phase == MATRIX).sum() == phase.size - (phase > 0).sum()
    outside = Inhomogeneity("cells", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), E, NU,
                            cells=np.array([[0.0, 0.0, 12.5]]))
    with pytest.raises(ValueError, match="outside the grid along x3"):
        phase_field([outside], X, X, Z)


def test_residual_stress_is_the_total_stress_inside_the_eigenstrain():
    """``R`` returns ``C (ε_compatible − ε*)``: compressive inside an expanding sphere.

    Mura §22: a dilatational eigenstrain ε* δ in a sphere of an infinite body has the interior
    stress ``3K (S_dil − 1) ε*`` with ``S_dil = (1 + ν) / (3 (1 − ν))``; deep below the surface
    (centre 2.4 radii deep) the lateral components are within 2 % of it.
    """
    n = 24
    op = HalfSpaceEigenstrain((n, n, n), (1.0, 1.0, 1.0), E, NU, threads=1)
    x = np.arange(n) + 0.5 - n / 2
    i, j, k = np.meshgrid(x, x, x, indexing="ij")
    eps = np.zeros((n, n, n, 6))
    eps[i**2 + j**2 + k**2 < 5.0**2, :3] = 1e-3
    stress = op.residual_stress(eps)[n // 2, n // 2, n // 2]
    bulk = E / (3 * (1 - 2 * NU))
    expected = 3 * bulk * ((1 + NU) / (3 * (1 - NU)) - 1) * 1e-3
    assert expected < 0
    np.testing.assert_allclose(stress[:2], expected, rtol=0.02)
