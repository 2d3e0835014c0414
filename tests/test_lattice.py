"""Influence coefficients on corner lattices against the corner-by-corner closed forms.

The lattice evaluation (sacflow.kernels.lattice, cuboid_lattice, surface.rectangle_stress_grid)
computes the same corner functions once per shared corner and differences them; it must equal
the direct corner sums of sacflow.kernels.cuboid.cuboid_stress and surface.rectangle_stress to
rounding, for every column, inside and outside the cell, near and far, for flat cells and at
the surface limit the eigenstrain operator uses.
"""

from __future__ import annotations

import numpy as np
import pytest

from sacflow.kernels.cell_average import sub_offsets
from sacflow.kernels.cuboid import PARITY, cuboid_stress
from sacflow.kernels.cuboid_lattice import CuboidLattice, corner_sum_coefficients
from sacflow.kernels.eigenstrain_spectra import cell_mean_love_stress
from sacflow.kernels.lattice import FoldedAxis, SampledAxis
from sacflow.kernels.surface import rectangle_stress, rectangle_stress_grid

NU, MU = 0.3, 80.8e9
ALL = [(c, d) for c in range(6) for d in range(6)]


def wrapped_offsets(n: int, length: int, d: float) -> np.ndarray:
    """Offsets of a wrap-around kernel (0 … n−1, then negative), in metres."""
    o = np.arange(length)
    return np.where(o < n, o, o - length) * d


def relative_error(new, ref, axes, scale=None):
    """Largest difference per column over the column's largest value (or a given scale)."""
    scale = np.abs(ref).max(axis=axes) if scale is None else scale
    return (np.abs(new - ref).max(axis=axes) / np.where(scale > 0, scale, 1.0)).max()


@pytest.mark.parametrize("spacing", [(1.0e-6, 1.3e-6, 0.7e-6), (2e-6, 2e-6, 0.25e-6),
                                     (1e-6, 1e-6, 1e-6)])
def test_cuboid_lattice_equals_corner_sums(spacing):
    half = [d / 2 for d in spacing]
    x1, x2 = wrapped_offsets(9, 17, spacing[0]), wrapped_offsets(6, 12, spacing[1])
    lattice = CuboidLattice(x1, x2, half, NU, MU)
    near_field = np.abs(cuboid_stress(x1[:, None], x2[None, :], spacing[2], *half, NU, MU)
                        ).reshape(-1, 36).max(axis=0)
    for o3 in (0, -1, 1, 2, -3, 7, 40):
        x3 = o3 * spacing[2]
        new = lattice.plane(x3, ALL)
        ref = cuboid_stress(x1[:, None], x2[None, :], x3, *half, NU, MU)
        ref = np.moveaxis(ref.reshape(x1.size, x2.size, 36), -1, 0)
        assert relative_error(new, ref, (1, 2)) < 1e-12 or o3 > 7, o3
        # Far away both differ from the exact value by the round-off of the corner sums'
        # cancellation, ~1e-16 (r / h)^3 of the local value: small against the near field.
        assert relative_error(new, ref, (1, 2), near_field) < 1e-13, o3


def test_cuboid_lattice_at_the_surface_limit():
    """The operator's surface traction: σ33 just above the top face of a first-layer cuboid."""
    d = (1e-6, 1e-6, 0.5e-6)
    half = [x / 2 for x in d]
    x1 = wrapped_offsets(5, 10, d[0])
    lattice = CuboidLattice(x1, x1, half, NU, MU)
    columns = [(2, k) for k in range(6)]
    for x3 in (-0.5 * d[2] - 1e-10 * d[2], -2.5 * d[2] - 1e-10 * d[2], 1.5 * d[2] - 1e-10 * d[2]):
        new = lattice.plane(x3, columns)
        ref = np.moveaxis(cuboid_stress(x1[:, None], x1[None, :], x3, *half, NU, MU)[..., 2, :],
                          -1, 0)
        assert relative_error(new, ref, (1, 2)) < 1e-12


def test_corner_sum_coefficients_give_the_stress_of_the_sums():
    """Outside the cuboid the stress is linear in the 18 corner sums: inside, −C:ε* is added."""
    k = corner_sum_coefficients(NU, MU)
    assert k.shape == (18, 6, 6)
    # the trace of φ,ij sums T: −4π inside: only the free term differs, checked via the kernel
    lattice = CuboidLattice(np.array([0.0]), np.array([0.0]), (1.0, 1.0, 1.0), NU, MU)
    inside = lattice.folded_plane(0.0)[0, 0].reshape(6, 6)
    ref = cuboid_stress(0.0, 0.0, 0.0, 1.0, 1.0, 1.0, NU, MU)[0]
    np.testing.assert_allclose(inside, ref, rtol=0, atol=1e-12 * np.abs(ref).max())


def test_folded_axis_lattice_and_differences():
    x = np.array([0.0, 2.0, 4.0, -2.0, -4.0, 6.0])
    axis = FoldedAxis(x, 1.0)
    np.testing.assert_array_equal(axis.folded, [0.0, 2.0, 4.0, 6.0])
    np.testing.assert_array_equal(axis.lattice, [-1.0, 1.0, 3.0, 5.0, 7.0])
    values = axis.lattice**3
    np.testing.assert_allclose(axis.difference(values, 0), (axis.folded + 1)**3
                               - (axis.folded - 1)**3)
    np.testing.assert_array_equal(axis.unfold(axis.folded, 0), np.abs(x))
    np.testing.assert_array_equal(axis.sign, [1, 1, 1, -1, -1, 1])


