"""FFT back end and discrete-convolution FFT (DC-FFT) for non-periodic linear operators.

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
* pyfftw plans and their aligned buffers are built once per operator (FFTW's own wisdom makes
  re-planning a known shape cheap); ``scipy.fft`` is the fallback when pyfftw is not importable.
"""

from __future__ import annotations

import functools
import os
from collections.abc import Callable, Sequence

import numpy as np
import scipy.fft

try:  # pragma: no cover - exercised implicitly
    import pyfftw

    HAVE_PYFFTW = True
except ImportError:  # pragma: no cover
    pyfftw = None
    HAVE_PYFFTW = False

__all__ = [
    "HAVE_PYFFTW",
    "Convolution",
    "RealFFT",
    "default_threads",
    "padded_length",
    "real_fft",
    "wraparound_offsets",
]


#: Transforms with fewer points (batch included) run on one thread.
_THREADED_POINTS = 1 << 20


def default_threads() -> int:
    """Number of FFT threads: ``SACFLOW_FFT_THREADS`` or the number of usable cores."""
    env = os.environ.get("SACFLOW_FFT_THREADS")
    if env:
        return max(1, int(env))
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not on Linux
        return max(1, os.cpu_count() or 1)


def _planner_flag() -> str:
    """FFTW planner rigour: ``FFTW_ESTIMATE`` unless ``SACFLOW_FFTW_PLANNER=measure``.

    Measured on this project's 2-core machine, ``FFTW_MEASURE`` plans take 1–4 s for the
    operator shapes and gain < 10 % per transform, so estimation is the default.
    """
    measure = os.environ.get("SACFLOW_FFTW_PLANNER") == "measure"
    return "FFTW_MEASURE" if measure else "FFTW_ESTIMATE"


def padded_length(n_in: int, n_out: int) -> int:
    """Smallest FFT-friendly length ≥ ``n_in + n_out − 1`` (no wrap-around aliasing)."""
    return int(scipy.fft.next_fast_len(n_in + n_out - 1, real=True))


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


