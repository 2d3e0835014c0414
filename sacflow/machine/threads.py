"""Thread budget of the numerical core: FFTW threads on, BLAS threads off.

The core's BLAS calls are short (dot products of one grid, least-squares problems of a few
columns) and OpenBLAS worker threads keep spinning after each call for a while. On a machine
with few cores those spinning threads compete with FFTW's threads for the same cores: a contact
solve took more than twice as long (``docs/performance.md``). The compute entry points run
inside :func:`single_threaded_blas`; the limit is lifted again on exit, so a notebook's own BLAS
work is unaffected.

The loops of the kernels' set-up are shared out between threads here too
(:func:`contiguous_ranges`, :func:`in_threads`), and so are the compiled passes over the cuboid
box that run at every evaluation of a plastic increment (:func:`over_ranges`, on a pool kept for
the process).
"""

from __future__ import annotations

import contextlib
import functools
import sys
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np
from threadpoolctl import ThreadpoolController

__all__ = ["SPLIT_ITEMS", "contiguous_ranges", "in_threads", "over_ranges",
           "single_threaded_blas"]

#: Passes over fewer items (float64 entries read, or their equivalent in work) than this run
#: on the calling thread alone: a pass over arrays that fit in the last-level cache (16 MB
#: each, half of a common 32 MB cache) is as fast on one thread, and handing a part to another
#: costs more than it saves; beyond, the arrays stream from memory and a second thread gains
#: (the measurements: ``docs/performance.md``, "Two threads on a strongly plastic step").
SPLIT_ITEMS = 1 << 21


def _controller() -> ThreadpoolController:
    """Return a controller over the BLAS libraries loaded now.

    numpy's BLAS is loaded with numpy; SciPy's own BLAS with ``scipy.linalg``, which every
    SciPy module that calls BLAS imports (the plastic solver's gmres, for one). The controller
    is built again once, when ``scipy.linalg`` appears. It is not imported here: an elastic
    run does not need it, and its import (with ``numpy.f2py`` and ``charset_normalizer``) is
    slow, paid by the first case of every process.
    """
    return _controller_for("scipy.linalg" in sys.modules)


@functools.lru_cache(maxsize=2)
def _controller_for(scipy_linalg_loaded: bool) -> ThreadpoolController:
    """Build the controller for ``scipy.linalg`` (not) loaded; cached: building it is slow."""
    return ThreadpoolController()


@contextlib.contextmanager
def single_threaded_blas() -> Iterator[None]:
    """Limit every loaded BLAS library to one thread inside the block (cheap: cached)."""
    with _controller().limit(limits=1, user_api="blas"):
        yield


def contiguous_ranges(count: int, parts: int) -> list[tuple[int, int]]:
    """Split ``0 … count − 1`` into ``min(parts, count)`` contiguous ranges ``(first, last)``.

    One range per thread: consecutive items stay together (a thread's planes of corner
    functions serve consecutive depth offsets; its writes touch one block of the result).
    """
    parts = max(1, min(parts, count))
    bounds = np.linspace(0, count, parts + 1).round().astype(int)
    return [(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]


def in_threads(function: Callable[..., None], threads: int,
               *arguments: Sequence[Any]) -> None:
    """Call ``function`` on each tuple of ``arguments`` in up to ``threads`` threads, and wait.

    The loops of the kernels' set-up over planes, layers, projections and blocks: numpy,
    scipy.fft and FFTW release the GIL; each call writes its own part of the result, so the
    result does not depend on the split.
    """
    count = len(arguments[0])
    with ThreadPoolExecutor(max(1, min(threads, count)), "sacflow-kernels") as pool:
        list(pool.map(function, *arguments))


@functools.cache
def _pool(threads: int) -> ThreadPoolExecutor:
    """Return the process's pool of ``threads`` threads for :func:`over_ranges` (made once)."""
    return ThreadPoolExecutor(threads, "sacflow-ranges")


def over_ranges(kernel: Callable[..., Any], count: int, threads: int, *arguments: Any,
                weight: int = 1) -> list[Any]:
    """Call ``kernel(*arguments, first, last)`` on contiguous ranges of ``0 … count − 1``.

    The ranges (:func:`contiguous_ranges`, one per thread) run at once, the first on the
    calling thread, the others on a pool kept for the process; the results come back in range
    order. ``kernel`` must release the GIL (a ``nogil`` compiled loop) and write only its own
    range of the outputs, so that the result does not depend on the number of threads.
    ``count × weight`` below :data:`SPLIT_ITEMS` (``weight``: items per index, e.g. the cells
    of a row) runs as one range on the calling thread.
    """
    if threads <= 1 or count * weight < SPLIT_ITEMS or count < 2:
        return [kernel(*arguments, 0, count)]
    ranges = contiguous_ranges(count, threads)
    pool = _pool(len(ranges) - 1)
    futures = [pool.submit(kernel, *arguments, first, last) for first, last in ranges[1:]]
    results = [kernel(*arguments, *ranges[0])]
    results.extend(future.result() for future in futures)
    return results
