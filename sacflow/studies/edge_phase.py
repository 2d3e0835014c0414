"""How much of a quantity's zigzag over a scan of cell counts follows a contact edge's phase.

The contact pressure is one value per surface cell, so a quantity computed at N cells per side
carries, beside a smooth error of the cell size, an error that depends on where the contact's
edge falls within its cell: its phase φ = a / Δx less the nearest whole number, in [−½, ½].
Over a scan of nearby counts the smooth error is close to linear in N, and the edge's part is
a periodic function of φ. The least-squares model

    f(N) = c₀ + c₁ N + c₂ cos 2πφ(N) + c₃ sin 2πφ(N)

then separates the two: the *residual* (the root mean square of f less the model) is what the
phase leaves unexplained, against the *spread* about the line c₀ + c₁ N alone. Which radius a
sets φ is the question: Hertz's, or the contact's own, which a plastic body widens.

The functions take arrays; ``pipelines/contact_edge_phase.py`` reads the scans of
``pipelines/contact_edge_scan.py``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from sacflow.studies.richardson import NEGLIGIBLE_CHANGE

__all__ = ["MIN_COUNTS", "PhaseFit", "phase_fit"]

#: Fewest counts the four-coefficient model is fitted to with a residual left to judge by.
MIN_COUNTS = 6


@dataclass(frozen=True)
class PhaseFit:
    """The least-squares fit of the module docstring's model.

    Attributes
    ----------
    slope : float
        c₁, the smooth change per cell count.
    amplitude : float
        (c₂² + c₃²)^½, the size of the phase's part.
    peak_phase : float
        The phase at which that part is largest, in [−½, ½).
    spread : float
        Root mean square of f about its least-squares line in N alone (0 when below the
        round-off of f, :data:`sacflow.studies.richardson.NEGLIGIBLE_CHANGE` of its size).
    residual : float
        Root mean square of f less the whole model.
    """

    slope: float
    amplitude: float
    peak_phase: float
    spread: float
    residual: float

    @property
    def explained(self) -> float:
        """The share of the spread about the line that the phase explains.

        1 − (residual / spread)², the coefficient of determination of the phase's part.
        """
        return 1.0 - (self.residual / self.spread) ** 2 if self.spread > 0.0 else 0.0


def phase_fit(counts: ArrayLike, values: ArrayLike, phases: ArrayLike) -> PhaseFit:
    """Fit a line in the cell count plus one period of the edge's phase (module docstring).

    Parameters
    ----------
    counts, values, phases : array_like
        Per scanned count: the cells per side N, the quantity f and the edge's phase φ(N).

    Returns
    -------
    PhaseFit

    Raises
    ------
    ValueError
        With arrays of different lengths, fewer than :data:`MIN_COUNTS` counts, or a phase
        outside [−½, ½].
    """
    n = np.asarray(counts, dtype=float)
    f = np.asarray(values, dtype=float)
    phi = np.asarray(phases, dtype=float)
    if not n.shape == f.shape == phi.shape or n.ndim != 1:
        raise ValueError("counts, values and phases must be three arrays of one length")
    if n.size < MIN_COUNTS:
        raise ValueError(f"a phase fit needs {MIN_COUNTS} counts or more, got {n.size}")
    if np.any(np.abs(phi) > 0.5):
        raise ValueError("a phase lies in [-1/2, 1/2]: a radius in cells less its nearest "
                         "whole number")
    line = np.column_stack([np.ones_like(n), n])
    angle = 2.0 * np.pi * phi
    model = np.column_stack([line, np.cos(angle), np.sin(angle)])
    coefficients = np.linalg.lstsq(model, f, rcond=None)[0]
    straight = np.linalg.lstsq(line, f, rcond=None)[0]
    cos_part, sin_part = coefficients[2], coefficients[3]
    peak = float(np.arctan2(sin_part, cos_part) / (2.0 * np.pi))
    spread = float(np.sqrt(np.mean((f - line @ straight) ** 2)))
    if spread <= NEGLIGIBLE_CHANGE * float(np.max(np.abs(f))):
        spread = 0.0
    return PhaseFit(slope=float(coefficients[1]), amplitude=float(np.hypot(cos_part, sin_part)),
                    peak_phase=peak if peak < 0.5 else peak - 1.0, spread=spread,
                    residual=float(np.sqrt(np.mean((f - model @ coefficients) ** 2))))
