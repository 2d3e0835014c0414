"""Spectra of even and odd kernels from their values at offsets ≥ 0 (sacflow.kernels.folded_fft).

The eigenstrain operator's kernel spectra come from cosine and sine transforms of the kernels
at the offsets k1, k2 ≥ 0. They must equal the 2-D FFT of the kernel mirrored onto the whole
wrap-around period (what the operator did before), for even and odd periods, and the parities
they rest on must be those of the closed forms.
"""

from __future__ import annotations

import numpy as np
import pytest

from sacflow.kernels.convolution import padded_length, wraparound_offsets
from sacflow.kernels.cuboid import PARITY
from sacflow.kernels.folded_fft import folded_spectra, stored_sign
from sacflow.kernels.residual_displacement import cuboid_surface_displacement
from sacflow.kernels.surface import rectangle_stress

CLASSES = np.array([[1, 1], [1, -1], [-1, 1], [-1, -1]])


def mirrored_spectrum(folded, parities, lengths):
    """rfft2 of the kernels mirrored onto the wrap-around period (offsets beyond n − 1: zero)."""
    (n1, n2, count), (L1, L2) = folded.shape, lengths
    o1 = wraparound_offsets(n1, n1, 0, L1)[:, None]
    o2 = wraparound_offsets(n2, n2, 0, L2)[None, :]
    used = (np.abs(o1) <= n1 - 1) & (np.abs(o2) <= n2 - 1)
    i1, i2 = np.minimum(np.abs(o1), n1 - 1), np.minimum(np.abs(o2), n2 - 1)
    full = np.zeros((L1, L2, count))
    for c, (p1, p2) in enumerate(parities):
        sign = np.where(o1 < 0, p1, 1) * np.where(o2 < 0, p2, 1)
        full[..., c] = np.where(used, sign * folded[i1, i2, c], 0.0)
    return np.fft.rfft2(full, axes=(0, 1))[: L1 // 2 + 1]


@pytest.mark.parametrize("n1, n2", [(5, 4), (24, 65), (33, 12), (1, 3), (2, 2), (8, 8)])
def test_equals_the_fft_of_the_mirrored_kernel(n1, n2):
    L1, L2 = padded_length(n1, n1), padded_length(n2, n2)
    rng = np.random.default_rng(n1 * 100 + n2)
    parities = np.repeat(CLASSES, 2, axis=0)
    folded = rng.standard_normal((n1, n2, len(parities)))
    # an odd kernel vanishes on its mirror plane
    folded[0, :, parities[:, 0] < 0] = 0.0
    folded[:, 0, parities[:, 1] < 0] = 0.0
    spectrum = mirrored_spectrum(folded, parities, (L1, L2))
    real = parities.prod(axis=1) > 0
    expected = np.where(real, spectrum.real, spectrum.imag)
    dropped = np.where(real, spectrum.imag, spectrum.real)
    scale = np.abs(spectrum).max()
    assert np.abs(dropped).max() < 1e-13 * scale  # the parities make it real or imaginary
    got = folded_spectra(folded, parities, (L1, L2))
    assert got.shape == (L1 // 2 + 1, L2 // 2 + 1, len(parities))
    assert np.abs(got - expected).max() < 1e-13 * scale


def test_period_longer_than_the_kernel():
    """Offsets between n and L // 2 are zero: the transforms pad them."""
    parities = CLASSES
    folded = np.random.default_rng(3).standard_normal((6, 5, 4))
    folded[0, :, parities[:, 0] < 0] = 0.0
    folded[:, 0, parities[:, 1] < 0] = 0.0
    for lengths in [(16, 12), (15, 13), (12, 9)]:
        spectrum = mirrored_spectrum(folded, parities, lengths)
        expected = np.where(parities.prod(axis=1) > 0, spectrum.real, spectrum.imag)
        got = folded_spectra(folded, parities, lengths)
        assert np.abs(got - expected).max() < 1e-13 * np.abs(spectrum).max()


def test_too_many_offsets_are_refused():
    with pytest.raises(ValueError, match="exceed half the periods"):
        folded_spectra(np.zeros((6, 3, 1)), CLASSES[:1], (9, 8))


def test_stored_sign():
    assert stored_sign((1, 1)) == 1.0
    assert stored_sign((-1, 1)) == stored_sign((1, -1)) == stored_sign((-1, -1)) == -1.0


def test_layer_kernels_have_the_parities_of_their_component():
    """The operator takes component c of the surface kernels with the parities of component c.

    Love's rectangle (corner by corner) and the surface displacement of a buried cuboid at
    mirrored points.
    """
    rng = np.random.default_rng(5)
    x1, x2 = rng.uniform(0.3e-6, 4e-6, 7), rng.uniform(0.3e-6, 4e-6, 7)
    h, depth = 0.5e-6, 1.7e-6
    for axis in (0, 1):
        m1, m2 = (-x1, x2) if axis == 0 else (x1, -x2)
        here = rectangle_stress(x1, x2, depth, h, h, 0.3)
        there = rectangle_stress(m1, m2, depth, h, h, 0.3)
        np.testing.assert_allclose(there, PARITY[axis] * here, rtol=1e-9,
                                   atol=1e-14 * np.abs(here).max())
        here = cuboid_surface_displacement(x1, x2, depth, h, h, h, 0.3)
        there = cuboid_surface_displacement(m1, m2, depth, h, h, h, 0.3)
        np.testing.assert_allclose(there, PARITY[axis] * here, rtol=1e-9,
                                   atol=1e-14 * np.abs(here).max())
