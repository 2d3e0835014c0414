"""Anderson mixing for fixed points x = G(x).

Type II Anderson acceleration: Walker & Ni, SIAM J. Numer. Anal. 49 (2011) 1715,
doi:10.1137/10078356X.

Used by the solver to accelerate the plastic-strain fixed point of seed §1.7 (Figs. 4–5), which
plain (Picard) iteration solves in hundreds of sweeps (seed §2.5). Its compiled passes
(:mod:`sacflow.solver.vector_passes`, numba) are imported where they run: an elastic run, which
never mixes, does not load numba (the libraries of :mod:`sacflow.solver.memory_estimate`).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence

import numpy as np

__all__ = ["SUPPORT_MARGIN", "AndersonMixer"]

#: Cells by which a growing support is widened around the vectors' nonzeros (along every axis of
#: ``shape`` but the last, the components). The plastic zone grows by about a cell a sweep in the
#: first sweeps of an increment, and every growth lays each stored vector out anew (a pass over
#: the whole history); with the margin the support is laid out a few times an increment instead.
SUPPORT_MARGIN = 1


class AndersonMixer:
    """Stateful Anderson accelerator: feed ``(x, G(x))``, get the next iterate.

    Parameters
    ----------
    depth : int
        Number of previous residual differences kept (``0`` = plain Picard iteration).
    mixing : float
        Relaxation β in ``x⁺ = x + β f − (ΔX + β ΔF) γ``.
    shape : sequence of int, optional
        Shape of the vectors (flat in C order when fed), e.g. ``(n1, n2, n3, 6)``: a support
        that grows is then widened by :data:`SUPPORT_MARGIN` cells along its axes but the last.

    Notes
    -----
    The history is kept on the support of the vectors seen (the entries where some ``x`` or
    ``G(x)`` was nonzero), which only grows: outside it every stored difference is zero, and
    so is the next iterate. The plastic strain increment is nonzero in the plastic zone only,
    a part of the cuboid box (at 128 × 128 × 64 cuboids a tenth under a mildly plastic step,
    half under a strongly plastic one): the history takes that
    part of the memory and of the time of full vectors, with the same result to rounding.
    Given the vectors' ``shape``, a support that grows takes every cell within
    :data:`SUPPORT_MARGIN` of the new nonzeros at once (zero entries, which change no iterate):
    at 128 × 128 × 64 cuboids under a strongly plastic step the history is then laid out 4
    times in 24 sweeps instead of 12, for a support 7 % larger.
    The passes over the vectors (gathers, differences, the mixing, the scatter back) are
    compiled loops shared out between threads (:mod:`sacflow.solver.vector_passes`) with
    numpy's operations in numpy's order; the dot products are sums over fixed blocks, the same
    whatever the threads. The iterates do not depend on the number of threads.
    """

    def __init__(self, depth: int = 5, mixing: float = 1.0,
                 shape: Sequence[int] | None = None):
        self.depth = depth
        self.mixing = mixing
        self._shape = tuple(shape) if shape is not None and len(shape) > 1 else None
        self._dx: deque[np.ndarray] = deque(maxlen=max(depth, 1))
        self._df: deque[np.ndarray] = deque(maxlen=max(depth, 1))
        self._gram = np.zeros((0, 0))  # ΔF^T ΔF, updated one column at a time
        self._last_x: np.ndarray | None = None
        self._last_f: np.ndarray | None = None
        self._support: np.ndarray = np.zeros(0, dtype=np.intp)  # sorted indices of those kept
        self._kept: np.ndarray | None = None  # the support as a mask over the full vector

    def reset(self) -> None:
        """Forget the history (e.g. after the problem changed)."""
        self._dx.clear()
        self._df.clear()
        self._gram = np.zeros((0, 0))
        self._last_x = self._last_f = None
        self._support = np.zeros(0, dtype=np.intp)
        self._kept = None

    def deepen(self, depth: int) -> None:
        """Keep up to ``depth`` differences from now on, the ones stored so far included.

        A deeper history lets the least-squares step span the slow directions of ``G`` that a
        short one keeps forgetting (Anderson(m) on a linear map is a windowed GMRES: Walker &
        Ni 2011, §2; a short window stagnates where GMRES(m) does). Nothing stored is lost, so
        the next step is the one the deeper mixer would take with this history.
        """
        if depth <= self.depth:
            return
        self.depth = depth
        self._dx = deque(self._dx, maxlen=depth)
        self._df = deque(self._df, maxlen=depth)

    def _grow_support(self, x: np.ndarray, gx: np.ndarray) -> None:
        """Add the nonzero entries of ``x`` and ``G(x)``; widen the stored vectors with zeros.

        The support is kept as a mask over the full vector too: the union and the old entries'
        places in it are a mask operation and two scans, linear in the vector's length (sorting
        or hashing the indices, as a set union does, costs far more on a large plastic zone).
        """
        from sacflow.solver.vector_passes import new_nonzeros, scatter_support  # compiled (numba)

        kept = self._kept
        if kept is None:
            kept = self._kept = np.zeros(x.size, dtype=bool)
        if not new_nonzeros(x, gx, kept):
            return
        new = x != 0.0
        new |= gx != 0.0
        if self._shape is not None:
            new = _widened_mask(new, self._shape, SUPPORT_MARGIN)
        new |= kept
        # sorted: the union of the old support and the nonzeros; indices of 32 bits when they
        # fit (half the memory of the support, and of the old entries' places in it)
        index = np.int32 if x.size <= np.iinfo(np.int32).max else np.intp
        support = np.flatnonzero(new).astype(index)
        where = np.flatnonzero(kept[support]).astype(index)  # the old entries' places
        self._kept = new

        def widened(v: np.ndarray) -> np.ndarray:
            return scatter_support(v, where, support.size)

        for history in (self._dx, self._df):  # one at a time: each old vector freed at once
            for k, v in enumerate(history):
                history[k] = widened(v)
        if self._last_x is not None and self._last_f is not None:
            self._last_x, self._last_f = widened(self._last_x), widened(self._last_f)
        self._support = support

    def _append(self, dx: np.ndarray, df: np.ndarray, row: np.ndarray) -> None:
        """Add a difference pair and its Gram row (``ΔF_k · df`` of the columns kept with it)."""
        gram = self._gram
        if len(self._df) == self._df.maxlen:
            gram = gram[1:, 1:]
        self._dx.append(dx)
        self._df.append(df)
        m = len(row)
        new = np.empty((m, m))
        new[: m - 1, : m - 1] = gram
        new[m - 1, :] = row
        new[:, m - 1] = row
        self._gram = new

    def step(self, x: np.ndarray, gx: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """Return the next iterate from the current ``x`` and ``G(x)`` (flat arrays).

        With ``out`` (a flat float vector of their size, e.g. ``gx`` itself when the caller has
        no further use for it) the iterate is written there once ``x`` and ``gx`` are read.

        The least-squares problem ``min_γ ‖f − ΔF γ‖`` is solved through its normal equations
        with the cached Gram matrix ``ΔF^T ΔF`` (a pseudo-inverse drops directions below 1e-13 of
        the largest): each step costs O(m n) for ``m`` stored differences of length ``n``
        (the support, class notes) instead of the O(m² n) of a QR factorisation of ``ΔF``.
        The new Gram row and the right-hand side ``ΔF^T f`` come from one pass over the stored
        columns and the two vectors (:func:`~sacflow.solver.vector_passes.column_dots`).
        """
        if self.depth == 0:
            plain: np.ndarray = x + self.mixing * (gx - x)
            return plain
        from sacflow.solver.vector_passes import (  # compiled (numba): plastic runs only
            column_dots,
            gather_differences,
            mix_start,
            mix_subtract,
            scatter_support,
        )

        x, gx = np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(gx, dtype=float)
        self._grow_support(x, gx)
        support = self._support
        last = None if self._last_x is None or self._last_f is None else (self._last_x,
                                                                         self._last_f)
        spare = None  # the oldest pair, if the next one drops it: its arrays take the new one
        if last is not None and self._df and len(self._df) == self._df.maxlen:
            spare = (self._dx[0], self._df[0])
        xs, f, dx, df = gather_differences(x, gx, support, last, spare)
        rhs = np.zeros(0)  # ΔF^T f; a history exists only after a first pair (dx from a last)
        if dx is not None and df is not None:
            # the columns the new pair joins (the oldest dropped when the history is full)
            kept = list(self._df)[1:] if len(self._df) == self._df.maxlen else list(self._df)
            row, rhs = column_dots([*kept, df], df, f)  # its Gram row, and ΔF^T f
            self._append(dx, df, row)
        self._last_x, self._last_f = xs, f
        mixed = mix_start(xs, f, self.mixing)
        if self._df:
            gamma = np.linalg.pinv(self._gram, rcond=1e-13, hermitian=True) @ rhs
            for g, dx_k, df_k in zip(gamma, self._dx, self._df, strict=True):
                mix_subtract(mixed, dx_k, df_k, float(g), self.mixing)
        return scatter_support(mixed, support, x.size, out)


def _widened_mask(mask: np.ndarray, shape: tuple[int, ...], margin: int) -> np.ndarray:
    """Flat ``mask`` widened to every entry of a cell within ``margin`` cells of a marked one.

    The cells are the entries of ``shape`` but its last axis (the components): a cell is marked
    if any of its entries is, the marked cells are dilated by a box of ``margin`` cells along
    each axis (ORed with their neighbours, not wrapped round the ends), and every entry of a
    marked cell is returned marked.
    """
    cells: np.ndarray = np.asarray(mask.reshape(shape).any(axis=-1))
    for axis in range(cells.ndim):
        for _ in range(margin):
            ahead = tuple(slice(1, None) if a == axis else slice(None) for a in range(cells.ndim))
            behind = tuple(slice(None, -1) if a == axis else slice(None)
                           for a in range(cells.ndim))
            shifted = cells[behind].copy()
            cells[behind] |= cells[ahead]
            cells[ahead] |= shifted
    return np.broadcast_to(cells[..., None], shape).reshape(-1)
