"""Von Mises equivalent stress of many stress tensors in one compiled pass.

The radial return checks every point of the cuboid box against the yield condition at every
sweep of the plastic fixed point; at 128 × 128 × 64 cuboids that is a million tensors, of which a
few per cent yield. Through numpy the check builds the deviator and its square as full-box
temporaries (three passes over 50 MB arrays); this loop reads each tensor once
(``docs/performance.md``). The same arithmetic as
``sqrt(3/2 s:s)``, ``s = σ − tr(σ)/3 I``, shear components counted twice
(:func:`sacflow.mechanics.plasticity.deviator`,
:func:`sacflow.mechanics.plasticity.double_contraction`).
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["equivalent_stress"]


@numba.njit(cache=True, nogil=True, boundscheck=False)
def equivalent_stress(stress: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    """Return ``q = sqrt(3/2 s:s)`` of each row of ``stress`` (n, 6), components 11 22 33 12 13 23.

    Parameters
    ----------
    stress : ndarray (n, 6)
        Stress tensors [Pa] (tensor shear components).

    Returns
    -------
    ndarray (n,)
        Von Mises equivalent stress [Pa].
    """
    n = stress.shape[0]
    out = np.empty(n)
    for k in range(n):
        mean = (stress[k, 0] + stress[k, 1] + stress[k, 2]) / 3.0
        s0 = stress[k, 0] - mean
        s1 = stress[k, 1] - mean
        s2 = stress[k, 2] - mean
        t3, t4, t5 = stress[k, 3], stress[k, 4], stress[k, 5]
        contraction = s0 * s0 + s1 * s1 + s2 * s2 + 2.0 * (t3 * t3 + t4 * t4 + t5 * t5)
        out[k] = np.sqrt(1.5 * contraction)
    return out
