"""Anderson mixing for fixed points x = G(x).

Type II Anderson acceleration: Walker & Ni, SIAM J. Numer. Anal. 49 (2011) 1715,
doi:10.1137/10078356X.

Used by the solver to accelerate the plastic-strain fixed point of seed §1.7 (Figs. 4–5), which
plain (Picard) iteration solves in hundreds of sweeps (seed §2.5).
"""

from __future__ import annotations

from collections import deque

import numpy as np

__all__ = ["AndersonMixer"]


class AndersonMixer:
    """Stateful Anderson accelerator: feed ``(x, G(x))``, get the next iterate.

    Parameters
    ----------
    depth : int
        Number of previous residual differences kept (``0`` = plain Picard iteration).
    mixing : float
        Relaxation β in ``x⁺ = x + β f − (ΔX + β ΔF) γ``.
    """

    def __init__(self, depth: int = 5, mixing: float = 1.0):
        self.depth = depth
        self.mixing = mixing
        self._dx: deque[np.ndarray] = deque(maxlen=max(depth, 1))
        self._df: deque[np.ndarray] = deque(maxlen=max(depth, 1))
        self._gram = np.zeros((0, 0))  # ΔF^T ΔF, updated one column at a time
        self._last_x: np.ndarray | None = None
        self._last_f: np.ndarray | None = None

    def reset(self) -> None:
        """Forget the history (e.g. after the problem changed)."""
        self._dx.clear()
        self._df.clear()
        self._gram = np.zeros((0, 0))
        self._last_x = self._last_f = None

    def _append(self, dx: np.ndarray, df: np.ndarray) -> None:
        """Add a difference pair; keep the Gram matrix of the ΔF columns in step (O(m n))."""
        gram = self._gram
        if len(self._df) == self._df.maxlen:
            gram = gram[1:, 1:]
        self._dx.append(dx)
        self._df.append(df)
        row = np.array([float(col @ df) for col in self._df])
        m = len(row)
        new = np.empty((m, m))
        new[: m - 1, : m - 1] = gram
        new[m - 1, :] = row
        new[:, m - 1] = row
        self._gram = new

    def step(self, x: np.ndarray, gx: np.ndarray) -> np.ndarray:
        """Return the next iterate from the current ``x`` and ``G(x)`` (flat arrays).

        The least-squares problem ``min_γ ‖f − ΔF γ‖`` is solved through its normal equations
        with the cached Gram matrix ``ΔF^T ΔF`` (a pseudo-inverse drops directions below 1e-13 of
        the largest): each step costs O(m n) for ``m`` stored differences of length ``n``
        instead of the O(m² n) of a QR factorisation of ``ΔF``.
        """
        f = gx - x
        if self.depth == 0:
            return x + self.mixing * f
        if self._last_x is not None:
            self._append(x - self._last_x, f - self._last_f)
        self._last_x, self._last_f = x.copy(), f.copy()
        if not self._df:
            return x + self.mixing * f
        rhs = np.array([float(col @ f) for col in self._df])
        gamma = np.linalg.pinv(self._gram, rcond=1e-13, hermitian=True) @ rhs
        out = x + self.mixing * f
        for g, dx, df in zip(gamma, self._dx, self._df, strict=True):
            out -= g * (dx + self.mixing * df)
        return out
