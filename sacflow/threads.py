"""Thread budget of the numerical core: FFTW threads on, BLAS threads off.

The core's BLAS calls are short (dot products of one grid, least-squares problems of a few
columns) and OpenBLAS worker threads keep spinning after each call for a while. On a machine
with few cores those spinning threads compete with FFTW's threads for the same cores: measured on
this project's 2-core machine, a 512² contact solve took 3.9 s with the default BLAS threads and
1.6 s with one BLAS thread (same FFTW plans). The compute entry points therefore run inside
:func:`single_threaded_blas`; the limit is lifted again on exit, so a notebook's own BLAS work
is unaffected.
"""

from __future__ import annotations

import contextlib
import functools
from collections.abc import Iterator

from threadpoolctl import ThreadpoolController

__all__ = ["single_threaded_blas"]


@functools.lru_cache(maxsize=1)
def _controller() -> ThreadpoolController:
    """Controller over the BLAS libraries loaded when first asked (after the core's imports)."""
    import scipy.linalg  # noqa: F401 - make sure SciPy's own BLAS is loaded and seen

    return ThreadpoolController()


@contextlib.contextmanager
def single_threaded_blas() -> Iterator[None]:
    """Limit every loaded BLAS library to one thread inside the block (cost ≈ 10 µs)."""
    with _controller().limit(limits=1, user_api="blas"):
        yield
