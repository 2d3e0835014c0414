"""Geometry shared by the closed forms of surface loads on a half-space.

The normal load (Boussinesq, Love's rectangle: :mod:`sacflow.kernels.surface`) and the
tangential load (Cerruti and its rectangle: :mod:`sacflow.kernels.shear`) are set up alike: the
field points as float arrays with a depth x3 >= 0 (positive into the body), their distances
from a point force, and the corner sum over a uniformly loaded rectangle |ξ1| <= h1,
|ξ2| <= h2, ``Σ w F(x1 + s1 h1, x2 + s2 h2)`` over the corners of :data:`CORNERS` (Johnson,
*Contact Mechanics*, CUP 1985, §3.2-3.3; Love, Phil. Trans. R. Soc. A 228 (1929) 377).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["CORNERS", "PointForce", "RectanglePoints", "as_float", "check_depth",
           "point_force", "rectangle_points", "safe_div"]

CORNERS: tuple[tuple[float, float, float], ...] = (
    (1.0, 1.0, 1.0),
    (1.0, -1.0, -1.0),
    (-1.0, 1.0, -1.0),
    (-1.0, -1.0, 1.0),
)
"""(sign of h1, sign of h2, weight) of the four corners in the corner sum."""


def as_float(*arrays: ArrayLike) -> list[NDArray[np.float64]]:
    """Return the arguments as float64 arrays."""
    return [np.asarray(a, dtype=np.float64) for a in arrays]


def check_depth(x3: NDArray[np.float64]) -> None:
    """Raise ``ValueError`` if a depth is negative (the half-space is x3 >= 0)."""
    if np.any(x3 < 0.0):
        raise ValueError("x3 is the depth below the surface and must be >= 0")


def safe_div(num: NDArray[np.float64], den: NDArray[np.float64]) -> NDArray[np.float64]:
    """Divide num by den, with 0 where den == 0 (limits the callers know to be 0 or irrelevant)."""
    zero = den == 0.0
    return np.where(zero, 0.0, num / np.where(zero, 1.0, den))


class PointForce(NamedTuple):
    """Field points relative to a point force on the surface, and their distances from it."""

    x1: NDArray[np.float64]
    x2: NDArray[np.float64]
    #: Depth x3 (>= 0).
    z: NDArray[np.float64]
    #: Broadcast shape of the field points.
    shape: tuple[int, ...]
    #: ρ = |x|, ρ³, ρ⁵ and ρ + x3.
    rho: NDArray[np.float64]
    rho3: NDArray[np.float64]
    rho5: NDArray[np.float64]
    rho_z: NDArray[np.float64]


def point_force(x1: ArrayLike, x2: ArrayLike, x3: ArrayLike) -> PointForce:
    """Set up the point-force solutions: float field points, depth checked, ρ and its powers.

    Raises ``ValueError`` if any x3 < 0.
    """
    x, y, z = as_float(x1, x2, x3)
    check_depth(z)
    shape = np.broadcast_shapes(x.shape, y.shape, z.shape)
    rho = np.sqrt(x * x + y * y + z * z)
    rho3 = rho**3
    return PointForce(x, y, z, shape, rho, rho3, rho3 * rho * rho, rho + z)


class RectanglePoints(NamedTuple):
    """Field points relative to the centre of a loaded rectangle, and its half-widths."""

    x1: NDArray[np.float64]
    x2: NDArray[np.float64]
    #: Depth x3 (>= 0).
    z: NDArray[np.float64]
    h1: NDArray[np.float64]
    h2: NDArray[np.float64]
    #: Broadcast shape of the inputs.
    shape: tuple[int, ...]


def rectangle_points(x1: ArrayLike, x2: ArrayLike, x3: ArrayLike, half1: ArrayLike,
                     half2: ArrayLike) -> RectanglePoints:
    """Set up the rectangle solutions: float inputs, depth checked, their broadcast shape.

    Raises ``ValueError`` if any x3 < 0.
    """
    x, y, z, h1, h2 = as_float(x1, x2, x3, half1, half2)
    check_depth(z)
    shape = np.broadcast_shapes(x.shape, y.shape, z.shape, h1.shape, h2.shape)
    return RectanglePoints(x, y, z, h1, h2, shape)
