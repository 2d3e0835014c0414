"""Papadopoulos' deviatoric 5-vector: stress deviators as points of R⁵ (for the fatigue criteria).

The multiaxial fatigue criteria (:mod:`sacflow.mechanics.fatigue_criteria`) measure the
amplitude of a non-proportional stress path by the minimum ball enclosing the path of the
deviator (:mod:`sacflow.mechanics.minimum_ball`). That ball is meaningful only in a space where
the Euclidean distance is the deviatoric norm ``√J2 = √(½ s:s)``: the deviator ``s`` is mapped
isometrically onto

``S = (√3/2 s11, (s22 − s33)/2, s12, s13, s23)``,  ``|S| = √J2``

(Papadopoulos et al. 1997, [Pa97]_). Stress components are stored along a last axis in the order
``11 22 33 12 13 23`` (tensor, not engineering, shears; Pa; tension positive).

References
----------
.. [Pa97] I. V. Papadopoulos, P. Davoli, C. Gorla, M. Filippini, A. Bernasconi, "A
   comparative study of multiaxial high-cycle fatigue criteria for metals", *Int. J.
   Fatigue* 19 (1997) 219–235.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "HALF_SQRT3",
    "N_COMPONENTS",
    "N_DEVIATORIC",
    "SQRT3",
    "as_stress_components",
    "deviator_from_vector",
    "deviatoric_vector",
]

#: Stress components per material point and time (order 11 22 33 12 13 23).
N_COMPONENTS = 6
#: Dimension of the deviatoric vector space (Papadopoulos' 5-vector).
N_DEVIATORIC = 5

#: √3, of the map's first component and of its inverse.
SQRT3 = math.sqrt(3.0)
#: √3/2, the factor of ``s11`` in the first component of the 5-vector.
HALF_SQRT3 = 0.5 * SQRT3


def as_stress_components(stress: ArrayLike) -> NDArray[np.float64]:
    """Float array with a last axis of the six stress components (``11 22 33 12 13 23``).

    Raises
    ------
    ValueError
        If the last axis does not have length 6.
    """
    sig = np.asarray(stress, dtype=float)
    if sig.shape[-1:] != (N_COMPONENTS,):
        raise ValueError(f"expected a last axis of {N_COMPONENTS} stress components "
                         f"(11 22 33 12 13 23), got shape {sig.shape}")
    return sig


def deviatoric_vector(stress: ArrayLike) -> NDArray[np.float64]:
    """Papadopoulos' deviatoric 5-vector of stress tensors [Pa97]_.

    Parameters
    ----------
    stress : array_like (..., 6)
        Components ``11 22 33 12 13 23`` (tensor shears).

    Returns
    -------
    ndarray (..., 5)
        ``S = (√3/2 s11, (s22 − s33)/2, s12, s13, s23)`` with ``s`` the deviator, so that
        ``|S| = √J2 = √(½ s:s)``: the map is an isometry from deviators (norm ``√(½ s:s)``)
        onto R⁵, which is what makes the minimum enclosing ball meaningful.
    """
    sig = as_stress_components(stress)
    out = np.empty((*sig.shape[:-1], N_DEVIATORIC))
    s11 = sig[..., 0] - (sig[..., 0] + sig[..., 1] + sig[..., 2]) / 3.0
    out[..., 0] = HALF_SQRT3 * s11
    out[..., 1] = 0.5 * (sig[..., 1] - sig[..., 2])
    out[..., 2:] = sig[..., 3:]
    return out


def deviator_from_vector(vector: ArrayLike) -> NDArray[np.float64]:
    """Inverse of :func:`deviatoric_vector`: the deviator's six components.

    Parameters
    ----------
    vector : array_like (..., 5)
        Deviatoric 5-vectors ``S``.

    Returns
    -------
    ndarray (..., 6)
        Traceless components ``11 22 33 12 13 23``:
        ``s11 = 2 S1/√3``, ``s22 = −S1/√3 + S2``, ``s33 = −S1/√3 − S2``.
    """
    v = np.asarray(vector, dtype=float)
    if v.shape[-1:] != (N_DEVIATORIC,):
        raise ValueError(f"expected a last axis of length {N_DEVIATORIC}, got shape {v.shape}")
    out = np.empty((*v.shape[:-1], N_COMPONENTS))
    third = v[..., 0] / SQRT3
    out[..., 0] = 2.0 * third
    out[..., 1] = -third + v[..., 1]
    out[..., 2] = -third - v[..., 1]
    out[..., 3:] = v[..., 2:]
    return out
