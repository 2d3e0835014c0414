"""Discrete-convolution FFT (DC-FFT) for non-periodic linear operators.

Conventions
-----------
* All operators here are *linear, non-periodic* discrete convolutions between cell-centred grids
  of equal spacing: ``out[i] = Σ_j K(i + offset - j) · x[j]`` where ``K(d)`` is an influence
  coefficient evaluated at the integer cell offset ``d`` (one per axis) and ``offset`` is the index
  of the output grid's first cell on the input grid.
* DC-FFT (Liu, Wang & Liu, Wear 243 (2000) 101, doi:10.1016/S0043-1648(00)00427-0): the exact
  coefficients for every offset ``d ∈ [offset − (n_in − 1), offset + n_out − 1]`` are placed in
  wrap-around order (index ``d mod L``) on a zero-padded grid of length ``L ≥ n_in + n_out − 1``;
  the input is zero-padded to ``L``; product of spectra; inverse; the output is read at
  ``(i + offset) mod L``. The result equals direct summation to round-off.
* FFT normalisation: forward transforms are unnormalised; the ``1/L`` of the inverse is folded into
  the cached kernel spectra, so ``inverse(forward(x) · K̂)`` needs no extra pass.
* The transforms are the cached pyfftw plans of :class:`sacflow.kernels.fft.RealFFT`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from sacflow.kernels.fft import RealFFT

__all__ = ["Convolution", "next_regular", "padded_length", "wraparound_offsets"]


def padded_length(n_in: int, n_out: int) -> int:
    """Smallest FFT-friendly length ≥ ``n_in + n_out − 1`` (no wrap-around aliasing)."""
    return next_regular(n_in + n_out - 1)


def next_regular(n: int) -> int:
    """Smallest 5-smooth number (2^a 3^b 5^c) ≥ ``n``: the lengths FFTW transforms fastest.

    The same as ``scipy.fft.next_fast_len(n, real=True)`` (checked in the tests), without
    importing ``scipy.fft``.
    """
    if n <= 1:
        return 1
    best = 1 << (n - 1).bit_length()  # the power of two: an upper bound
    p5 = 1
    while p5 < best:
        p35 = p5
        while p35 < best:
            # smallest p35 · 2^a ≥ n
            quotient = -(-n // p35)
            candidate = p35 << (quotient - 1).bit_length()
            best = min(best, candidate)
            p35 *= 3
        p5 *= 5
    return best


def wraparound_offsets(n_in: int, n_out: int, offset: int, length: int) -> np.ndarray:
    """Integer cell offset ``d`` stored at each index of a wrap-around kernel of ``length``.

    Index ``s`` holds ``d`` with ``d ≡ s (mod length)`` and ``d`` in the range the convolution
    needs, ``[offset − (n_in − 1), offset + n_out − 1]``; unused indices hold a sentinel outside
    that range (their coefficients are set to zero by :class:`Convolution`).
    """
    lo, hi = offset - (n_in - 1), offset + n_out - 1
    if hi - lo + 1 > length:
        raise ValueError(f"padded length {length} too short for offsets [{lo}, {hi}]")
    s = np.arange(length)
    d = lo + np.mod(s - lo, length)
    d[d > hi] = hi + 1  # sentinel: not used by the convolution
    return d


class Convolution:
    """Non-periodic multi-component convolution between two cell-centred grids (DC-FFT).

    ``out[c, i] = Σ_d Σ_j K_cd(i + offset − j) · x[d, j]`` over the ``ndim`` spatial axes.

    Parameters
    ----------
    coefficients : callable
        ``coefficients(*d) -> array (n_out_comp, n_in_comp, *d.shape)``: the influence
        coefficients at integer cell offsets ``d`` (one int array per axis, broadcast shapes).
    in_shape, out_shape : tuple of int
        Spatial shapes of the input and output grids.
    offset : tuple of int, optional
        Index of the output grid's first cell on the input grid (default zeros).
    threads : int, optional
        FFT threads.
    block : int, optional
        Output components transformed together (default: all). Smaller blocks keep the inverse
        transform's buffers small, ``block`` padded grids instead of ``n_out_comp`` (small
        enough to stay in cache, ``docs/performance.md``), for the same FFT work.
    cache : (str, mapping), optional
        Kind and parameters under which the kernel spectra are kept in the disk cache
        (:func:`sacflow.machine.kernel_cache.cached_arrays`); the parameters must hold everything
        the coefficients depend on (the grid shapes and offset are added here). Default:
        computed every time.

    Notes
    -----
    Set-up evaluates the coefficients once on the padded grid and caches their spectra; each
    application costs ``n_in_comp`` forward and ``n_out_comp`` inverse FFTs of the padded grid plus
    ``n_in_comp · n_out_comp`` spectral multiply-adds.
    """

    def __init__(
        self,
        coefficients: Callable[..., np.ndarray],
        in_shape: Sequence[int],
        out_shape: Sequence[int],
        offset: Sequence[int] | None = None,
        threads: int | None = None,
        block: int | None = None,
        cache: tuple[str, Mapping[str, Any]] | None = None,
    ):
        self.in_shape = tuple(int(n) for n in in_shape)
        self.out_shape = tuple(int(n) for n in out_shape)
        self.ndim = len(self.in_shape)
        self.offset = tuple(offset) if offset is not None else (0,) * self.ndim
        self.padded = tuple(
            padded_length(ni, no) for ni, no in zip(self.in_shape, self.out_shape, strict=True)
        )
        self.threads = threads
        d = [
            wraparound_offsets(ni, no, o, length)
            for ni, no, o, length in zip(
                self.in_shape, self.out_shape, self.offset, self.padded, strict=True
            )
        ]

        def compute() -> dict[str, np.ndarray]:
            return {"spectra": self._kernel_spectra(coefficients, d, block, threads)}

        if cache is None:
            spectra = compute()["spectra"]
        else:
            from sacflow.machine.kernel_cache import cached_arrays

            kind, parameters = cache
            key = {**parameters, "in_shape": list(self.in_shape),
                   "out_shape": list(self.out_shape), "offset": [int(o) for o in self.offset],
                   "padded": list(self.padded)}
            spectra = cached_arrays(kind, key, compute)["spectra"]
        self.spectra = spectra
        self.spectra.flags.writeable = False
        self.n_out, self.n_in = self.spectra.shape[:2]
        self.block = min(block or self.n_out, self.n_out)
        self._blocks = [(k, min(k + self.block, self.n_out))
                        for k in range(0, self.n_out, self.block)]
        self._in_window = (slice(None), *(slice(0, n) for n in self.in_shape))
        self._out_window = (slice(None),) + tuple(
            slice(o % length, o % length + no)
            if o % length + no <= length
            else np.mod(np.arange(no) + o, length)
            for no, o, length in zip(self.out_shape, self.offset, self.padded, strict=True)
        )
        window = self._out_window[1:]
        if not all(isinstance(w, slice) for w in window):  # wraps around: index arrays
            window = np.ix_(*(np.arange(w.start, w.stop) if isinstance(w, slice) else w
                              for w in window))
        self._out_index = tuple(window)  # of one output component, on the padded grid
        # Dedicated buffers: the forward input keeps its zero padding between calls. Pruned
        # transforms: the input fills the leading block; the output is the leading block when
        # the window does not wrap around and starts at index 0.
        prefix_out = all(
            isinstance(w, slice) and w.start == 0 for w in self._out_window[1:]
        )
        self._forward = RealFFT(
            (self.n_in, *self.padded), self.ndim, threads, in_extent=self.in_shape
        )
        self._inverse = RealFFT(
            (self.block, *self.padded), self.ndim, threads,
            out_extent=self.out_shape if prefix_out else None,
        )

    def _kernel_spectra(self, coefficients: Callable[..., np.ndarray], d: list[np.ndarray],
                        block: int | None, threads: int | None) -> np.ndarray:
        """Spectra (n_out, n_in, *spectrum) of the coefficients at the wrap-around offsets ``d``.

        Zero where an offset is not used; divided by the padded size (the inverse transform
        is unnormalised). One block of output components is transformed at a time.
        """
        grids = np.meshgrid(*d, indexing="ij", sparse=True)
        valid = np.ones(self.padded, dtype=bool)
        for g, no, o in zip(grids, self.out_shape, self.offset, strict=True):
            valid &= g <= o + no - 1
        coeffs = np.asarray(coefficients(*grids), dtype=float)
        n_out, n_in = coeffs.shape[:2]
        width = min(block or n_out, n_out)
        coeffs = coeffs.reshape(n_out * n_in, *self.padded)
        batch = RealFFT((width * n_in, *self.padded), self.ndim, threads, one_shot=True)
        spectra = np.empty((n_out * n_in, *batch.spectrum_shape[1:]), complex)
        for k0 in range(0, n_out, width):  # spectra of one block of output components at a time
            rows = slice(k0 * n_in, min(k0 + width, n_out) * n_in)
            real = batch.real[: rows.stop - rows.start]
            real[...] = 0.0
            np.copyto(real, coeffs[rows], where=valid)  # zero where the offset is not used
            np.divide(batch.forward()[: rows.stop - rows.start], batch.size, out=spectra[rows])
        return spectra.reshape(n_out, n_in, *spectra.shape[1:])

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """Apply to ``x`` of shape ``(n_in_comp, *in_shape)`` (or ``in_shape`` if one component).

        Returns a new array ``(n_out_comp, *out_shape)`` (or ``out_shape`` for one component).
        """
        single_in = x.ndim == self.ndim
        self._forward.real[self._in_window] = x.reshape((self.n_in, *self.in_shape))
        xs = self._forward.forward()
        out = np.empty((self.n_out, *self.out_shape))
        for k0, k1 in self._blocks:
            acc = self._inverse.spectrum[: k1 - k0]
            np.multiply(self.spectra[k0:k1, 0], xs[0], out=acc)
            for k in range(1, self.n_in):
                acc += self.spectra[k0:k1, k] * xs[k]
            if k1 - k0 < self.block:  # a last, shorter block: the rest of the batch is unused
                self._inverse.spectrum[k1 - k0:] = 0.0
            real = self._inverse.inverse()
            out[k0:k1] = real[(slice(0, k1 - k0), *self._out_index)]
        if single_in and self.n_out == 1:
            return out[0, ...]
        return out
