"""The residual surface displacement of the cells' plastic strain at their sub-cells' centres.

The contact on sub-cells (:mod:`sacflow.solver.subcell_contact`) needs the body's residual
surface displacement at the centres of s × s sub-cells of each surface cell. The solver
interpolates it from the cells' centres by bicubic splines. This operator gives instead the
displacement of the cells' piecewise-uniform plastic strain itself at those points: Chiu's
cuboids integrated by the reciprocal theorem (:func:`~sacflow.kernels.residual_displacement.
cuboid_surface_displacement`; Chiu 1978, Jacq et al. 2002 eqs. 2.3–2.7) at the offsets of the
sub-cells from the cells' centres, one discrete convolution (DC-FFT) with s² outputs.

It is the reference the splines are measured against (``pipelines/press_pressure_profile.py``):
where the plastic strain reaches the surface, a strain uniform over each top-layer cuboid has a
surface displacement that bends at every cell face, so the two differ by what the cells put
into the displacement, not only by the splines' error.
"""

from __future__ import annotations

import numpy as np

from sacflow.kernels.convolution import Convolution
from sacflow.kernels.residual_displacement import cuboid_surface_displacement

__all__ = ["SubcellResidualDisplacement"]

#: Stress-like components of the plastic strain (11, 22, 33, 12, 13, 23).
COMPONENTS = 6


class SubcellResidualDisplacement:
    """u3 at the sub-cells' centres of a plastic strain uniform over each cuboid.

    Parameters
    ----------
    shape : (int, int, int)
        Cells of the body (n1, n2, nz).
    cell : (float, float)
        Lateral cell size (dx1, dx2) [m].
    layer_centres, layer_half_thickness : ndarray, shape (nz,)
        Depth of each layer's centre and its half thickness [m].
    nu : float
        Poisson's ratio.
    subcells : int
        Sub-cells per cell along each axis.
    threads : int, optional
        FFT threads.
    """

    def __init__(self, shape: tuple[int, int, int], cell: tuple[float, float],
                 layer_centres: np.ndarray, layer_half_thickness: np.ndarray, nu: float,
                 subcells: int, threads: int | None = None) -> None:
        n1, n2, nz = shape
        self.subcells = subcells
        dx1, dx2 = cell
        offsets = (np.arange(subcells) + 0.5) / subcells - 0.5
        c3 = np.asarray(layer_centres, dtype=float)[None, None, :]
        h3 = np.asarray(layer_half_thickness, dtype=float)[None, None, :]

        def coefficients(d1: np.ndarray, d2: np.ndarray) -> np.ndarray:
            out = np.empty((subcells * subcells, nz * COMPONENTS, d1.shape[0], d2.shape[1]))
            for a, o1 in enumerate(offsets):
                for b, o2 in enumerate(offsets):
                    k = cuboid_surface_displacement(
                        (d1 * dx1 + o1 * dx1)[:, :, None], (d2 * dx2 + o2 * dx2)[:, :, None],
                        c3, dx1 / 2, dx2 / 2, h3, nu)  # (N1, N2, nz, 6)
                    out[a * subcells + b] = np.moveaxis(k, (2, 3), (0, 1)).reshape(
                        nz * COMPONENTS, d1.shape[0], d2.shape[1])
            return out

        self.convolution = Convolution(coefficients, (n1, n2), (n1, n2), threads=threads)

    def __call__(self, plastic_strain: np.ndarray) -> np.ndarray:
        """Return u3 [m] at the sub-cells' centres, shape (n1 s, n2 s), of ``plastic_strain``.

        ``plastic_strain`` has shape (n1, n2, nz, 6), tensor components (11, 22, 33, 12, 13, 23).
        """
        n1, n2, nz, _ = plastic_strain.shape
        s = self.subcells
        channels = np.moveaxis(plastic_strain, (2, 3), (0, 1)).reshape(nz * COMPONENTS, n1, n2)
        per_offset = self.convolution(np.ascontiguousarray(channels))  # (s², n1, n2)
        fine: np.ndarray = per_offset.reshape(s, s, n1, n2).transpose(2, 0, 3, 1)
        return fine.reshape(n1 * s, n2 * s)