@pytest.mark.parametrize("half", [(0.5e-6, 0.5e-6), (1e-6, 0.3e-6)])
def test_rectangle_stress_grid_equals_corner_sums(half):
    x1 = wrapped_offsets(8, 15, 2 * half[0])
    x2 = wrapped_offsets(5, 11, 2 * half[1])
    for z in (0.25e-6, 1e-6, 7.5e-6):
        new = rectangle_stress_grid(x1, x2, z, *half, NU)
        ref = rectangle_stress(x1[:, None], x2[None, :], z, *half, NU)
        assert relative_error(new, ref, (0, 1)) < 1e-12


def test_rectangle_stress_grid_needs_a_depth():
    with pytest.raises(ValueError, match="depth > 0"):
        rectangle_stress_grid(np.zeros(1), np.zeros(1), 0.0, 1.0, 1.0, NU)


def test_folded_axis_differences_of_slices_and_of_gathers_agree():
    """A regular grid's ends run through consecutive lattice points (slices); others gather."""
    regular = FoldedAxis(np.arange(7) * 2.0, 1.0)
    irregular = FoldedAxis(np.array([0.0, 2.0, 6.0, 7.0]), 1.0)
    assert regular._runs is not None and irregular._runs is None
    for axis in (regular, irregular):
        values = np.random.default_rng(3).standard_normal((2, axis.lattice.size, 3))
        want = values[:, axis.upper] - values[:, axis.lower]
        np.testing.assert_array_equal(axis.difference(values, 1), want)


def test_sampled_axis_mean_takes_odd_kernels_across_the_origin_with_their_sign():
    x, sub = np.arange(4) * 1.0, np.array([-0.25, 0.25])
    axis = SampledAxis(x, sub, 0.5)
    # the union of the sub-points, folded: odd multiples of a quarter, k = 0's lower sub-point
    # folded onto its upper one
    np.testing.assert_allclose(axis.axis.folded, np.arange(1, 14, 2) * 0.25)
    np.testing.assert_array_equal(axis.sign < 0, [[True, False]] + [[False, False]] * 3)
    f = np.stack([axis.axis.folded**2, axis.axis.folded**3], axis=-1)  # an even, an odd column
    mean = axis.mean(f, 0, np.array([False, True]))
    points = x[:, None] + sub[None, :]
    np.testing.assert_allclose(mean, np.stack([(points**2).mean(1), (points**3).mean(1)], -1))


@pytest.mark.parametrize("sampling", [2, 3])
@pytest.mark.parametrize("spacing", [(1.0e-6, 1.3e-6, 0.7e-6), (1e-6, 1e-6, 2.3e-6)])
def test_sampled_cuboid_lattice_is_the_mean_of_the_closed_form_over_the_sub_points(sampling,
                                                                                 spacing):
    """The union lattice's mean (laterally and in depth) against Chiu's cuboid point by point,
    on the target cell itself (sub-points inside the source) and its neighbours."""
    half = [d / 2 for d in spacing]
    q = sub_offsets(sampling)
    x1, x2 = np.arange(5) * spacing[0], np.arange(4) * spacing[1]
    lattice = CuboidLattice(x1, x2, half, NU, MU, sub=(q * spacing[0], q * spacing[1]))
    for o3 in (0, 1, -2, 9):
        x3 = o3 * spacing[2]
        got = lattice.mean_plane(x3, ALL, tuple(q * spacing[2]))
        want = np.mean([cuboid_stress((x1 + p1 * spacing[0])[:, None],
                                      (x2 + p2 * spacing[1])[None, :],
                                      x3 + p3 * spacing[2], *half, NU, MU)
                        for p1 in q for p2 in q for p3 in q], axis=0).reshape(5, 4, 36)
        # against the largest coefficient: columns zero by symmetry are rounding there
        assert relative_error(got, want, (0, 1), np.abs(want).max()) < 1e-12, o3
    # columns odd along an axis vanish on the symmetry plane through the source
    odd1 = [n for n, (c, d) in enumerate(ALL) if PARITY[0, c] * PARITY[0, d] < 0]
    assert np.abs(lattice.mean_plane(spacing[2], ALL)[0, :, odd1]).max() < 1e-12 * np.abs(
        lattice.mean_plane(spacing[2], ALL)).max()


def test_mean_plane_needs_sub_points():
    lattice = CuboidLattice(np.zeros(1), np.zeros(1), (1.0, 1.0, 1.0), NU, MU)
    with pytest.raises(ValueError, match="sub-points"):
        lattice.mean_plane(0.0, ALL)


@pytest.mark.parametrize("sampling", [1, 2, 3])
def test_cell_mean_love_stress_is_the_mean_over_the_sub_points(sampling):
    spacing = (1.0e-6, 1.4e-6, 0.6e-6)
    x1, x2 = np.arange(6) * spacing[0], np.arange(5) * spacing[1]
    q = sub_offsets(sampling)
    got = cell_mean_love_stress(x1, x2, 2.5 * spacing[2], spacing, NU, sampling)
    want = np.mean([rectangle_stress((x1 + p1 * spacing[0])[:, None],
                                     (x2 + p2 * spacing[1])[None, :],
                                     (2.5 + p3) * spacing[2], spacing[0] / 2, spacing[1] / 2, NU)
                    for p1 in q for p2 in q for p3 in q], axis=0)
    assert relative_error(got, want, (0, 1)) < 1e-12
