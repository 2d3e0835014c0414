r"""Stress and strain measures of (..., 6) symmetric tensors: deviator, a:b, von Mises.

Conventions
-----------
* Tensor components on a last axis of size 6 in the order (11, 22, 33, 12, 13, 23), *tensor*
  shear components (ε12, not γ12). In double contractions the shear components therefore count
  twice: ``a:b = a11 b11 + a22 b22 + a33 b33 + 2 (a12 b12 + a13 b13 + a23 b23)``.
* Von Mises equivalent stress q = sqrt(3/2 s:s), s = σ − tr(σ)/3 I the deviator (Hill, *The
  Mathematical Theory of Plasticity*, OUP 1950, ch. II; Johnson, *Contact Mechanics*, CUP 1985,
  eq. 6.3 for the component form used by :func:`von_mises`).
* Equivalent strain sqrt(2/3 e:e), e the deviator: for a plastic strain increment it is the
  increment of the accumulated equivalent plastic strain p = ∫ sqrt(2/3 dεp:dεp).

:func:`equivalent_stress` is the compiled one-pass form of the yield check over the cuboid box:
at 128 × 128 × 64 cuboids a million tensors, of which a few per cent yield; through numpy the
check builds the deviator and its square as full-box temporaries, the loop reads each tensor
once (``docs/performance.md``). numba is imported at its first call: elastic runs do without it.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sacflow.kernels.cuboid import SHEAR_WEIGHTS

__all__ = ["COMPONENTS", "deviator", "deviatoric_equivalent", "double_contraction",
           "equivalent_strain", "equivalent_stress", "squared_von_mises_and_gradient",
           "von_mises"]

#: Labels of the six tensor components, in the order of the last axis.
COMPONENTS: tuple[str, ...] = ("11", "22", "33", "12", "13", "23")


def double_contraction(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """Return ``a:b`` of two (..., 6) symmetric tensors, shear components counted twice."""
    out: NDArray[np.float64] = np.einsum("...i,...i,i->...", np.asarray(a, float),
                                         np.asarray(b, float), SHEAR_WEIGHTS)
    return out


def deviator(stress: ArrayLike) -> NDArray[np.float64]:
    """Return the deviatoric part ``s = σ − tr(σ)/3 I`` of (..., 6) tensors (a new array)."""
    s = np.array(stress, dtype=float)
    s[..., :3] -= ((s[..., 0] + s[..., 1] + s[..., 2]) / 3.0)[..., None]
    return s


def deviatoric_equivalent(deviatoric: ArrayLike) -> NDArray[np.float64]:
    """Return ``sqrt(3/2 t:t)`` of (..., 6) tensors that are deviatoric already.

    The von Mises measure of a deviator (s − X in kinematic hardening, the flow direction's
    argument): no trace is removed.
    """
    t = np.asarray(deviatoric, dtype=float)
    out: NDArray[np.float64] = np.sqrt(1.5 * double_contraction(t, t))
    return out


def equivalent_strain(strain: ArrayLike) -> NDArray[np.float64]:
    """Return sqrt(2/3 e:e) with e the deviator of (..., 6) tensor strains (= Δp for Δεp)."""
    e = deviator(strain)
    out: NDArray[np.float64] = np.sqrt(2.0 / 3.0 * double_contraction(e, e))
    return out


def von_mises(stress: ArrayLike) -> NDArray[np.float64]:
    r"""Von Mises equivalent stress of (..., 6) arrays in the order (11, 22, 33, 12, 13, 23).

    .. math:: \sigma_{vM} = \sqrt{\tfrac12\left[(\sigma_{11}-\sigma_{22})^2
        + (\sigma_{22}-\sigma_{33})^2 + (\sigma_{33}-\sigma_{11})^2\right]
        + 3(\sigma_{12}^2 + \sigma_{13}^2 + \sigma_{23}^2)}

    equal to sqrt(3/2 s:s) (module docstring) to rounding.

    Parameters
    ----------
    stress : array_like, shape (..., 6)
        Stress tensors (tensor shear components, not engineering ones).

    Returns
    -------
    ndarray
        Equivalent stress, shape (...).
    """
    s = np.asarray(stress, dtype=np.float64)
    if s.shape[-1:] != (6,):
        raise ValueError(f"stress must have a last axis of size 6, got shape {s.shape}")
    d = (s[..., 0] - s[..., 1]) ** 2 + (s[..., 1] - s[..., 2]) ** 2 + (s[..., 2] - s[..., 0]) ** 2
    shear = s[..., 3] ** 2 + s[..., 4] ** 2 + s[..., 5] ** 2
    out: NDArray[np.float64] = np.sqrt(0.5 * d + 3.0 * shear)
    return out


def squared_von_mises_and_gradient(
    stress: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Return σ_vM² of (..., 6) stresses (the form of :func:`von_mises`) and its gradient.

    The gradient is with respect to the six components (11, 22, 33, 12, 13, 23), the shear
    ones counted once: what an optimiser over stress components needs (Melan's theorem,
    :mod:`sacflow.mechanics.shakedown`).
    """
    a, b, c, d, e, f = (stress[..., i] for i in range(6))
    q = 0.5 * ((a - b) ** 2 + (b - c) ** 2 + (c - a) ** 2) + 3.0 * (d * d + e * e + f * f)
    grad = np.stack([2 * a - b - c, 2 * b - c - a, 2 * c - a - b, 6 * d, 6 * e, 6 * f], axis=-1)
    return q, grad


def equivalent_stress(stress: NDArray[np.float64]) -> NDArray[np.float64]:
    """Return ``q = sqrt(3/2 s:s)`` of each row of ``stress`` (n, 6) in one compiled pass.

    The same arithmetic as ``deviatoric_equivalent(deviator(stress))`` (module docstring),
    without the full-size temporaries.

    Parameters
    ----------
    stress : ndarray (n, 6), C-contiguous
        Stress tensors [Pa] (tensor shear components).

    Returns
    -------
    ndarray (n,)
        Von Mises equivalent stress [Pa].
    """
    out: NDArray[np.float64] = compiled_equivalent_stress()(stress)
    return out


@cache
def compiled_equivalent_stress() -> Callable[[NDArray[np.float64]], NDArray[np.float64]]:
    """Return the numba-compiled row loop of :func:`equivalent_stress` (compiled once, cached)."""
    import numba  # plastic runs only

    compiled: Callable[[NDArray[np.float64]], NDArray[np.float64]] = numba.njit(
        cache=True, nogil=True, boundscheck=False)(equivalent_stress_rows)
    return compiled


def equivalent_stress_rows(stress: NDArray[np.float64]) -> NDArray[np.float64]:
    """Row loop of :func:`equivalent_stress` (plain Python; compiled by numba on first use)."""
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
