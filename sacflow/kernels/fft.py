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
  re-planning a known shape cheap); ``scipy.fft`` is the fallback when pyfftw is not importable,
  imported only then (its import is a sizeable part of a campaign worker's start).
"""

from __future__ import annotations

import functools
import os
import sys
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from sacflow.machine.environment import fft_threads_from_env, fftw_planner_from_env

#: Optional modules pyfftw's package imports for its interfaces, which sacflow does not use:
#: ``dask.array`` (with xarray and pandas) and ``scipy.fftpack`` (with ``scipy.fft``).
_PYFFTW_OPTIONAL = ("dask.array", "scipy.fftpack")


def _import_pyfftw():
    """Import pyfftw without its dask and scipy interfaces (None without pyfftw).

    pyfftw's package imports ``pyfftw.interfaces.dask_fft`` whenever dask is installed and
    ``pyfftw.interfaces.scipy_fft`` whenever scipy is, and with them the modules of
    :data:`_PYFFTW_OPTIONAL`, which make its import many times slower (``docs/performance.md``):
    time paid by every ``sacflow`` command and every campaign worker. sacflow uses only
    ``pyfftw.FFTW``: the modules not loaded already are blocked (an ImportError, which pyfftw
    catches) while pyfftw is imported, and are importable again afterwards.
    """
    blocked = [name for name in _PYFFTW_OPTIONAL if name not in sys.modules]
    for name in blocked:
        sys.modules[name] = None  # type: ignore[assignment]
    try:
        import pyfftw
    except ImportError:  # pragma: no cover
        return None
    finally:
        for name in blocked:
            del sys.modules[name]
    return pyfftw


pyfftw = _import_pyfftw()
HAVE_PYFFTW = pyfftw is not None

__all__ = [
    "HAVE_PYFFTW",
    "Convolution",
    "RealFFT",
    "RealToReal",
    "default_threads",
    "padded_length",
    "real_fft",
    "wraparound_offsets",
]


#: Time limit of one measured 3-D plan [s]: FFTW keeps the best plan found by then. A longer
#: search lengthens the operator's set-up for plans hardly faster (``docs/performance.md``).
_PLANNING_SECONDS = 0.3
#: Transforms with fewer points (batch included) run on one thread: below it FFTW's thread
#: synchronisation costs more than a second thread gains (``docs/performance.md``).
_THREADED_POINTS = 1 << 18


def default_threads() -> int:
    """Return the number of FFT threads: ``SACFLOW_FFT_THREADS`` or the number of usable cores.

    A value that is not a whole number >= 1 raises
    :class:`~sacflow.errors.EnvironmentVariableError` (see :mod:`sacflow.machine.environment`).
    """
    from_env = fft_threads_from_env()
    if from_env is not None:
        return from_env
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not on Linux
        return max(1, os.cpu_count() or 1)


def _new_plan(*args: Any, **kwargs: Any):
    """``pyfftw.FFTW(...)``, with the wisdom stored beside the kernel cache imported first.

    A measured plan of a known transform is then found at once (:mod:`sacflow.kernels.fftw_wisdom`).
    """
    from sacflow.kernels.fftw_wisdom import load_wisdom

    load_wisdom()
    return pyfftw.FFTW(*args, **kwargs)


#: Transforms with at least this many points (per batch item) are planned with ``FFTW_MEASURE``.
_MEASURED_POINTS = 1 << 18


def _planner(points: int, ndim: int, one_shot: bool = False) -> tuple[str, float | None]:
    """FFTW planner rigour and planning time limit [s] for a transform of ``points`` points.

    ``SACFLOW_FFTW_PLANNER=estimate|measure`` forces the rigour; by default large transforms are
    measured and small ones (and plans run once, ``one_shot``) estimated: a measured plan of a
    large transform runs markedly faster and FFTW keeps it for the rest of the process, while
    below ~2^18 points planning costs more than a whole run of small cases gains
    (``docs/performance.md``). Measured 3-D plans are limited to :data:`_PLANNING_SECONDS` each;
    2-D plans are not (their full search is what makes a large contact solve fast).
    """
    if one_shot:
        return "FFTW_ESTIMATE", None
    forced = fftw_planner_from_env()  # None, "estimate" or "measure"; anything else raises
    if forced is not None:
        flag = f"FFTW_{forced.upper()}"
    else:
        flag = "FFTW_MEASURE" if points >= _MEASURED_POINTS else "FFTW_ESTIMATE"
    return flag, (_PLANNING_SECONDS if ndim == 3 else None)


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
    one_shot : bool
        The plan runs once (e.g. kernel spectra at set-up): always ``FFTW_ESTIMATE``.
    in_extent : tuple of int, optional
        The input is zero outside ``real[..., :e_1, …, :e_ndim]`` (zero padding): the forward
        transform skips the lines that are known to be zero (a pruned FFT, below).
    out_extent : tuple of int, optional
        Only ``real[..., :e_1, …, :e_ndim]`` of the inverse is used: the inverse transform
        computes only the lines that reach that block; the rest of ``real`` is left stale.
    in_place : bool, optional
        ``real`` is a view of ``spectrum``'s memory (FFTW's in-place layout, rows padded to
        ``2 (L // 2 + 1)`` values): half the memory; a forward transform destroys ``real``.

    Notes
    -----
    ``real`` and ``spectrum`` are the plan's own aligned buffers: write into ``real`` and call
    :meth:`forward` (result in ``spectrum``), or write ``spectrum`` and call :meth:`inverse`
    (unnormalised; result in ``real``). The inverse destroys ``spectrum``.

    Pruning: a multi-dimensional FFT is a sequence of 1-D transforms along each axis. Forward,
    the real-to-complex pass along the last axis needs only the lines inside the input block;
    each following complex pass along an earlier axis needs the lines inside the block of the
    axes not yet transformed (zero-filled beyond the block along its own axis). The inverse runs
    the same passes in reverse, keeping only the lines that reach the output block. For the
    DC-FFT grids here (data on half of each axis) this saves about 40 % of a 3-D transform.
    Requires pyfftw; the scipy fallback transforms everything.
    """

    def __init__(
        self,
        shape: Sequence[int],
        ndim: int,
        threads: int | None = None,
        one_shot: bool = False,
        in_extent: Sequence[int] | None = None,
        out_extent: Sequence[int] | None = None,
        in_place: bool = False,
    ):
        self.shape = tuple(int(s) for s in shape)
        self.ndim = ndim
        self.axes = tuple(range(len(self.shape) - ndim, len(self.shape)))
        self.size = int(np.prod([self.shape[a] for a in self.axes]))
        # Threads help only for large enough transforms; on small ones FFTW's synchronisation
        # costs more than it saves, by far when the other core is busy. Campaign workers run on
        # one thread each.
        total = int(np.prod(self.shape))
        self.threads = threads or (default_threads() if total >= _THREADED_POINTS else 1)
        spec_shape = self.shape[:-1] + (self.shape[-1] // 2 + 1,)
        self.spectrum_shape = spec_shape
        self._fwd = self._inv = None
        self._fwd_stages: list | None = None
        self._inv_stages: list | None = None
        self._real_written = False
        self._in_place = False
        self._real_tail: tuple | None = None
        if HAVE_PYFFTW:
            self.spectrum = pyfftw.empty_aligned(spec_shape, dtype="complex128")
            self._in_place = in_place
            if self._in_place:
                # the real array is a view of the spectrum's memory (rows padded to
                # 2 (L // 2 + 1) values, FFTW's in-place layout): half the buffer memory
                self.real = self.spectrum.view(np.float64)[..., : self.shape[-1]]
            else:
                self.real = pyfftw.empty_aligned(self.shape, dtype="float64")
            self._planner, self._time_limit = _planner(self.size, ndim, one_shot)
            in_block = self._pruned_extent(in_extent)
            if in_block is not None:
                self._fwd_stages = self._forward_stages(in_block)
            else:
                self._fwd = self._plan(self.real, self.spectrum, self.axes, "FFTW_FORWARD")
            out_block = self._pruned_extent(out_extent)
            if out_block is not None:
                self._inv_stages = self._inverse_stages(out_block)
            else:
                self._inv = self._plan(
                    self.spectrum, self.real, self.axes, "FFTW_BACKWARD", destroy=True
                )
            if not self._in_place:  # in place, the real array is a view of the spectrum's
                self.real[...] = 0.0
            self.spectrum[...] = 0.0
        else:  # pragma: no cover - fallback
            self.real = np.zeros(self.shape)
            self.spectrum = np.zeros(spec_shape, dtype=complex)

    def _pruned_extent(self, extent: Sequence[int] | None) -> tuple[int, ...] | None:
        """Return ``extent`` as integers when the transform can skip lines, else None."""
        if extent is None or self.ndim < 2:
            return None
        if len(extent) != self.ndim:
            raise ValueError(f"extent {tuple(extent)} must give one length per transformed axis")
        full = self.shape[-self.ndim:]
        if any(not 0 < e <= n for e, n in zip(extent, full, strict=True)):
            raise ValueError(f"extent {tuple(extent)} outside the grid {full}")
        if any(e < n for e, n in zip(extent[:-1], full[:-1], strict=True)):
            return tuple(int(e) for e in extent)
        return None

    def _plan(self, a, b, axes, direction: str, destroy: bool = False):
        flags = (self._planner,) + (("FFTW_DESTROY_INPUT",) if destroy else ())
        return _new_plan(a, b, axes=axes, direction=direction, flags=flags,
                         threads=self.threads, planning_timelimit=self._time_limit)

    def _block(self, extent: Sequence[int | None]) -> tuple:
        """Index of ``[..., :e_1, …]`` over the transformed axes (``None``: whole axis)."""
        lead = (slice(None),) * (len(self.shape) - self.ndim)
        return lead + tuple(slice(None, e) for e in extent)

    def _forward_stages(self, ext: tuple[int, ...]) -> list:
        k, axes = self.ndim, self.axes
        block = self._block(ext[:-1] + (None,))
        # The lines read by the first pass must be zero beyond the block: the caller keeps the
        # padding zero, an inverse through the same buffer does not (cleared after one, below).
        tail = self._block(ext[:-1] + (None,))[:-1] + (slice(ext[-1], None),)
        self._real_tail = tail if ext[-1] < self.shape[-1] else None
        first = self._plan(self.real[block], self.spectrum[block], (axes[-1],), "FFTW_FORWARD")
        stages: list[tuple[tuple | None, Any]] = [(None, first)]
        for j in range(k - 2, -1, -1):  # complex passes, from the second-to-last axis back
            lines = self._block(ext[:j] + (None,) * (k - j))
            view = self.spectrum[lines]
            lead = (slice(None),) * (len(self.shape) - k)
            zero = (lead + tuple(slice(None, e) for e in ext[:j]) + (slice(ext[j], None),)
                    + (slice(None),) * (k - j - 1))
            stages.append((zero if ext[j] < self.shape[axes[j]] else None,
                           self._plan(view, view, (axes[j],), "FFTW_FORWARD")))
        return stages

    def _inverse_stages(self, ext: tuple[int, ...]) -> list:
        k, axes = self.ndim, self.axes
        stages = []
        for j in range(k - 1):  # complex passes, first axis first
            view = self.spectrum[self._block(ext[:j] + (None,) * (k - j))]
            stages.append(self._plan(view, view, (axes[j],), "FFTW_BACKWARD"))
        block = self._block(ext[:-1] + (None,))
        stages.append(self._plan(self.spectrum[block], self.real[block], (axes[-1],),
                                 "FFTW_BACKWARD", destroy=True))
        return stages

    def forward(self) -> np.ndarray:
        """Transform ``real`` into ``spectrum`` (unnormalised) and return ``spectrum``."""
        if self._fwd is not None:
            self._fwd.execute()
        elif self._fwd_stages is not None:
            if self._real_written and self._real_tail is not None:
                self.real[self._real_tail] = 0.0
            for zero, plan in self._fwd_stages:  # zero: spectrum lines beyond the block
                if zero is not None:
                    self.spectrum[zero] = 0.0
                plan.execute()
            # in place, the spectrum now fills the real rows beyond the input block too
            self._real_written = self._in_place
        else:  # pragma: no cover
            import scipy.fft

            self.spectrum[...] = scipy.fft.rfftn(self.real, axes=self.axes, workers=self.threads)
        return self.spectrum

    def inverse(self) -> np.ndarray:
        """Transform ``spectrum`` into ``real`` *without* the 1/N factor and return ``real``."""
        self._real_written = True  # possibly beyond a forward's input block
        if self._inv is not None:
            self._inv.execute()
        elif self._inv_stages is not None:
            for plan in self._inv_stages:
                plan.execute()
        else:  # pragma: no cover
            import scipy.fft

            lengths = [self.shape[a] for a in self.axes]
            self.real[...] = scipy.fft.irfftn(
                self.spectrum, s=lengths, axes=self.axes, workers=self.threads
            ) * self.size
        return self.real

    @property
    def nbytes(self) -> int:
        """Bytes held by the buffers (one, shared, when the transform is in place)."""
        shared = np.shares_memory(self.real, self.spectrum)
        return self.spectrum.nbytes + (0 if shared else self.real.nbytes)


#: scipy.fft fallback (function name, type) of each FFTW real-to-real kind used here;
#: unnormalised, the same definitions (FFTW manual §4.8.3, scipy.fft.dct/dst with norm=None).
_R2R_FALLBACK = {
    "FFTW_REDFT10": ("dct", 2),
    "FFTW_REDFT01": ("dct", 3),
    "FFTW_RODFT10": ("dst", 2),
    "FFTW_RODFT01": ("dst", 3),
}


class RealToReal:
    """Cached real-to-real transform (a DCT or DST of FFTW's ``kind``) along one axis.

    Parameters
    ----------
    src, dst : ndarray
        Input and output (float64, same shape; strided views are fine; the same array for an
        in-place transform). Out of place, ``src`` is kept intact.
    axis : int
        Axis transformed.
    kind : str
        ``"FFTW_REDFT10"`` (DCT-II), ``"FFTW_REDFT01"`` (DCT-III), ``"FFTW_RODFT10"`` (DST-II) or
        ``"FFTW_RODFT01"`` (DST-III); unnormalised: a type II then its type III multiplies by
        twice the length.
    threads : int, optional
        FFT threads; default as :class:`RealFFT` (threaded from 2^18 points).
    """

    def __init__(self, src: np.ndarray, dst: np.ndarray, axis: int, kind: str,
                 threads: int | None = None):
        if kind not in _R2R_FALLBACK:
            raise ValueError(f"unknown real-to-real kind {kind!r}")
        if src.shape != dst.shape:
            raise ValueError(f"shapes differ: {src.shape} and {dst.shape}")
        self.src, self.dst, self.axis, self.kind = src, dst, axis, kind
        threads = threads or (default_threads() if src.size >= _THREADED_POINTS else 1)
        self._plan = None
        if HAVE_PYFFTW:
            # FFTW's estimated real-to-real plans are several times slower than measured ones on
            # batches of strided lines: always measure, within the time limit of 3-D plans (src
            # is overwritten while planning).
            forced = fftw_planner_from_env() == "estimate"
            flag = "FFTW_ESTIMATE" if forced else "FFTW_MEASURE"
            self._plan = _new_plan(src, dst, axes=(axis,), direction=[kind], flags=(flag,),
                                   threads=threads, planning_timelimit=_PLANNING_SECONDS)

    def __call__(self) -> np.ndarray:
        """Transform ``src`` into ``dst`` and return ``dst``."""
        if self._plan is not None:
            self._plan.execute()
        else:  # pragma: no cover - fallback
            import scipy.fft

            function, kind = _R2R_FALLBACK[self.kind]
            self.dst[...] = getattr(scipy.fft, function)(self.src, type=kind, axis=self.axis)
        return self.dst


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
    block : int, optional
        Output components transformed together (default: all). Smaller blocks keep the inverse
        transform's buffers small, ``block`` padded grids instead of ``n_out_comp`` (the
        pressure-to-stress operator of a 128 × 128 × 16 grid: 6 MB instead of 100 MB, which
        also stays in cache), for the same FFT work.
    cache : (str, mapping), optional
        Kind and parameters under which the kernel spectra are kept in the disk cache
        (:func:`sacflow.machine.kernel_cache.cached_arrays`); the parameters must hold everything
        the
        coefficients depend on (the grid shapes and offset are added here). Default: computed
        every time.

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
            return out[0]
        return out
