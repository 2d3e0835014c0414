r"""Eshelby's equivalent inclusion method on the half-space eigenstrain operator.

An elastic inhomogeneity Ω_k (stiffness C_k) in the matrix (stiffness C, compliance S) is
replaced by the homogeneous body carrying an equivalent eigenstrain ε* in Ω_k such that both
have the same stress (Mura, *Micromechanics of Defects in Solids*, 2nd ed., Nijhoff 1987, §22;
the semi-analytical form on cuboids: Zhou, Keer & Wang, Int. J. Numer. Meth. Engng 79 (2009)
1009; Leroux, Fulleringer & Nélias, Int. J. Solids Struct. 47 (2010) 2243). With the total
stress ``σ = σ_a + R[εp + ε*]`` (``σ_a`` the contact pressure's and the initial stress, ``R``
the residual-stress operator, which returns ``C (ε_compatible − ε_eigen)``, the total stress,
inside the eigenstrain's cells), the strain in Ω is ``ε = S σ + ε*`` and Hooke's law of the
inhomogeneity ``σ = C_k ε`` is

.. math::

    F(\varepsilon^*) = C_k\,\varepsilon^* - (I - C_k S)\,\sigma = 0,

i.e. ``ε* = (S_k − S) σ`` multiplied by ``−C_k`` (Mura's equivalence condition). This form stays
bounded for a cavity (``C_k → 0``: ``σ = 0`` in Ω) and, divided by ``max(1, E_k/E)``, for a rigid
inhomogeneity; its operator ``C_k − (I − C_k S) R_ΩΩ ≈ C (I − S^E) + C_k S^E`` (``S^E`` the
Eshelby tensor) is well conditioned for every modulus ratio, where ``ε* − ΔS σ`` is not as
``E_k → 0``.

The solver's fixed point carries ε* in the inhomogeneous cells of its iterate (where the
plastic strain increment is zero when the inhomogeneity is elastic; with a hardening law of its
own the iterate there is ``Δεp + ε*``, :mod:`sacflow.solver.own_hardening`). Each evaluation
gives the
total stress with the full operator; :meth:`EquivalentInclusion.update` then returns the
Newton-like correction ``ε* + δ`` with ``(C_k − (I − C_k S) R_s) δ = −F(ε*)``, ``R_s`` the
eigenstrain operator on a sub-box around the inhomogeneities (lateral bounding box plus
:data:`SUB_BOX_MARGIN` cells, layers from the surface down to the lowest inhomogeneous cell),
solved by GMRES. The sub-box operator is exact for the infinite-space and image parts of ``R``
(zero-padded convolutions) and truncates the surface traction correction to its footprint: the
defect ``R − R_s`` is small and the outer fixed point (Anderson mixing) removes it, so at
convergence ``F = 0`` with the full operator.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from sacflow.errors import ConvergenceError
from sacflow.kernels.cuboid import stiffness_matrix
from sacflow.kernels.eigenstrain import HalfSpaceEigenstrain
from sacflow.solver.inputs import Inhomogeneity, SolverInputs, SolverSettings
from sacflow.solver.own_hardening import OwnHardening, own_hardening
from sacflow.solver.phase import phase_field
from sacflow.solver.state import GridCoords

__all__ = ["SUB_BOX_MARGIN", "EquivalentInclusion", "inclusion_for", "isotropic_stiffness"]

#: Cells added on each lateral side of the inhomogeneities' bounding box for the sub-box
#: operator of the inner Krylov solves (the surface traction of the eigenstrain spreads beyond).
SUB_BOX_MARGIN = 4
#: Components of a symmetric tensor (11, 22, 33, 12, 13, 23).
COMPONENTS = 6


def isotropic_stiffness(E: float, nu: float) -> np.ndarray:
    """Isotropic stiffness (6, 6) on tensor components (tensor shears), as the kernels'."""
    stiffness: np.ndarray = stiffness_matrix(nu, E / (2.0 * (1.0 + nu)))
    return stiffness


