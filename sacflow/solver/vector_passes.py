"""Compiled passes over the plastic fixed point's vectors, shared out between threads.

An evaluation of an increment's fixed point (:mod:`sacflow.solver.fixed_point`) and its
Anderson step (:mod:`sacflow.solver.anderson`) make a dozen elementwise passes over vectors of
the box's size (six components per cuboid) or of the plastic zone's: the trial stress, the
residual's norms, the gathers and scatters between the box and the support of the history, the
mixing of the stored differences. As numpy expressions each is a pass of its own with a
temporary, on one thread, while the FFTs around them use every core. Here each is one compiled
loop over a range of the vector (:func:`sacflow.machine.threads.over_ranges` runs the ranges in
threads), with the same floating-point operations in the same order as the numpy expressions
they replace, so the iterates do not change, whatever the number of threads. The history's
dot products (:func:`column_dots`) are the exception to numpy's order, not to the rule: sums
over blocks fixed in advance, the same on any number of threads.

Every compiled loop takes ``first, last`` (the range) as its last two arguments, takes views of
that range of its arrays and runs from 0: an index numba cannot prove non-negative (such as one
running from ``first``) gets Python's negative-index wraparound at every access, which keeps
LLVM from vectorising the loop (several times slower than numpy's own loop).
"""

from __future__ import annotations

from collections.abc import Sequence

import numba
import numpy as np

from sacflow.kernels.fft import default_threads
from sacflow.machine import threads as thread_budget
from sacflow.machine.threads import over_ranges

__all__ = ["DOT_BLOCK", "DOT_SLOTS", "column_dots", "gather_differences", "largest_magnitudes",
           "mix_start", "mix_subtract", "new_nonzeros", "scatter_support", "summed", "threads",
           "trial_stress"]


#: Entries of each partial sum of :func:`column_dots` (128 kB of a vector, so that the two
#: vectors' blocks stay in the core's cache while every column passes over them). Fixed, not a
#: share of a thread: the partial sums, and so the dot products, do not depend on the threads.
DOT_BLOCK = 1 << 14
#: Columns of :func:`column_dots` per pass over the two vectors (a fixed number of arguments:
#: one compiled loop whatever the history's depth).
DOT_SLOTS = 4


def threads() -> int:
    """Threads of these passes: those of the FFTs (``SACFLOW_FFT_THREADS`` or the cores)."""
    return default_threads()


@numba.njit(nogil=True, cache=True, boundscheck=False)
def _trial_stress(x: np.ndarray, stress: np.ndarray, two_mu: float, out: np.ndarray,
                  first: int, last: int) -> None:  # pragma: no cover - compiled
    x, stress, out = x[first:last], stress[first:last], out[first:last]
    for i in range(out.size):
        out[i] = x[i] * two_mu + stress[i]


@numba.njit(nogil=True, cache=True, boundscheck=False)
def _total(a: np.ndarray, b: np.ndarray, out: np.ndarray, first: int,
           last: int) -> None:  # pragma: no cover - compiled
    a, b, out = a[first:last], b[first:last], out[first:last]
    for i in range(out.size):
        out[i] = a[i] + b[i]


