"""FFT back end: cached pyfftw plans of real transforms (pruned, in place, real-to-real).

Conventions
-----------
* Forward transforms are unnormalised and so are the inverses (no ``1/N``): the operators fold
  every normalisation into their cached kernel spectra (:mod:`sacflow.kernels.convolution`,
  :mod:`sacflow.kernels.eigenstrain`).
* pyfftw plans and their aligned buffers are built once per operator (FFTW's own wisdom makes
  re-planning a known shape cheap, :mod:`sacflow.kernels.fftw_wisdom`); ``scipy.fft`` is the
  fallback when pyfftw is not importable, imported only then (its import is a sizeable part of a
  campaign worker's start).
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from typing import Any

import numpy as np

from sacflow.machine import resources
from sacflow.machine.environment import fft_threads_from_env, fftw_planner_from_env

#: Optional modules pyfftw's package imports for its interfaces, which sacflow does not use:
#: ``dask.array`` (with xarray and pandas) and ``scipy.fftpack`` (with ``scipy.fft``).
_PYFFTW_OPTIONAL = ("dask.array", "scipy.fftpack")


def _import_pyfftw() -> Any:
    """Import pyfftw without its dask and scipy interfaces (None without pyfftw).

    pyfftw has no type information: the module is typed ``Any``.

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
#: A ``pyfftw.FFTW`` plan (pyfftw has no type information).
FFTWPlan = Any
#: An index of the transformed block of a buffer (one slice per axis).
Index = tuple[slice, ...]
HAVE_PYFFTW = pyfftw is not None

__all__ = ["HAVE_PYFFTW", "RealFFT", "RealToReal", "default_threads"]


#: Time limit of one measured 3-D plan [s]: FFTW keeps the best plan found by then. A longer
#: search lengthens the operator's set-up for plans hardly faster (``docs/performance.md``).
_PLANNING_SECONDS = 0.3
#: Transforms with fewer points (batch included) run on one thread: below it FFTW's thread
#: synchronisation costs more than a second thread gains (``docs/performance.md``).
_THREADED_POINTS = 1 << 18


def default_threads() -> int:
    """Return the number of FFT threads: ``SACFLOW_FFT_THREADS`` or the number of usable cores.

    The variable is capped at the usable cores (with a warning), see
    :func:`~sacflow.machine.environment.fft_threads_from_env`.

    A value that is not a whole number >= 1 raises
    :class:`~sacflow.errors.EnvironmentVariableError` (see :mod:`sacflow.machine.environment`).
    """
    from_env = fft_threads_from_env()
    return resources.usable_cores() if from_env is None else from_env


def _new_plan(*args: Any, **kwargs: Any) -> FFTWPlan:
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
    the same passes in reverse, keeping only the lines that reach the output block: on the
    DC-FFT grids (data on half of each axis) a sizeable part of a 3-D transform is skipped
    (``docs/performance.md``). Requires pyfftw; the scipy fallback transforms everything.
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
        self._fwd: FFTWPlan | None = None
        self._inv: FFTWPlan | None = None
        self._fwd_stages: list[tuple[Index | None, FFTWPlan]] | None = None
        self._inv_stages: list[FFTWPlan] | None = None
        self._real_written = False
        self._in_place = False
        self._real_tail: Index | None = None
        self.real: np.ndarray
        self.spectrum: np.ndarray
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

    def _plan(self, a: np.ndarray, b: np.ndarray, axes: tuple[int, ...], direction: str,
              destroy: bool = False) -> FFTWPlan:
        flags = (self._planner,) + (("FFTW_DESTROY_INPUT",) if destroy else ())
        return _new_plan(a, b, axes=axes, direction=direction, flags=flags,
                         threads=self.threads, planning_timelimit=self._time_limit)

    def _block(self, extent: Sequence[int | None]) -> Index:
        """Index of ``[..., :e_1, …]`` over the transformed axes (``None``: whole axis)."""
        lead = (slice(None),) * (len(self.shape) - self.ndim)
        return lead + tuple(slice(None, e) for e in extent)

    def _forward_stages(self, ext: tuple[int, ...]) -> list[tuple[Index | None, FFTWPlan]]:
        k, axes = self.ndim, self.axes
        block = self._block(ext[:-1] + (None,))
        # The lines read by the first pass must be zero beyond the block: the caller keeps the
        # padding zero, an inverse through the same buffer does not (cleared after one, below).
        tail = self._block(ext[:-1] + (None,))[:-1] + (slice(ext[-1], None),)
        self._real_tail = tail if ext[-1] < self.shape[-1] else None
        first = self._plan(self.real[block], self.spectrum[block], (axes[-1],), "FFTW_FORWARD")
        stages: list[tuple[Index | None, FFTWPlan]] = [(None, first)]
        for j in range(k - 2, -1, -1):  # complex passes, from the second-to-last axis back
            lines = self._block(ext[:j] + (None,) * (k - j))
            view = self.spectrum[lines]
            lead = (slice(None),) * (len(self.shape) - k)
            zero = (lead + tuple(slice(None, e) for e in ext[:j]) + (slice(ext[j], None),)
                    + (slice(None),) * (k - j - 1))
            stages.append((zero if ext[j] < self.shape[axes[j]] else None,
                           self._plan(view, view, (axes[j],), "FFTW_FORWARD")))
        return stages

    def _inverse_stages(self, ext: tuple[int, ...]) -> list[FFTWPlan]:
        k, axes = self.ndim, self.axes
        stages: list[FFTWPlan] = []
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
        return int(self.spectrum.nbytes + (0 if shared else self.real.nbytes))


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
        self._plan: FFTWPlan | None = None
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
