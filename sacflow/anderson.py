"""Anderson mixing for fixed points x = G(x) (type II, Walker & Ni, SIAM J. Numer. Anal. 49
(2011) 1715, doi:10.1137/10078356X).

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
        self._last_x: np.ndarray | None = None
        self._last_f: np.ndarray | None = None

    def reset(self) -> None:
        """Forget the history (e.g. after the problem changed)."""
        self._dx.clear()
        self._df.clear()
        self._last_x = self._last_f = None

    def step(self, x: np.ndarray, gx: np.ndarray) -> np.ndarray:
        """Return the next iterate from the current ``x`` and ``G(x)`` (flat arrays)."""
        f = gx - x
        if self.depth == 0:
            return x + self.mixing * f
        if self._last_x is not None:
            self._dx.append(x - self._last_x)
            self._df.append(f - self._last_f)
        self._last_x, self._last_f = x.copy(), f.copy()
        if not self._df:
            return x + self.mixing * f
        dF = np.stack(self._df, axis=1)
        dX = np.stack(self._dx, axis=1)
        gamma, *_ = np.linalg.lstsq(dF, f, rcond=1e-12)
        return x + self.mixing * f - (dX + self.mixing * dF) @ gamma
