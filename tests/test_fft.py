"""Pruned real FFTs (skipping known-zero input lines and unused output lines) against numpy."""

import numpy as np
import pytest
import scipy.fft
from numpy.testing import assert_allclose, assert_array_equal

from sacflow.kernels.convolution import next_regular
from sacflow.kernels.cuboid import PARITY
from sacflow.kernels.fft import RealFFT, RealToReal
from sacflow.kernels.pair_products import DEPTH_SUM_BLOCKS, PAIRS, depth_sums, pair_products


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


@pytest.mark.parametrize(("kind", "function", "kind_type"), [
    ("FFTW_REDFT10", scipy.fft.dct, 2), ("FFTW_REDFT01", scipy.fft.dct, 3),
    ("FFTW_RODFT10", scipy.fft.dst, 2), ("FFTW_RODFT01", scipy.fft.dst, 3)])
def test_real_to_real_in_place_on_strided_lines_equals_scipy(kind, function, kind_type):
    """In place on a strided block (the eigenstrain operator's footprint lines), as scipy."""
    buf = np.zeros((3, 9, 7, 8))
    block = buf[:, 1:, :5, :4]
    data = np.random.default_rng(2).standard_normal(block.shape)
    transform = RealToReal(block, block, 1, kind)
    block[...] = data
    outside = buf.copy()
    transform()
    assert_allclose(block, function(data, type=kind_type, axis=1), rtol=0, atol=1e-12)
    outside[:, 1:, :5, :4] = block  # nothing outside the block is touched
    assert_allclose(buf, outside, rtol=0, atol=0)


def mirrored(half_rows: np.ndarray, sign: float, axis: int, L1: int) -> np.ndarray:
    """Rows 0 … L1 // 2 along ``axis`` completed to L1 rows: row L1 − k is ``sign`` × row k."""
    n = half_rows.shape[axis]
    rows = np.arange(L1)
    source = np.where(rows < n, rows, L1 - rows)
    factor = np.where(rows < n, 1.0, sign)
    shape = [1] * half_rows.ndim
    shape[axis] = L1
    return np.take(half_rows, source, axis=axis) * factor.reshape(shape)


def test_pair_products_equal_the_dense_six_by_six_products():
    """The compiled loop against the full 6 × 6 matrix built from the 21 stored kernels."""
    rng = np.random.default_rng(4)
    M, L1, L2h = 3, 4, 5
    spec = rng.standard_normal((6, M, L1, L2h)) + 1j * rng.standard_normal((6, M, L1, L2h))
    half = L1 // 2 + 1  # rows stored; the others are mirror images with the x1 parities
    kernels = rng.standard_normal((M, half, L2h, 21))
    inv_weight = 1.0 / np.array([1, 1, 1, 2, 2, 2.0])
    correction = rng.standard_normal((6, M, half, L2h))  # 13, 23: imaginary, stored / i
    p_hat = rng.standard_normal((L1, L2h)) + 1j * rng.standard_normal((L1, L2h))
    dense = np.zeros((6, 6, M, L1, L2h), dtype=complex)
    for k, (c, d) in enumerate(PAIRS):
        odd = (c >= 4) != (d >= 4)
        full = mirrored(kernels[..., k], PARITY[0, c] * PARITY[0, d], 1, L1)
        dense[c, d] = full * (1j if odd else 1.0)  # stored: row c >= column d
        dense[d, c] = -dense[c, d] if odd else dense[c, d]
    correction = np.stack([mirrored(correction[c], PARITY[0, c], 1, L1) for c in range(6)])
    imaginary = np.array([1, 1, 1, 1, 1j, 1j])[:, None, None, None]
    expected = (np.einsum("cd...,d...->c...", dense, spec) * inv_weight[:, None, None, None]
                + imaginary * correction * p_hat)
    out = np.zeros_like(spec)
    pair_products(spec, kernels, inv_weight, correction, p_hat, out, 1, M)
    assert_allclose(out[:, 1:], expected[:, 1:], rtol=1e-13, atol=1e-13)
    assert not out[:, 0].any()  # only the planes asked for


