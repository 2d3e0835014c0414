r"""Lateral spectra of kernels even or odd along x1 and x2, from their values at offsets ≥ 0.

A kernel ``f`` sampled at the whole-cell offsets ``k`` of a wrap-around period ``L``
(:func:`sacflow.kernels.convolution.wraparound_offsets`) and even or odd along an axis has a DFT
that is real (even) or imaginary (odd), and is fixed by its values at ``k = 0 … ⌊L/2⌋``. For an even
period ``L = 2M``:

.. math::

    F(q) = f_0 + (−1)^q f_M + 2 \sum_{k=1}^{M-1} f_k \cos(π q k / M)
    \quad\text{(even: a DCT-I of } f_0 … f_M),

    F(q) = −2i \sum_{k=1}^{M-1} f_k \sin(π q k / M)
    \quad\text{(odd: } −i \text{ times a DST-I of } f_1 … f_{M-1}),

for ``q = 0 … M``: the rows (and columns) a real-input spectrum stores. For an odd period
``L = 2M + 1`` there is no such transform; the sequence ``g`` of period ``2L`` with
``g_{2k} = f_k`` and zeros at the odd positions has ``G(q) = F(q)`` and is even (odd) with an
even period, so the formulas above apply to it (the transforms then are about twice as long).

Compared with mirroring the kernel onto the whole ``L1 × L2`` period and taking a real 2-D FFT
(what :mod:`sacflow.kernels.eigenstrain` did before), the kernel is needed at a quarter of the
offsets, nothing is mirrored, and the transforms (FFTW's ``REDFT00``/``RODFT00`` through
``scipy.fft``) are a quarter of the size; the spectra are real by construction.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.fft

__all__ = ["folded_spectra", "stored_sign"]


def stored_sign(parities: Sequence[int]) -> float:
    """Sign of the real or imaginary part of a spectrum relative to the product of transforms.

    ``parities`` (±1 per axis): each odd axis contributes a factor −i. Zero odd axes: the
    spectrum is real, +1; one: imaginary, its imaginary part is −1 times the transforms; two:
    real, (−i)² = −1.
    """
    return -1.0 if any(p < 0 for p in parities) else 1.0


def _along(values: np.ndarray, axis: int, length: int, odd: bool, workers: int) -> np.ndarray:
    """Transform along ``axis`` the values at offsets 0 … K − 1 (zero beyond) of period ``length``.

    Returns the rows ``q = 0 … length // 2`` of the DFT divided by 1 (even) or −i (odd).
    """
    half = length // 2
    values = np.moveaxis(values, axis, 0)
    if length % 2:  # odd period: interleave zeros (period 2L, module notes)
        period = 2 * length
        seq = np.zeros((length + 1, *values.shape[1:]))
        count = min(values.shape[0], half + 1)
        seq[0:2 * count:2] = values[:count]
    else:
        period = length
        seq = np.zeros((half + 1, *values.shape[1:]))
        count = min(values.shape[0], half + 1)
        seq[:count] = values[:count]
    out = np.zeros((half + 1, *values.shape[1:]))
    mid = period // 2  # the DCT-I has mid + 1 points, the DST-I mid − 1
    if odd:
        # DST-I of seq[1 … mid − 1]: frequencies 1 … mid − 1; keep those ≤ half
        top = min(half, mid - 1)
        if mid > 1:
            out[1:top + 1] = scipy.fft.dst(seq[1:mid], type=1, axis=0, workers=workers)[:top]
    else:
        out[:] = scipy.fft.dct(seq, type=1, axis=0, workers=workers)[:half + 1]
    return np.moveaxis(out, 0, axis)


def folded_spectra(folded: np.ndarray, parities: np.ndarray, lengths: Sequence[int],
                   workers: int = 1) -> np.ndarray:
    """Half spectra of kernels even or odd in x1 and x2, given at the offsets ``k1, k2 ≥ 0``.

    Parameters
    ----------
    folded : ndarray (K1, K2, C)
        Each kernel's values at offsets ``k1 = 0 … K1 − 1``, ``k2 = 0 … K2 − 1`` (cells); zero
        at the larger offsets up to ``L // 2`` (as the unused offsets of a convolution).
        ``K ≤ L // 2 + 1``.
    parities : ndarray (C, 2) of ±1
        Each kernel's parity along x1 and x2.
    lengths : (L1, L2)
        The wrap-around periods.
    workers : int
        Threads of each transform.

    Returns
    -------
    ndarray (L1 // 2 + 1, L2 // 2 + 1, C)
        Rows ``q1 ≤ L1 // 2`` and columns ``q2 ≤ L2 // 2`` of each kernel's 2-D DFT (its
        unnormalised forward transform over the whole period): the real part of the real spectra
        (no odd axis or two), the imaginary part of the imaginary ones (one odd axis).
    """
    L1, L2 = (int(n) for n in lengths)
    K1, K2, C = folded.shape
    if K1 > L1 // 2 + 1 or K2 > L2 // 2 + 1:
        raise ValueError(f"offsets 0 … {K1 - 1}, 0 … {K2 - 1} exceed half the periods "
                         f"{L1}, {L2}")
    parities = np.asarray(parities)
    out = np.empty((L1 // 2 + 1, L2 // 2 + 1, C))
    for p1 in (1, -1):
        for p2 in (1, -1):
            columns = np.flatnonzero((parities[:, 0] == p1) & (parities[:, 1] == p2))
            if columns.size == 0:
                continue
            part = _along(folded[..., columns], 0, L1, p1 < 0, workers)
            part = _along(part, 1, L2, p2 < 0, workers)
            part *= stored_sign((p1, p2))
            out[..., columns] = part
    return out
