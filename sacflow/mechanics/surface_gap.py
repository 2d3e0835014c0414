"""Initial gap between the bodies: curvature, dents and measured surfaces (no I/O here).

Conventions: heights in metres on the body-fixed grid; the *gap contribution* of a feature is
positive where it separates the surfaces. A dent (a hollow in body 1) adds to the gap; a
measured height (positive outward, a peak) subtracts from it. The curvature term is centred on
the load point, the surface features are body-fixed and move with body 1 (seed §1.6, Fig. 3).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Protocol

import numpy as np

__all__ = ["curvature_gap", "dent_profile", "features_gap"]


def curvature_gap(
    x1: np.ndarray, x2: np.ndarray, load_x1: float, load_x2: float, radii: Sequence[float]
) -> np.ndarray:
    """Separation of two curved bodies in Hertz's parabolic approximation (Johnson eq. 4.1).

    ``h = (x1 − l1)² / (2 R1) + (x2 − l2)² / (2 R2)`` with the effective principal radii
    ``1/R_i = 1/R_i(body) + 1/R_i(counter-body)``; infinite radii contribute nothing.
    """
    h = np.zeros(np.broadcast_shapes(np.shape(x1), np.shape(x2)))
    for coord, centre, radius in ((x1, load_x1, radii[0]), (x2, load_x2, radii[1])):
        if np.isfinite(radius):
            h = h + (np.asarray(coord) - centre) ** 2 / (2.0 * radius)
    return h


def dent_profile(
    x1: np.ndarray,
    x2: np.ndarray,
    depth: float,
    width: float,
    decay: float = 13.0,
    centre: Sequence[float] = (0.0, 0.0),
) -> np.ndarray:
    """Gap added by a damped-sinusoid dent: ``A cos(2π r / w) exp(−decay r² / w²)``.

    Reading of seed eq. (3.3) consistent with its numbers: for A = 35 µm,
    w = 450 µm the profile crosses zero at r = w/4 ≈ 112 µm and has shoulders ≈ −0.12 A high
    at r ≈ 0.35 w (the shoulders stand proud of the surface, reducing the gap).
    """
    r = np.hypot(np.asarray(x1) - centre[0], np.asarray(x2) - centre[1])
    return depth * np.cos(2.0 * np.pi * r / width) * np.exp(-decay * r**2 / width**2)


class Dent(Protocol):
    """A damped-sinusoid dent (the schema's ``Dent``): see :func:`dent_profile`."""

    @property
    def depth(self) -> float:
        """Amplitude A [m]."""

    @property
    def width(self) -> float:
        """Width w [m]."""

    @property
    def decay(self) -> float:
        """Decay of the envelope."""

    @property
    def x1(self) -> float:
        """Centre x1 [m]."""

    @property
    def x2(self) -> float:
        """Centre x2 [m]."""


def features_gap(x1: np.ndarray, x2: np.ndarray, dents: Sequence[Dent],
                 heights: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None
                 ) -> np.ndarray:
    """Gap contribution of the body-fixed surface features at body-frame points (x1, x2).

    Parameters
    ----------
    x1, x2 : ndarray
        Body-frame coordinates [m] (broadcast).
    dents : sequence
        Objects with ``depth, width, decay, x1, x2`` (schema ``Dent``).
    heights : callable, optional
        ``heights(x1, x2) -> ndarray`` measured surface height [m] (positive outward).
    """
    h = np.zeros(np.broadcast_shapes(np.shape(x1), np.shape(x2)))
    for dent in dents:
        h = h + dent_profile(x1, x2, dent.depth, dent.width, dent.decay, (dent.x1, dent.x2))
    if heights is not None:
        h = h - heights(x1, x2)
    return h