def test_depth_sums_equal_numpy_contraction():
    """Surface fields: Σ_d Σ_m spec_d(m) K_qd(m), the 13 and 23 kernels stored divided by i."""
    rng = np.random.default_rng(5)
    Q, M, L1, L2h = 2, 7, 5, 5
    spec = rng.standard_normal((6, M, L1, L2h)) + 1j * rng.standard_normal((6, M, L1, L2h))
    kernels = rng.standard_normal((Q, 6, M, L1 // 2 + 1, L2h))
    full = np.stack([mirrored(kernels[:, d], PARITY[0, d], 2, L1) for d in range(6)], axis=1)
    imaginary = np.array([1, 1, 1, 1, 1j, 1j])[None, :, None, None, None]
    expected = np.einsum("dmab,qdmab->qab", spec, imaginary * full)
    partial = np.full((DEPTH_SUM_BLOCKS, Q, L1, L2h), np.nan, dtype=complex)
    depth_sums(spec, kernels, partial, 0, DEPTH_SUM_BLOCKS)
    assert_allclose(partial.sum(axis=0), expected, rtol=1e-13, atol=1e-13)
    split = np.full_like(partial, np.nan)
    depth_sums(spec, kernels, split, 2, DEPTH_SUM_BLOCKS)  # a second thread's blocks
    assert np.isnan(split[:2]).all() and not np.isnan(split[2:]).any()
    depth_sums(spec, kernels, split, 0, 2)
    assert_array_equal(split, partial)  # the same sums in the same order, whatever the split
    # each block sums its own depth frequencies: with the other planes zero, the others vanish
    only = np.zeros_like(spec)
    only[:, M // DEPTH_SUM_BLOCKS:2 * M // DEPTH_SUM_BLOCKS] = spec[:, M // DEPTH_SUM_BLOCKS:
                                                                 2 * M // DEPTH_SUM_BLOCKS]
    depth_sums(only, kernels, split, 0, DEPTH_SUM_BLOCKS)
    assert not split[[0, 2, 3]].any() and split[1].any()


def test_pyfftw_is_imported_without_dask_array_and_scipy_fft_which_stay_importable():
    """pyfftw's optional interfaces (dask.array, xarray, pandas; scipy.fft) are not loaded."""
    import subprocess
    import sys

    code = ("import sys, sacflow.kernels.fft as f\n"
            "print(f.HAVE_PYFFTW, *(m in sys.modules for m in\n"
            "      ('dask.array', 'xarray', 'scipy.fft', 'scipy.fftpack')))\n"
            "import dask.array, scipy.fftpack\n"
            "print(dask.array.ones(3).sum().compute(), scipy.fftpack.dct([1.0, 1.0])[0])\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["True", "False", "False", "False", "False", "3.0", "4.0"]


def test_next_regular_equals_scipy_next_fast_len():
    """The 5-smooth padding length is scipy's real-input fast length (computed independently)."""
    lengths = [*range(0, 3000), 4097, 10**5 + 1, 2**20 + 1, 3**11 + 2, 5**8 - 1]
    ours = [next_regular(n) for n in lengths]
    assert ours == [scipy.fft.next_fast_len(max(n, 1), real=True) for n in lengths]


def test_in_place_pruned_transforms_equal_the_out_of_place_ones():
    """One buffer for real and spectrum: repeated forwards (with and without an inverse in
    between) see only the new input block, as the out-of-place transform does."""
    from sacflow.kernels.fft import RealFFT

    rng = np.random.default_rng(8)
    shape, block = (2, 3, 12, 10), (7, 6)
    inplace = RealFFT(shape, 2, 1, in_extent=block, out_extent=block, in_place=True)
    plain = RealFFT(shape, 2, 1, in_extent=block, out_extent=block)
    assert np.shares_memory(inplace.real, inplace.spectrum)
    assert inplace.nbytes < plain.nbytes
    for round_ in range(4):
        data = rng.standard_normal((*shape[:2], *block))
        for fft in (inplace, plain):
            fft.real[:, :, :7, :6] = data
        assert_allclose(inplace.forward(), plain.forward(), rtol=0, atol=1e-12)
        if round_ % 2:  # an inverse every other round
            assert_allclose(inplace.inverse()[:, :, :7, :6], plain.inverse()[:, :, :7, :6],
                            rtol=0, atol=1e-11)
