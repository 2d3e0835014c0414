"""Pruned real FFTs (skipping known-zero input lines and unused output lines) against numpy."""

import numpy as np
import pytest
from numpy.testing import assert_allclose

from sacflow.kernels.fft import RealFFT


@pytest.mark.parametrize(
    ("shape", "ndim", "in_extent", "out_extent"),
    [
        ((3, 10, 9, 8), 3, (5, 4, 3), (4, 6, 8)),  # batch of three 3-D transforms
        ((10, 9, 8), 3, (10, 2, 8), (1, 9, 3)),  # no pruning along some axes
        ((2, 12, 10), 2, (6, 5), (7, 10)),
        ((16, 15), 2, (8, 15), (16, 4)),
    ],
)
def test_pruned_transforms_equal_numpy(shape, ndim, in_extent, out_extent):
    rng = np.random.default_rng(7)
    lead = (slice(None),) * (len(shape) - ndim)
    axes = tuple(range(len(shape) - ndim, len(shape)))
    fft = RealFFT(shape, ndim, in_extent=in_extent, out_extent=out_extent)
    block_in = lead + tuple(slice(0, e) for e in in_extent)
    block_out = lead + tuple(slice(0, e) for e in out_extent)
    for _ in range(2):  # twice: stale data from the first call must not leak into the second
        x = np.zeros(shape)
        x[block_in] = rng.standard_normal(x[block_in].shape)
        fft.real[block_in] = x[block_in]
        assert_allclose(fft.forward(), np.fft.rfftn(x, axes=axes), rtol=0, atol=1e-12 * x.size)
        spectrum = np.fft.rfftn(rng.standard_normal(shape), axes=axes)
        fft.spectrum[...] = spectrum
        expected = np.fft.irfftn(spectrum, s=shape[-ndim:], axes=axes) * np.prod(shape[-ndim:])
        assert_allclose(fft.inverse()[block_out], expected[block_out], rtol=0,
                        atol=1e-12 * np.abs(expected).max())


def test_extent_outside_the_grid_is_refused():
    with pytest.raises(ValueError, match="outside the grid"):
        RealFFT((8, 8), 2, in_extent=(9, 4))
