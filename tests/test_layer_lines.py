"""Compiled copies between the cuboid box and the eigenstrain operator's lines."""

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from sacflow.kernels.eigenstrain_spectra import EVEN, ODD
from sacflow.kernels.layer_lines import box_from_lines, lines_from_box
from sacflow.machine.threads import over_ranges


def numpy_lines(eps: np.ndarray, lines: np.ndarray) -> None:
    """The copy written with numpy's strided assignments (the operator's earlier code)."""
    n3 = eps.shape[2]
    layers = np.moveaxis(eps, (3, 2), (0, 1))
    lines[EVEN, :n3] = layers[EVEN]
    lines[EVEN, n3:] = 0.0
    lines[ODD, 1:n3 + 1] = layers[ODD]
    lines[ODD, n3 + 1:] = 0.0


@pytest.mark.parametrize("threads", [1, 2, 3])
def test_lines_from_box_and_back_equal_the_strided_copies_for_any_split(threads):
    """Layer k of an even component in row k, of an odd one in row k + 1, zero below; row 0 of
    the odd ones untouched; the way back gives the box again, bit for bit."""
    rng = np.random.default_rng(3)
    n1, n2, n3, depth = 7, 5, 4, 9
    eps = rng.standard_normal((n1, n2, n3, 6))
    buffer = rng.standard_normal((6, depth, n1 + 2, n2 + 3))  # the lines are a strided view
    expected = buffer.copy()
    numpy_lines(eps, expected[:, :, :n1, :n2])
    for first, last in [(0, 3), (3, n1)] if threads == 2 else [(0, n1)]:
        lines_from_box(eps, buffer[:, :, :n1, :n2], first, last)
    if threads == 3:
        over_ranges(lines_from_box, n1, threads, eps, buffer[:, :, :n1, :n2], weight=1 << 20)
    assert_array_equal(buffer, expected)  # padding and the footprint's margin included
    back = np.full_like(eps, np.nan)
    over_ranges(box_from_lines, n1, threads, buffer[:, :, :n1, :n2], back, weight=1 << 20)
    assert_array_equal(back, eps)


def test_a_range_writes_only_its_own_rows():
    """Threads write disjoint parts: the rows outside [first, last) are left as they were."""
    eps = np.ones((4, 3, 2, 6))
    buffer = np.full((6, 5, 4, 3), 7.0)
    lines_from_box(eps, buffer, 1, 3)
    assert (buffer[:, :, [0, 3]] == 7.0).all()
    assert (buffer[:4, :2, 1:3] == 1.0).all() and (buffer[:4, 2:, 1:3] == 0.0).all()
    out = np.full((4, 3, 2, 6), 5.0)
    box_from_lines(buffer, out, 2, 4)
    assert (out[:2] == 5.0).all()