def summed(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Return ``a + b`` (the plastic strain before an increment plus the increment), one pass."""
    out = np.empty(a.shape)
    over_ranges(_total, a.size, threads(), a.reshape(-1), b.reshape(-1), out.reshape(-1))
    return out


def trial_stress(x: np.ndarray, stress: np.ndarray, two_mu: float) -> np.ndarray:
    """``σ + 2μ x`` (the elastic trial stress of a plastic strain increment ``x``), same shape."""
    out = np.empty(stress.shape)  # C order: its flat view is itself
    over_ranges(_trial_stress, x.size, threads(), x.reshape(-1), stress.reshape(-1), two_mu,
                out.reshape(-1))
    return out


@numba.njit(nogil=True, cache=True, boundscheck=False)
def _magnitudes(a: np.ndarray, b: np.ndarray, first: int,
                last: int) -> tuple[float, float, float]:  # pragma: no cover - compiled
    largest_a = largest_b = largest_change = 0.0
    nan = False
    a, b = a[first:last], b[first:last]
    for i in range(a.size):
        u, v = a[i], b[i]
        nan |= (u != u) | (v != v)
        largest_a = max(largest_a, abs(u))
        largest_b = max(largest_b, abs(v))
        largest_change = max(largest_change, abs(v - u))
    if nan:
        return np.nan, np.nan, np.nan
    return largest_a, largest_b, largest_change


def largest_magnitudes(a: np.ndarray, b: np.ndarray) -> tuple[float, float, float]:
    """``(max |a|, max |b|, max |b − a|)`` in one pass (NaN for all three if one holds a NaN).

    Exact whatever the split: a maximum does not depend on the order it is taken in.
    """
    parts = over_ranges(_magnitudes, a.size, threads(), a.reshape(-1), b.reshape(-1))
    values = np.array(parts).max(axis=0)  # NaN wins, as it does in numpy's maximum
    return float(values[0]), float(values[1]), float(values[2])


@numba.njit(nogil=True, cache=True, boundscheck=False)
def _new_nonzeros(x: np.ndarray, gx: np.ndarray, kept: np.ndarray, first: int,
                  last: int) -> int:  # pragma: no cover - compiled
    count = 0
    x, gx, kept = x[first:last], gx[first:last], kept[first:last]
    for i in range(x.size):
        if not kept[i] and (x[i] != 0.0 or gx[i] != 0.0):
            count += 1
    return count


def new_nonzeros(x: np.ndarray, gx: np.ndarray, kept: np.ndarray) -> int:
    """Entries where ``x`` or ``gx`` is nonzero and ``kept`` is False (flat arrays)."""
    return sum(over_ranges(_new_nonzeros, x.size, threads(), x, gx, kept))


@numba.njit(nogil=True, cache=True, boundscheck=False)
def _gather_differences(x: np.ndarray, gx: np.ndarray, support: np.ndarray,
                        last_x: np.ndarray, last_f: np.ndarray, xs: np.ndarray, f: np.ndarray,
                        dx: np.ndarray, df: np.ndarray, first: int,
                        last: int) -> None:  # pragma: no cover - compiled
    support, xs, f = support[first:last], xs[first:last], f[first:last]
    if dx.size > 0:
        dx, df = dx[first:last], df[first:last]
        last_x, last_f = last_x[first:last], last_f[first:last]
        for k in range(support.size):  # xs may be last_x, f last_f: read each before writing
            s = support[k]
            xk = x[s]
            fk = gx[s] - xk
            dx[k] = xk - last_x[k]
            df[k] = fk - last_f[k]
            xs[k] = xk
            f[k] = fk
        return
    for k in range(support.size):
        s = support[k]
        xs[k] = x[s]
        f[k] = gx[s] - x[s]


def gather_differences(x: np.ndarray, gx: np.ndarray, support: np.ndarray,
                       last: tuple[np.ndarray, np.ndarray] | None,
                       spare: tuple[np.ndarray, np.ndarray] | None = None
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray | None]:
    """Gather the iterate and its residual on the support, and their differences.

    Returns ``xs = x[s]``, ``f = G(x)[s] − xs`` and, given the previous ``(xs, f)`` as
    ``last``, ``Δx = xs − xs_prev`` and ``Δf = f − f_prev`` (else None for both). ``xs`` and
    ``f`` are written over ``last``'s arrays (which the caller no longer needs), the
    differences into ``spare`` if given (two arrays of the support's size that are done with,
    e.g. the history's oldest pair about to be dropped): no new arrays for what a step keeps.
    """
    size = support.size
    empty = np.empty(0)
    xs, f = last if last is not None else (np.empty(size), np.empty(size))
    dx, df = empty, empty
    if last is not None:
        dx, df = spare if spare is not None else (np.empty(size), np.empty(size))
    last_x, last_f = last if last is not None else (empty, empty)
    over_ranges(_gather_differences, size, threads(), x, gx, support, last_x, last_f, xs, f,
                dx, df)
    return xs, f, (dx if last is not None else None), (df if last is not None else None)


@numba.njit(nogil=True, cache=True, boundscheck=False)
def _mix_start(xs: np.ndarray, f: np.ndarray, beta: float, out: np.ndarray, first: int,
               last: int) -> None:  # pragma: no cover - compiled
    xs, f, out = xs[first:last], f[first:last], out[first:last]
    for k in range(out.size):
        out[k] = xs[k] + beta * f[k]


def mix_start(xs: np.ndarray, f: np.ndarray, beta: float) -> np.ndarray:
    """``xs + β f``: the relaxed Picard iterate that the mixing corrects."""
    out = np.empty_like(xs)
    over_ranges(_mix_start, xs.size, threads(), xs, f, beta, out)
    return out


@numba.njit(nogil=True, cache=True, boundscheck=False)
def _mix_subtract(mixed: np.ndarray, dx: np.ndarray, df: np.ndarray, gamma: float,
                  beta: float, first: int, last: int) -> None:  # pragma: no cover - compiled
    mixed, dx, df = mixed[first:last], dx[first:last], df[first:last]
    for k in range(mixed.size):
        mixed[k] -= gamma * (dx[k] + beta * df[k])


def mix_subtract(mixed: np.ndarray, dx: np.ndarray, df: np.ndarray, gamma: float,
                 beta: float) -> None:
    """``mixed −= γ (Δx + β Δf)`` in place: one stored difference's share of the step."""
    over_ranges(_mix_subtract, mixed.size, threads(), mixed, dx, df, gamma, beta)


@numba.njit(nogil=True, cache=True, boundscheck=False)
def _scatter_support(values: np.ndarray, support: np.ndarray, out: np.ndarray, first: int,
                     last: int) -> None:  # pragma: no cover - compiled
    k = np.searchsorted(support, first)
    size = support.size
    out = out[first:last]
    for t in range(out.size):
        if k < size and support[k] == first + t:
            out[t] = values[k]
            k += 1
        else:
            out[t] = 0.0


def scatter_support(values: np.ndarray, support: np.ndarray, size: int,
                    out: np.ndarray | None = None) -> np.ndarray:
    """Return the ``size``-entry vector holding ``values`` on the (sorted) support, 0 off it.

    Written into ``out`` (flat, float, of ``size`` entries, overwritten) if given: a vector the
    caller is done with, instead of a new one (at 128 × 128 × 64 cuboids a new 50 MB vector is
    mapped from the kernel and its pages zero-filled as they are first written).
    """
    if out is None:
        out = np.empty(size)
    elif out.shape != (size,) or out.dtype != np.float64 or not out.flags.c_contiguous:
        raise ValueError(f"out must be a contiguous float vector of {size} entries")
    over_ranges(_scatter_support, size, threads(), values, support, out)
    return out


@numba.njit(nogil=True, cache=True, boundscheck=False, fastmath={"reassoc", "contract"})
def _column_dots(c0: np.ndarray, c1: np.ndarray, c2: np.ndarray, c3: np.ndarray, used: int,
                 a: np.ndarray, b: np.ndarray, partial: np.ndarray, first: int,
                 last: int) -> None:  # pragma: no cover - compiled
    size = a.size
    columns = (c0, c1, c2, c3)
    for block in range(first, last):
        start = block * DOT_BLOCK
        stop = min(start + DOT_BLOCK, size)
        a_block, b_block = a[start:stop], b[start:stop]
        for k in range(used):
            column = columns[k][start:stop]
            with_a = with_b = 0.0
            for i in range(column.size):
                with_a += column[i] * a_block[i]
                with_b += column[i] * b_block[i]
            partial[block, k, 0] = with_a
            partial[block, k, 1] = with_b


def column_dots(columns: Sequence[np.ndarray], a: np.ndarray,
                b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(c_k · a, c_k · b)`` for every column ``c_k``, in one pass over the vectors.

    The Anderson step needs the new ΔF difference's products with every stored one (a row of
    the Gram matrix) and the residual's (the right-hand side): as separate dot products that
    reads each stored column twice and the two vectors once per column; here the columns go
    :data:`DOT_SLOTS` at a time, each block of the two vectors read once for them all. Each
    product is a sum of partial sums over fixed blocks of :data:`DOT_BLOCK` entries, added in
    block order, so it is the same whatever the number of threads (it differs from numpy's dot
    product by rounding: the order of the additions is another). Vectors below
    :data:`~sacflow.machine.threads.SPLIT_ITEMS` entries, which stay in the cache, take numpy's
    dot products instead: there the compiled sums are slower than BLAS, and the memory traffic
    they save is not what limits the step (``docs/performance.md``).
    """
    count = len(columns)
    if a.size < thread_budget.SPLIT_ITEMS:  # in cache: numpy's (BLAS) products are faster
        return (np.array([float(column @ a) for column in columns]),
                np.array([float(column @ b) for column in columns]))
    blocks = -(-a.size // DOT_BLOCK)
    partial = np.zeros((blocks, count, 2))
    for first in range(0, count, DOT_SLOTS):
        group = list(columns[first:first + DOT_SLOTS])
        used = len(group)
        group += [a] * (DOT_SLOTS - used)  # unused slots, never read
        over_ranges(_column_dots, blocks, threads(), *group, used, a, b,
                    partial[:, first:first + used], weight=DOT_BLOCK * (used + 2))
    sums = partial.sum(axis=0)
    return sums[:, 0].copy(), sums[:, 1].copy()