class RealFFT:
    """Cached forward/inverse real FFT over the trailing ``ndim`` axes of a fixed-shape array.

    Parameters
    ----------
    shape : tuple of int
        Full real array shape (leading batch axes first).
    ndim : int
        Number of trailing axes transformed (the last one is halved in the spectrum).
    threads : int, optional
        FFT threads; default :func:`default_threads`.

    Notes
    -----
    ``real`` and ``spectrum`` are the plan's own aligned buffers: write into ``real`` and call
    :meth:`forward` (result in ``spectrum``), or write ``spectrum`` and call :meth:`inverse`
    (unnormalised; result in ``real``). The inverse destroys ``spectrum``.
    """

    def __init__(self, shape: Sequence[int], ndim: int, threads: int | None = None):
        self.shape = tuple(int(s) for s in shape)
        self.ndim = ndim
        self.size = int(np.prod(self.shape[-ndim:]))
        # Threads help only for large transforms; on small ones FFTW's synchronisation costs
        # more than it saves (measured: a 256² transform is ~15× slower with 2 threads when the
        # other core is busy).
        total = int(np.prod(self.shape))
        self.threads = threads or (default_threads() if total >= _THREADED_POINTS else 1)
        self.axes = tuple(range(len(self.shape) - ndim, len(self.shape)))
        spec_shape = self.shape[:-1] + (self.shape[-1] // 2 + 1,)
        self.spectrum_shape = spec_shape
        if HAVE_PYFFTW:
            self.real = pyfftw.empty_aligned(self.shape, dtype="float64")
            self.spectrum = pyfftw.empty_aligned(spec_shape, dtype="complex128")
            flags = (_planner_flag(),)
            self._fwd = pyfftw.FFTW(
                self.real, self.spectrum, axes=self.axes, direction="FFTW_FORWARD",
                flags=flags, threads=self.threads,
            )
            self._inv = pyfftw.FFTW(
                self.spectrum, self.real, axes=self.axes, direction="FFTW_BACKWARD",
                flags=flags + ("FFTW_DESTROY_INPUT",), threads=self.threads,
            )
            self.real[...] = 0.0
        else:  # pragma: no cover - fallback
            self.real = np.zeros(self.shape)
            self.spectrum = np.zeros(spec_shape, dtype=complex)
            self._fwd = self._inv = None

    def forward(self) -> np.ndarray:
        """Transform ``real`` into ``spectrum`` (unnormalised) and return ``spectrum``."""
        if self._fwd is not None:
            self._fwd.execute()
        else:  # pragma: no cover
            self.spectrum[...] = scipy.fft.rfftn(self.real, axes=self.axes, workers=self.threads)
        return self.spectrum

    def inverse(self) -> np.ndarray:
        """Transform ``spectrum`` into ``real`` *without* the 1/N factor and return ``real``."""
        if self._inv is not None:
            self._inv.execute()
        else:  # pragma: no cover
            self.real[...] = scipy.fft.irfftn(
                self.spectrum, s=self.shape[-self.ndim:], axes=self.axes, workers=self.threads
            ) * self.size
        return self.real

    @property
    def nbytes(self) -> int:
        """Bytes held by the two buffers."""
        return self.real.nbytes + self.spectrum.nbytes


@functools.lru_cache(maxsize=32)
def real_fft(shape: tuple[int, ...], ndim: int, threads: int | None = None) -> RealFFT:
    """Return the cached :class:`RealFFT` for ``shape``: plans are built once per process."""
    return RealFFT(shape, ndim, threads)


def kernel_spectrum(
    kernel_wrapped: np.ndarray, ndim: int, threads: int | None = None
) -> np.ndarray:
    """Spectrum of wrap-around coefficients, scaled by 1/N (the inverse's normalisation).

    Returns a read-only complex array (STYLE 6: cached arrays are immutable).
    """
    fft = real_fft(kernel_wrapped.shape, ndim, threads)
    fft.real[...] = kernel_wrapped
    spec = fft.forward().copy()
    spec /= fft.size
    spec.flags.writeable = False
    return spec


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
        grids = np.meshgrid(*d, indexing="ij", sparse=True)
        valid = np.ones(self.padded, dtype=bool)
        for g, no, o in zip(grids, self.out_shape, self.offset, strict=True):
            valid &= g <= o + no - 1
        coeffs = np.asarray(coefficients(*grids), dtype=float)
        coeffs = np.where(valid, coeffs, 0.0)
        self.n_out, self.n_in = coeffs.shape[:2]
        batch = RealFFT((self.n_out * self.n_in, *self.padded), self.ndim, threads)
        batch.real[...] = coeffs.reshape(batch.shape)
        del coeffs
        self.spectra = batch.forward().reshape(
            self.n_out, self.n_in, *batch.spectrum_shape[1:]
        ) / batch.size
        del batch
        self.spectra.flags.writeable = False
        # Dedicated buffers: the forward input keeps its zero padding between calls.
        self._forward = RealFFT((self.n_in, *self.padded), self.ndim, threads)
        self._inverse = RealFFT((self.n_out, *self.padded), self.ndim, threads)
        self._in_window = (slice(None), *(slice(0, n) for n in self.in_shape))
        self._out_window = (slice(None),) + tuple(
            slice(o % length, o % length + no)
            if o % length + no <= length
            else np.mod(np.arange(no) + o, length)
            for no, o, length in zip(self.out_shape, self.offset, self.padded, strict=True)
        )

    @property
    def nbytes(self) -> int:
        """Bytes held by the cached kernel spectra and the FFT buffers."""
        return self.spectra.nbytes + self._forward.nbytes + self._inverse.nbytes

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """Apply to ``x`` of shape ``(n_in_comp, *in_shape)`` (or ``in_shape`` if one component).

        Returns a new array ``(n_out_comp, *out_shape)`` (or ``out_shape`` for one component).
        """
        single_in = x.ndim == self.ndim
        self._forward.real[self._in_window] = x.reshape((self.n_in, *self.in_shape))
        xs = self._forward.forward()
        acc = self._inverse.spectrum
        np.multiply(self.spectra[:, 0], xs[0], out=acc)
        for k in range(1, self.n_in):
            acc += self.spectra[:, k] * xs[k]
        real = self._inverse.inverse()
        window = self._out_window
        if all(isinstance(w, slice) for w in window):
            out = real[window].copy()
        else:
            out = real[np.ix_(range(self.n_out), *(
                np.arange(w.start, w.stop) if isinstance(w, slice) else w for w in window[1:]
            ))]
        if single_in and self.n_out == 1:
            return out[0]
        return out
