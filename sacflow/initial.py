"""Initial states of the body before any contact: depth profiles to arrays, and their checks.

A body may start with a residual stress ``σ11(x3), σ22(x3)`` (case hardening) and an
equivalent plastic strain ``p0(x3)`` (a work-hardened layer): :class:`sacflow.schema.
InitialResidualStress` and :class:`sacflow.schema.InitialHardening`. Both are piecewise linear
in depth, constant beyond their first and last points, and evaluated at the cuboid centres.
No I/O.
"""

from __future__ import annotations

import numpy as np

from sacflow.errors import SacflowError
from sacflow.plasticity import HardeningLaw, von_mises

__all__ = ["InitialYieldError", "check_initial_yield", "initial_eqps", "initial_stress"]

#: Relative slack of the initial yield check (the profile may sit on the yield surface).
_YIELD_SLACK = 1e-12


class InitialYieldError(SacflowError):
    """The initial residual stress exceeds the yield stress somewhere in the box."""


def _profile(depth, values, x3: np.ndarray) -> np.ndarray:
    """Linear interpolation in depth, constant beyond the ends (``np.interp``)."""
    return np.interp(x3, np.asarray(depth, dtype=float), np.asarray(values, dtype=float))


def initial_stress(profile, x3: np.ndarray) -> np.ndarray | None:
    """Return the initial residual stress at the layers ``x3``, shape (nz, 6), or None.

    Parameters
    ----------
    profile : InitialResidualStress or None
        ``depth``, ``s11``, ``s22`` (the schema model).
    x3 : ndarray
        Depths of the cuboid centres [m].
    """
    if profile is None:
        return None
    out = np.zeros((np.size(x3), 6))
    out[:, 0] = _profile(profile.depth, profile.s11, x3)
    out[:, 1] = _profile(profile.depth, profile.s22, x3)
    return out


def initial_eqps(profile, x3: np.ndarray) -> np.ndarray:
    """Return the initial equivalent plastic strain at the layers ``x3`` (zeros if no profile)."""
    if profile is None:
        return np.zeros(np.size(x3))
    return _profile(profile.depth, profile.equivalent_plastic_strain, x3)


def check_initial_yield(law: HardeningLaw, stress: np.ndarray, eqps: np.ndarray,
                        x3: np.ndarray) -> None:
    """Refuse an initial residual stress above the initial yield stress of its layer.

    Raises
    ------
    InitialYieldError
        Naming the depth, the von Mises stress of the profile and the yield stress there.
    """
    q = von_mises(stress)
    yield_stress = np.asarray(law.yield_stress(eqps, x3), dtype=float)
    over = np.flatnonzero(q > yield_stress * (1.0 + _YIELD_SLACK))
    if over.size:
        k = int(over[0])
        raise InitialYieldError(
            f"body.initial_residual_stress: at depth {x3[k] * 1e6:.4g} µm its von Mises stress "
            f"{q[k] * 1e-6:.4g} MPa exceeds the yield stress {yield_stress[k] * 1e-6:.4g} MPa "
            "(with body.initial_hardening); a residual stress cannot exceed it: lower the "
            "profile or raise the initial hardening"
        )