class EquivalentInclusion:
    """The equivalent eigenstrain of a body's elastic inhomogeneities (module docstring).

    Parameters
    ----------
    phase : ndarray of int8, shape (n1, n2, nz)
        Phase of each cell (:func:`sacflow.solver.phase.phase_field`).
    inhomogeneities : sequence of Inhomogeneity
        The regions' moduli, phase k the k-th.
    E, nu : float
        The matrix's Young's modulus [Pa] and Poisson's ratio.
    spacing : (float, float, float)
        Cuboid size [m].
    settings : SolverSettings
        ``inclusion_tolerance`` (relative GMRES residual) and ``inclusion_max_iterations``.
    threads : int or None
        FFT threads of the sub-box operator.
    own : OwnHardening or None
        The return of the inhomogeneities with a hardening law of their own (None: all
        elastic).

    Attributes
    ----------
    elastic : ndarray of bool (n1, n2, nz)
        The cells of every inhomogeneity: no plastic flow of the matrix's law there (those of
        an inhomogeneity with its own hardening return with it, :attr:`own`).
    cells : tuple of ndarray
        Indices of the cells carrying an equivalent eigenstrain: those of the inhomogeneities
        whose moduli differ from the matrix's (one with the matrix's is the matrix: ε* = 0).
    iterations : int
        GMRES iterations since the counter was last reset (the caller resets it per step).
    """

    def __init__(self, phase: np.ndarray, inhomogeneities: Sequence[Inhomogeneity], E: float,
                 nu: float, spacing: tuple[float, float, float], settings: SolverSettings,
                 threads: int | None, own: OwnHardening | None = None) -> None:
        self.phase = phase
        self.own = own
        self.elastic = phase > 0
        self.settings = settings
        self.iterations = 0
        compliance = np.linalg.inv(isotropic_stiffness(E, nu))
        differs = [k for k, inh in enumerate(inhomogeneities, 1) if (inh.E, inh.nu) != (E, nu)]
        self.cells = np.nonzero(np.isin(phase, differs))
        of_cell = phase[self.cells]
        stiff = np.zeros((len(inhomogeneities) + 1, COMPONENTS, COMPONENTS))
        coupling = np.zeros_like(stiff)
        for k, inh in enumerate(inhomogeneities, 1):
            scale = 1.0 / max(1.0, inh.E / E)  # a rigid limit stays bounded
            stiff[k] = scale * isotropic_stiffness(inh.E, inh.nu)
            coupling[k] = scale * np.eye(COMPONENTS) - stiff[k] @ compliance
        self.stiffness, self.coupling = stiff[of_cell], coupling[of_cell]  # (m, 6, 6)
        self.sub: HalfSpaceEigenstrain | None = None
        self.local: tuple[np.ndarray, ...] = ()
        if self.active:
            lo = [max(int(c.min()) - SUB_BOX_MARGIN, 0) for c in self.cells[:2]]
            hi = [min(int(c.max()) + SUB_BOX_MARGIN + 1, n)
                  for c, n in zip(self.cells[:2], phase.shape[:2], strict=True)]
            shape = (hi[0] - lo[0], hi[1] - lo[1], int(self.cells[2].max()) + 1)
            self.sub = HalfSpaceEigenstrain(
                shape, spacing, E, nu, threads=threads, stress_sampling=settings.stress_sampling,
                traction_quadrature=settings.surface_correction == "quadrature")
            self.local = (self.cells[0] - lo[0], self.cells[1] - lo[1], self.cells[2])
            self.sub_shape = (*shape, COMPONENTS)

    @property
    def active(self) -> bool:
        """Whether any cell carries an equivalent eigenstrain (an inhomogeneity differs)."""
        return bool(self.cells[0].size)

    @property
    def size(self) -> int:
        """Cells carrying an equivalent eigenstrain."""
        return int(self.cells[0].size)

    def embed(self, cells: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """Return the body field (n1, n2, nz, 6) of the cells' values (m, 6), zero elsewhere."""
        if out is None:
            out = np.zeros((*self.phase.shape, COMPONENTS))
        out[self.cells] = cells
        return out

    def total(self, plastic_strain: np.ndarray, eps: np.ndarray | None) -> np.ndarray:
        """Return the eigenstrain ``εp + ε*`` of the body (``εp`` itself when ``eps`` is None)."""
        if eps is None:
            return plastic_strain
        total = plastic_strain.copy()
        total[self.cells] += eps
        return total

    def restored(self, stored: np.ndarray | None) -> np.ndarray:
        """Return ε* of the cells (m, 6) from a stored body field (zero when none is stored)."""
        if stored is None:
            return np.zeros((self.size, COMPONENTS))
        field = np.asarray(stored, dtype=float).reshape(*self.phase.shape, COMPONENTS)
        cells: np.ndarray = field[self.cells].copy()
        return cells

    def residual(self, eps: np.ndarray, stress: np.ndarray) -> np.ndarray:
        """``F = C_k ε* − (I − C_k S) σ`` (scaled) on the cells, (m, 6) [Pa]."""
        out: np.ndarray = (np.einsum("mij,mj->mi", self.stiffness, eps)
                           - np.einsum("mij,mj->mi", self.coupling, stress))
        return out

    def update(self, eps: np.ndarray, stress: np.ndarray, step: int) -> np.ndarray:
        """Return the corrected equivalent eigenstrain ``ε* + δ`` (m, 6) for the stress ``σ``.

        ``eps`` is the current ε* of the cells and ``stress`` the total stress there [Pa] (with
        the full operator); δ solves ``(C_k − (I − C_k S) R_s) δ = −F(ε*, σ)`` by GMRES to
        ``inclusion_tolerance`` times the size of the terms of ``F`` (the two sides of Hooke's
        law of the inhomogeneity), which makes a converged ε* need no iteration.

        Raises
        ------
        ConvergenceError
            ``"inclusion"``, when GMRES does not reach the tolerance within
            ``inclusion_max_iterations``.
        """
        from scipy.sparse.linalg import LinearOperator, gmres

        sub = self.sub
        assert sub is not None
        n = eps.size
        stiff_term = np.einsum("mij,mj->mi", self.stiffness, eps)
        stress_term = np.einsum("mij,mj->mi", self.coupling, stress)
        rhs = (stress_term - stiff_term).ravel()
        reference = max(float(np.linalg.norm(stiff_term)), float(np.linalg.norm(stress_term)))
        opts = self.settings
        target = opts.inclusion_tolerance * reference
        if float(np.linalg.norm(rhs)) <= target:
            return eps
        field = np.zeros(self.sub_shape)

        def matvec(v: np.ndarray) -> np.ndarray:
            delta = v.reshape(eps.shape)
            field[self.local] = delta
            response = sub.residual_stress(field)[self.local]
            product: np.ndarray = (np.einsum("mij,mj->mi", self.stiffness, delta)
                                   - np.einsum("mij,mj->mi", self.coupling, response)).ravel()
            return product

        count = 0

        def counted(_: float) -> None:
            nonlocal count
            count += 1

        operator = LinearOperator((n, n), matvec=matvec, dtype=float)
        delta, info = gmres(operator, rhs, rtol=0.0, atol=target,
                            restart=opts.inclusion_max_iterations, maxiter=1,
                            callback=counted, callback_type="pr_norm")
        self.iterations += count
        if info != 0:
            residual = float(np.linalg.norm(rhs - matvec(delta))) / max(reference, np.finfo(
                float).tiny)
            raise ConvergenceError("inclusion", step=step, residual=residual,
                                   tolerance=opts.inclusion_tolerance, iterations=count)
        updated: np.ndarray = eps + delta.reshape(eps.shape)
        return updated


def inclusion_for(inputs: SolverInputs, coords: GridCoords) -> EquivalentInclusion | None:
    """Return the equivalent inclusion of the inputs' inhomogeneities on ``coords``, or None.

    Raises
    ------
    ValueError
        When an inhomogeneity has a hardening law of its own in an elastic body (whose run
        keeps no plastic state: the case schema refuses it too).
    """
    if not inputs.inhomogeneities:
        return None
    phase = phase_field(inputs.inhomogeneities, coords.x1, coords.x2, coords.x3)
    material, settings = inputs.material, inputs.settings
    dz = inputs.grid.depth / inputs.grid.nz
    own = own_hardening(phase, inputs.inhomogeneities, material.E, material.nu, coords.x3)
    if own is not None and not material.plastic:
        raise ValueError("an inhomogeneity's own hardening needs a plastic body (an elastic "
                         "body keeps no plastic state): give the body a plastic law")
    return EquivalentInclusion(phase, inputs.inhomogeneities, material.E, material.nu,
                               (*inputs.grid.cell, dz), settings, settings.fft_threads, own)
