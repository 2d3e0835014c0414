"""Where the load is on the body grid, and the initial gap there.

The curvature term of the gap moves with the load, dents and measured surfaces stay with the
body (seed §1.6, Fig. 3). Load positions are exact (a roll step may be a fraction of a cell):
the gap is evaluated at the exact position, only the contact window is placed on the nearest
whole cell of the body grid.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from sacflow.errors import SacflowError
from sacflow.mechanics.surface_gap import curvature_gap, features_gap
from sacflow.solver.inputs import ContactSpec
from sacflow.solver.state import GridCoords, MeasuredSurface

__all__ = ["LoadGeometry", "measured_heights"]

#: A surface height function ``heights(x1, x2) -> ndarray`` [m].
Heights = Callable[[np.ndarray, np.ndarray], np.ndarray]


class LoadGeometry:
    """The contact window and the initial gap of a load position on the body-fixed grid.

    Parameters
    ----------
    contact : ContactSpec
        Effective radii, dents and measured surface.
    coords : GridCoords
        Cell centres of the body grid.
    cell : tuple of float
        Surface cell size [m].
    window : tuple of int
        Cells of the contact window.
    origin : tuple of int
        Body index of the window's first cell when the load is at 0.
    """

    def __init__(self, contact: ContactSpec, coords: GridCoords, cell: tuple[float, float],
                 window: tuple[int, int], origin: tuple[int, int]) -> None:
        self.radii = contact.radii
        self.dents = contact.dents
        self.heights = measured_heights(contact.surface)
        self.coords = coords
        self.cell = cell
        self.window = window
        self.origin_cells = np.array(origin)

    def window_slices(self, position: tuple[float, float]) -> tuple[slice, slice]:
        """Slices of the body grid covered by the contact window centred on ``position``."""
        c = np.rint(np.array(position) / np.array(self.cell)).astype(int) + self.origin_cells
        return (slice(int(c[0]), int(c[0]) + self.window[0]),
                slice(int(c[1]), int(c[1]) + self.window[1]))

    def initial_gap(self, position: tuple[float, float], x1: np.ndarray,
                    x2: np.ndarray) -> np.ndarray:
        """Return the initial gap at body-frame points: curvature about the load, features."""
        h = curvature_gap(x1, x2, position[0], position[1], self.radii)
        gap: np.ndarray = h + features_gap(x1, x2, self.dents, self.heights)
        return gap

    def window_gap(self, position: tuple[float, float],
                   window: tuple[slice, slice]) -> np.ndarray:
        """Return the initial gap on the contact window ``window``."""
        return self.initial_gap(
            position, self.coords.x1[window[0]][:, None], self.coords.x2[window[1]][None, :]
        )


def measured_heights(surface: MeasuredSurface | None) -> Heights | None:
    """Height function of a measured surface (linear interpolation), or None.

    The heights come as arrays (:func:`sacflow.storage.surface_file.load_surface` reads the file):
    the numerical core does no I/O. Points outside the measured grid raise
    :class:`~sacflow.errors.SacflowError` naming the uncovered extent.
    """
    if surface is None:
        return None
    from scipy.interpolate import RegularGridInterpolator

    data = surface
    interp = RegularGridInterpolator((data.x1, data.x2), data.height, bounds_error=False)

    def heights(x1: np.ndarray, x2: np.ndarray) -> np.ndarray:
        X1, X2 = np.broadcast_arrays(x1, x2)
        out: np.ndarray = interp(np.stack([X1.ravel(), X2.ravel()], axis=-1)).reshape(X1.shape)
        if np.isnan(out).any():
            raise SacflowError(
                f"surface.path: the measured surface covers x1 in [{data.x1[0]:.4g}, "
                f"{data.x1[-1]:.4g}] m, x2 in [{data.x2[0]:.4g}, {data.x2[-1]:.4g}] m but the "
                f"grid needs x1 in [{X1.min():.4g}, {X1.max():.4g}], x2 in [{X2.min():.4g}, "
                f"{X2.max():.4g}] m: measure a larger area or shorten the track"
            )
        return out

    return heights
