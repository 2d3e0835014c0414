r"""The own hardening of inhomogeneities: a return mapping per phase, next to Eshelby's ε*.

An inhomogeneity Ω_k with its own hardening law (``[body.inhomogeneity.hardening]``) carries,
in its cells, its own plastic strain εp (in the body's plastic strain field, with its
equivalent plastic strain p and, with kinematic hardening, its backstress X) besides the
equivalent eigenstrain ε* of Eshelby's method (:mod:`sacflow.solver.inclusion`).

**The equivalence with plastic strain.** The homogeneous body (stiffness C, compliance S)
carrying the eigenstrain ``εp + ε*`` in Ω_k has, there, the total strain
``ε = S σ + εp + ε*`` (σ the total stress, which the residual-stress operators return inside
the eigenstrain's cells). The real inhomogeneity (compliance S_k) has ``ε = S_k σ_k + εp``. Both
have the same strain and stress (σ_k = σ) when

.. math::

    S\sigma + \varepsilon^p + \varepsilon^* = S_k\sigma + \varepsilon^p
    \iff \varepsilon^* = (S_k - S)\,\sigma ,

the equivalence of an elastic inhomogeneity (Mura, *Micromechanics of Defects in Solids*, 2nd
ed., Nijhoff 1987, §22): the plastic strain of the inhomogeneity is an eigenstrain of the
homogeneous body like the matrix's, and ε* still depends on the stress only.

**The return in the inhomogeneity's own stiffness.** Over an increment (εp_n, p_n, X_n before
it), the fixed point's iterate in Ω_k is ``x = Δεp + ε*`` (the increment of the eigenstrain the
operators see, ε* in full as for an elastic inhomogeneity). The elastic predictor of the real
material keeps the strain at the end of the increment and freezes the plastic strain:
``σ_tr = C_k (ε − εp_n) = C_k (S σ + x)`` — computed from ``x`` and σ without splitting
``x``; at the equivalence it is ``σ + C_k Δεp = σ + 2μ_k Δεp`` (Δεp deviatoric), the
matrix's predictor with the inhomogeneity's shear modulus μ_k. The return of that trial stress
with the inhomogeneity's law and μ_k (radial return or with the backstress,
:func:`~sacflow.mechanics.return_mapping.return_map`; step-doubled along the increment from
the converged stress σ_n when the settings ask for it,
:func:`~sacflow.mechanics.return_extrapolation.extrapolated_return`) gives Δεp, and
``ε* = x − Δεp``. Its equivalence residual ``C_k ε* − (I − C_k S) σ = σ_tr − 2μ_k Δεp − σ`` is
the real (returned) stress minus the homogeneous body's: the Krylov correction of
:meth:`~sacflow.solver.inclusion.EquivalentInclusion.update` drives it to zero, and the fixed
point's ``G(x) = Δεp + ε* + δ`` converges to both the return and the equivalence.

An inhomogeneity with the matrix's E and ν carries no ε*: its trial stress is the matrix's
``σ + 2μ x`` and only the law differs. The matrix's return runs over the whole box as without
inhomogeneities (their cells are then overwritten): a body without an inhomogeneity of its own
hardening runs no code of this module.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from sacflow.kernels.cuboid import stiffness_matrix
from sacflow.mechanics.hardening import HardeningLaw, KinematicLaw
from sacflow.mechanics.return_extrapolation import extrapolated_return
from sacflow.mechanics.return_mapping import ReturnResult, return_map
from sacflow.solver.inputs import Inhomogeneity

__all__ = ["OwnHardening", "PhaseLaw", "own_hardening"]

#: Indices (i1, i2, i3) of a set of cells of the body grid.
Cells = tuple[np.ndarray, np.ndarray, np.ndarray]


@dataclass(frozen=True)
class PhaseLaw:
    """The cells of one inhomogeneity with its own hardening, and how they return.

    ``stiffness`` C_k and ``trial_map`` C_k S (6, 6, tensor components) are None when the
    inhomogeneity has the matrix's E and ν (no ε*: the matrix's trial stress); ``depth`` is
    the depth of each cell [m] (depth-scaled laws).
    """

    cells: Cells
    law: HardeningLaw
    kinematic: KinematicLaw | None
    mu: float
    depth: np.ndarray
    stiffness: np.ndarray | None
    trial_map: np.ndarray | None


class OwnHardening:
    """The return mapping of the inhomogeneities with their own hardening (module docstring).

    Parameters
    ----------
    phases : sequence of PhaseLaw
        One per inhomogeneity with a hardening law of its own.
    """

    def __init__(self, phases: Sequence[PhaseLaw]) -> None:
        self.phases = tuple(phases)

    def apply(self, ret: ReturnResult, x: np.ndarray, stress: np.ndarray, trial: np.ndarray,
              state: tuple[np.ndarray, np.ndarray | None],
              start_stress: np.ndarray | None) -> None:
        """Return-map the inhomogeneities' cells with their laws, into ``ret`` (in place).

        ``x`` is the fixed point's iterate, ``stress`` the total stress it gives and ``trial``
        the matrix's trial stress ``σ + 2μ x`` (box fields); ``state`` the equivalent plastic
        strain and backstress before the increment; ``start_stress`` the converged stress σ_n
        when the return is step-doubled along the increment (None: one backward-Euler step).
        Writes Δεp, Δp, the plastic flags and (kinematic) the backstress of their cells.
        """
        equivalent, backstress = state
        for phase in self.phases:
            cells = phase.cells
            if phase.trial_map is None or phase.stiffness is None:
                trial_k = trial[cells]
            else:  # C_k (S σ + x): the real material's elastic predictor
                trial_k = (np.einsum("ij,mj->mi", phase.trial_map, stress[cells])
                           + np.einsum("ij,mj->mi", phase.stiffness, x[cells]))
            kinematic = phase.kinematic
            x_old = None if kinematic is None or backstress is None else backstress[cells]
            done = return_map(trial_k, equivalent[cells], phase.law, phase.mu, phase.depth,
                              kinematic=kinematic, backstress=x_old,
                              with_stress=kinematic is not None)
            if start_stress is not None:
                done = extrapolated_return(start_stress[cells], trial_k, equivalent[cells],
                                           phase.law, phase.mu, phase.depth,
                                           kinematic=kinematic, backstress=x_old, full=done)
            ret.plastic_strain_increment[cells] = done.plastic_strain_increment
            ret.equivalent_plastic_strain_increment[cells] = (
                done.equivalent_plastic_strain_increment)
            ret.plastic[cells] = done.plastic
            if ret.backstress is not None and done.backstress is not None:
                ret.backstress[cells] = done.backstress

    def yield_stress(self, equivalent: np.ndarray, out: np.ndarray) -> None:
        """Write the yield stress σ_Y(p) of the inhomogeneities' cells into ``out`` [Pa]."""
        for phase in self.phases:
            out[phase.cells] = phase.law.yield_stress(equivalent[phase.cells], phase.depth)


def own_hardening(phase: np.ndarray, inhomogeneities: Sequence[Inhomogeneity], E: float,
                  nu: float, depth: np.ndarray) -> OwnHardening | None:
    """Return the own hardening of the inhomogeneities that have one (None: none has).

    ``phase`` is the phase field (:func:`sacflow.solver.phase.phase_field`), ``E`` and ``nu``
    the matrix's elastic constants, ``depth`` the depths of the layers [m].
    """
    compliance = np.linalg.inv(stiffness_matrix(nu, E / (2.0 * (1.0 + nu))))
    phases = []
    for k, inh in enumerate(inhomogeneities, 1):
        if inh.law is None:
            continue
        cells: Cells = np.nonzero(phase == k)  # type: ignore[assignment]
        mu = inh.E / (2.0 * (1.0 + inh.nu))
        stiffness = trial_map = None
        if (inh.E, inh.nu) != (E, nu):
            stiffness = np.asarray(stiffness_matrix(inh.nu, mu))
            trial_map = stiffness @ compliance
        phases.append(PhaseLaw(cells, inh.law, inh.kinematic, mu, depth[cells[2]], stiffness,
                               trial_map))
    return OwnHardening(phases) if phases else None
