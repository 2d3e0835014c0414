"""The linear operators of a run, built once and reused every increment.

* the contact compliance on the contact window (Love's rectangles, DC-FFT:
  :class:`~sacflow.kernels.convolution.Convolution`);
* the pressure → stress convolution on the body grid (one operator serves every load position;
  with friction its kernel adds the shear traction's stress per unit pressure), its spectra
  kept in the kernel disk cache;
* for a plastic body, or one with elastic inhomogeneities, the eigenstrain operator (residual
  stress and residual surface displacement of the plastic strain and of the equivalent
  eigenstrain, :class:`~sacflow.kernels.eigenstrain.HalfSpaceEigenstrain`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from sacflow.kernels.convolution import Convolution
from sacflow.kernels.shear import subcell_load_stress_coefficients, surface_load_stress_coefficients
from sacflow.kernels.surface import rectangle_displacement
from sacflow.solver.layout import layer_centres

if TYPE_CHECKING:
    from sacflow.kernels.eigenstrain import HalfSpaceEigenstrain

__all__ = ["CONTACT_STRESS_VERSION", "Operators"]

#: Version of the pressure-to-stress kernels in the disk cache: bump it when their code changes.
CONTACT_STRESS_VERSION = 1
#: Tensor components of a stress field (one inverse transform of the pressure-stress
#: operator computes one depth layer's).
COMPONENTS = 6


class Operators:
    """Kernel spectra for the window and the cuboid box.

    Parameters
    ----------
    window : tuple of int
        Cells of the contact window.
    body_shape : tuple of int
        Cells of the body grid (n1, n2).
    cell : tuple of float
        Surface cell size [m].
    nz, dz : int, float
        Cuboid layers and their thickness [m].
    E, nu, e_star : float
        Young's modulus, Poisson's ratio of the body and the contact modulus [Pa].
    traction : tuple of float or None
        Shear traction per unit pressure (friction), or None.
    plastic : bool
        Whether the eigenstrain operator is needed: a plastic body, or one with elastic
        inhomogeneities (their equivalent eigenstrain); elastic homogeneous runs do without
        it, and without numba.
    threads : int or None
        FFT threads.
    stress_sampling : int
        Points per axis of a cell at which the stresses (contact and residual) are averaged:
        1 the centre value, more the cell mean (:mod:`sacflow.kernels.cell_average`).
    traction_quadrature : bool
        Whether the residual stress integrates the surface traction of the first layers'
        cuboids over each surface cell (:mod:`sacflow.kernels.traction_stencil`).
    traction_beyond_box : bool
        Whether it also removes the surface traction beyond the box's footprint
        (:mod:`sacflow.kernels.far_traction`).
    contact_subcells : int
        Sub-cells per surface cell along each axis of a contact solved on sub-cells
        (:mod:`sacflow.solver.subcell_contact`), 1 without: with more, the stress of the
        pressure's variation within each cell (:meth:`subcell_pressure_stress`).
    """

    def __init__(self, window: tuple[int, int], body_shape: tuple[int, int],
                 cell: tuple[float, float], nz: int, dz: float, E: float, nu: float,
                 e_star: float, traction: tuple[float, float] | None, plastic: bool,
                 threads: int | None, stress_sampling: int = 1,
                 traction_quadrature: bool = False, traction_beyond_box: bool = False,
                 contact_subcells: int = 1) -> None:
        self.body_shape = body_shape
        self.stress_sampling = stress_sampling
        self.cell = cell
        self.nz, self.dz, self.nu = nz, dz, nu
        self.traction = traction
        dx1, dx2 = cell
        h1, h2 = dx1 / 2, dx2 / 2

        def love(d1: np.ndarray, d2: np.ndarray) -> np.ndarray:
            unit: np.ndarray = rectangle_displacement(d1 * dx1, d2 * dx2, h1, h2)
            return (unit / (np.pi * e_star))[None, None]

        self.compliance = Convolution(love, window, window, threads=threads)
        z = layer_centres(nz, dz)
        stresses = surface_load_stress_coefficients(cell, z, nu, traction, stress_sampling, dz)
        # Pressure (embedded in the body grid at the window's place) -> stress on the body grid:
        # one operator serves every load position. With a shear traction q = μ p d its kernel
        # adds the traction's stress per unit pressure: the same one convolution.
        self.pressure_stress_op = Convolution(
            stresses, body_shape, body_shape, threads=threads,
            block=COMPONENTS,  # one depth layer (six components) per inverse transform
            cache=("contact_stress", self.contact_stress_parameters()),
        )
        self.subcells = contact_subcells
        self.subcell_stress_op: Convolution | None = None
        if contact_subcells > 1:
            # the sub-cells' pressures -> stress at the body cells: s² inputs, one transform each
            cache = ("contact_stress", {**self.contact_stress_parameters(),
                                        "contact_subcells": contact_subcells})
            if traction is None:  # the sub-cells' kernels mirror each other: keep ⌈s/2⌉²
                from sacflow.kernels.subcell_stress import MirroredSubcellStress  # numba

                self.subcell_stress_op = MirroredSubcellStress(
                    subcell_load_stress_coefficients(
                        cell, contact_subcells, z, nu, None, stress_sampling, dz,
                        only=MirroredSubcellStress.kept(contact_subcells)),
                    body_shape, contact_subcells, threads=threads, block=COMPONENTS,
                    cache=cache)
            else:  # a shear traction breaks the symmetry
                self.subcell_stress_op = Convolution(
                    subcell_load_stress_coefficients(cell, contact_subcells, z, nu, traction,
                                                     stress_sampling, dz),
                    body_shape, body_shape, threads=threads, block=COMPONENTS, cache=cache)
        self.eigen: HalfSpaceEigenstrain | None = None
        if plastic:
            from sacflow.kernels.eigenstrain import HalfSpaceEigenstrain

            self.eigen = HalfSpaceEigenstrain(
                (*body_shape, nz), (dx1, dx2, dz), E, nu, threads=threads,
                stress_sampling=stress_sampling, traction_quadrature=traction_quadrature,
                traction_beyond_box=traction_beyond_box,
            )

    def contact_stress_parameters(self) -> dict[str, Any]:
        """Everything the pressure-to-stress kernels depend on (their disk-cache key).

        Love's rectangles at the layer centres (cells, layer thickness, layers, ν) and, with
        friction, the traction per unit pressure; ``shape`` (body grid and layers) is what
        ``sacflow cache`` lists; the operator adds its own grid shapes. The stress sampling
        enters only when it is not the centre (the keys of the kernels already cached stay).
        """
        traction = self.traction
        sampling = {} if self.stress_sampling == 1 else {"stress_sampling": self.stress_sampling}
        return {
            "version": CONTACT_STRESS_VERSION, "shape": [*self.body_shape, int(self.nz)],
            "cell": [float(c) for c in self.cell],
            "dz": float(self.dz), "nz": int(self.nz), "nu": float(self.nu),
            "traction": None if traction is None else [float(t) for t in traction],
            **sampling,
        }

    @property
    def eigenstrain(self) -> HalfSpaceEigenstrain:
        """The eigenstrain operator (plastic bodies, or with inhomogeneities, only)."""
        if self.eigen is None:
            raise RuntimeError("an elastic body has no eigenstrain operator")
        return self.eigen

    def pressure_stress(self, pressure: np.ndarray, window: tuple[slice, slice],
                        subcell_pressure: np.ndarray | None = None) -> np.ndarray:
        """Stress [Pa] on the body grid, (n1, n2, nz, 6), of the window pressure at ``window``.

        With the contact on sub-cells, ``subcell_pressure`` (their pressure, whose cell means
        are ``pressure``) adds the stress of its variation within each cell
        (:meth:`subcell_pressure_stress`).
        """
        embedded = np.zeros(self.body_shape)
        embedded[window] = pressure
        return self.add_subcell_stress(self.body_pressure_stress(embedded), subcell_pressure,
                                       window)

    def add_subcell_stress(self, stress: np.ndarray, subcell_pressure: np.ndarray | None,
                           window: tuple[slice, slice], subtract: bool = False) -> np.ndarray:
        """Add (or ``subtract``) :meth:`subcell_pressure_stress` to ``stress`` in place, if any.

        Returns ``stress``; unchanged without a sub-cell pressure (a run on the cells).
        """
        if subcell_pressure is None:
            return stress
        correction = self.subcell_pressure_stress(subcell_pressure, window)
        if subtract:
            stress -= correction
        else:
            stress += correction
        return stress

    def body_pressure_stress(self, pressure: np.ndarray) -> np.ndarray:
        """Stress [Pa] (n1, n2, nz, 6) of a pressure given on the whole body grid."""
        out: np.ndarray = self.pressure_stress_op(pressure[None])  # (6 nz, n1, n2)
        out = out.reshape(self.nz, COMPONENTS, *self.body_shape)
        return np.moveaxis(out, (0, 1), (2, 3))

    def fused_stress(self, traction: np.ndarray, pressure: np.ndarray,
                     subcell_pressure: np.ndarray | None,
                     window: tuple[slice, slice]) -> np.ndarray:
        """Residual stress and contact stress in the eigenstrain operator's transforms [Pa].

        :meth:`HalfSpaceEigenstrain.stress` of the surface ``traction`` with the body-grid
        ``pressure``, plus the sub-cells' share (:meth:`add_subcell_stress`) if any.
        """
        return self.add_subcell_stress(self.eigenstrain.stress(traction, pressure),
                                       subcell_pressure, window)

    def without_pressure_stress(self, stress: np.ndarray, pressure: np.ndarray,
                                subcell_pressure: np.ndarray | None,
                                window: tuple[slice, slice]) -> np.ndarray:
        """``stress`` without the stress of the body-grid ``pressure`` (and its sub-cells')."""
        return self.add_subcell_stress(stress - self.body_pressure_stress(pressure),
                                       subcell_pressure, window, subtract=True)

    def subcell_pressure_stress(self, subcell_pressure: np.ndarray,
                                window: tuple[slice, slice]) -> np.ndarray:
        """Stress [Pa] (n1, n2, nz, 6) of the sub-cell pressure's variation within its cells.

        ``subcell_pressure`` (w1 s, w2 s) on the sub-cells of the window's cells at ``window``.
        Its cell means load the body through :meth:`pressure_stress`; this adds the stress of
        each sub-cell's deviation from its cell's mean (Love's rectangles of the sub-cells, the
        sum over a cell's sub-cells being the cell's own): together, the stress of the pressure
        as the contact solved it, not smeared over each cell.
        """
        op, s = self.subcell_stress_op, self.subcells
        if op is None:
            raise RuntimeError("the operators were built without contact sub-cells")
        w1, w2 = subcell_pressure.shape[0] // s, subcell_pressure.shape[1] // s
        fine = subcell_pressure.reshape(w1, s, w2, s)
        deviation = fine - fine.mean(axis=(1, 3), keepdims=True)
        embedded = np.zeros((s * s, *self.body_shape))
        embedded[(slice(None), *window)] = deviation.transpose(1, 3, 0, 2).reshape(s * s, w1, w2)
        out: np.ndarray = op(embedded).reshape(self.nz, COMPONENTS, *self.body_shape)
        return np.moveaxis(out, (0, 1), (2, 3))

    def residual_stress(self, plastic_strain: np.ndarray) -> np.ndarray:
        """Residual stress [Pa] (n1, n2, nz, 6) of the plastic strain."""
        stress: np.ndarray = self.eigenstrain.residual_stress(plastic_strain)
        return stress

    def residual_fields(self, plastic_strain: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Residual stress [Pa] and residual surface displacement [m] of the plastic strain.

        The two share one forward transform.
        """
        stress, displacement = self.eigenstrain.residual_stress(plastic_strain,
                                                                with_displacement=True)
        return stress, displacement
