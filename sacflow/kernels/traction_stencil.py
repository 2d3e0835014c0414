r"""The near-surface part of the half-space correction that centre sampling misses (a stencil).

The eigenstrain operator (:mod:`sacflow.kernels.eigenstrain`) removes the normal traction ``t``
that the infinite-space cuboids and their images leave on the surface as a uniform pressure
over each surface cell, equal to ``t`` at the cell's centre (Love's rectangles; Jacq et al.
2002, appendix 1). For a cuboid in the first layers ``t`` varies within a cell: it has
logarithmic corners and jumps at the cuboid's edges, and a shear source's (ε13, ε23) is odd
about the cell's centre, where it is sampled as zero. The exact correction for the same
piecewise-uniform eigenstrain is Boussinesq's response to ``t`` itself; the two differ by

.. math::

    Δ(x) = \int B(x - y;\, x_3)\, [t(y) - t(y_J)]\, dy, \qquad y \in \text{surface cell } J,

``B`` the stress of a unit point force (:func:`~sacflow.kernels.surface.boussinesq_stress`),
``y_J`` the centre of the cell holding ``y``. ``t - t(y_J)`` is small except near the source,
and ``B`` of a shallow target is narrow, so ``Δ`` is short-ranged: it is tabulated here for
sources in the first :data:`SOURCE_LAYERS` layers, targets in the first
:data:`TARGET_LAYERS` layers and lateral offsets up to a window (:func:`window_cells`), by
:data:`GAUSS_POINTS` × :data:`GAUSS_POINTS` Gauss–Legendre points per surface cell, and added
to the operator's stress (``tests/test_traction_stencil.py``: a surface 9 times finer comes out
as the operator plus ``Δ``; on the shipped press's plastic strain the first layer's σ33 on the
axis moves from +564 to about +144 MPa, ``docs/convergence.md``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numba
import numpy as np

from sacflow.kernels.cuboid import cuboid_stress_component
from sacflow.kernels.eigenstrain_spectra import MIRROR_SIGN, SURFACE_ABOVE
from sacflow.kernels.surface import boussinesq_stress
from sacflow.machine.threads import over_ranges

__all__ = ["GAUSS_POINTS", "SOURCE_LAYERS", "TARGET_LAYERS", "TractionStencil",
           "stencil_kernels", "surface_traction", "window_cells"]

#: Layers of sources whose traction's variation within a cell is integrated (deeper sources'
#: traction is smooth over a cell: the centre value is second-order accurate).
SOURCE_LAYERS = 4
#: Layers of targets that receive the correction (its size falls three to five times a layer).
TARGET_LAYERS = 6
#: Lateral reach of the window, as a share of the target layers' depth (``TARGET_LAYERS`` × dz):
#: ``Δ`` spreads over a distance that grows with the target's depth (the shipped press,
#: dx/dz = 0.44: a window of 4 cells left 90 MPa on the second layer's axis, 6 cells 20 MPa).
WINDOW_DEPTHS = 0.5
#: Largest lateral half-width of the window, in cells: the set-up grows as its fourth power
#: (the quadrature of every target over every loaded cell), 1.3 s at 7 cells. Only layers
#: more than 2.7 times thicker than the cells are wide ask for more (a coarser correction).
MAX_WINDOW = 8
#: Gauss–Legendre points per side of a surface cell (16 move ``Δ`` of a shear source by 1.7 %).
GAUSS_POINTS = 8


def window_cells(spacing: Sequence[float], targets: int = TARGET_LAYERS) -> int:
    """Lateral half-width (cells) of the stencil: :data:`WINDOW_DEPTHS` of the targets' depth.

    At least 3 cells (the first target layer's ``Δ`` falls below 1 % of its peak beyond them
    for cubic cells), at most :data:`MAX_WINDOW`.
    """
    d1, d2, d3 = spacing
    reach = WINDOW_DEPTHS * targets * d3
    return min(MAX_WINDOW, max(3, math.ceil(reach / min(d1, d2))))


def surface_traction(y1: np.ndarray, y2: np.ndarray, depth: float, half: Sequence[float],
                     nu: float, mu: float, source: int) -> np.ndarray:
    """σ33 on the surface of a unit ``source`` cuboid centred at ``depth`` and of its image [Pa].

    ``y1, y2`` relative to the cuboid's axis; ``half`` its half sizes. The limit from above the
    surface, as :func:`sacflow.kernels.eigenstrain_spectra.layer_spectra` takes it.
    """
    h1, h2, h3 = (float(h) for h in half)
    eta = SURFACE_ABOVE * 2.0 * h3
    own = cuboid_stress_component(y1, y2, -depth - eta, h1, h2, h3, nu, mu, source)[..., 2]
    image = cuboid_stress_component(y1, y2, depth - eta, h1, h2, h3, nu, mu, source)[..., 2]
    result: np.ndarray = own + MIRROR_SIGN[source] * image
    return result


def stencil_kernels(spacing: Sequence[float], nu: float, mu: float, sources: int, targets: int,
                    window: int, gauss: int = GAUSS_POINTS) -> np.ndarray:
    """``Δ`` of unit sources: (sources, 2W + 1, 2W + 1, targets, 6 sources, 6 components).

    Entry ``[l, i, j, z, d, c]``: component ``c`` of ``Δ`` at the centre of the cell ``(i − W,
    j − W)`` cells from a unit cuboid of eigenstrain component ``d`` in layer ``l``, in layer
    ``z``. The traction is integrated over the ``(2W + 1)²`` surface cells around the source.
    """
    d1, d2, d3 = (float(d) for d in spacing)
    half = (d1 / 2, d2 / 2, d3 / 2)
    w = 2 * window + 1
    nodes, weights = np.polynomial.legendre.leggauss(gauss)
    cells1 = (np.arange(w) - window) * d1
    cells2 = (np.arange(w) - window) * d2
    q1 = (cells1[:, None] + 0.5 * d1 * nodes).reshape(-1)
    q2 = (cells2[:, None] + 0.5 * d2 * nodes).reshape(-1)
    area = np.outer(np.tile(weights * 0.5 * d1, w), np.tile(weights * 0.5 * d2, w))
    Y1, Y2 = np.meshgrid(q1, q2, indexing="ij")
    C1, C2 = np.meshgrid(cells1, cells2, indexing="ij")
    # the traction's deviation from its cell-centre value, times the quadrature weights
    deviation = np.empty((sources, 6, *Y1.shape))
    for layer in range(sources):
        depth = (layer + 0.5) * d3
        for d in range(6):
            t = surface_traction(Y1, Y2, depth, half, nu, mu, d)
            centre = surface_traction(C1, C2, depth, half, nu, mu, d)
            deviation[layer, d] = (t - np.repeat(np.repeat(centre, gauss, 0), gauss, 1)) * area
    out = np.empty((sources, w, w, targets, 6, 6))
    flat = deviation.reshape(sources * 6, -1)
    for z in range(targets):
        x3 = (z + 0.5) * d3
        for i in range(w):
            for j in range(w):
                b = boussinesq_stress(cells1[i] - Y1, cells2[j] - Y2, x3, nu).reshape(-1, 6)
                out[:, i, j, z] = (flat @ b).reshape(sources, 6, 6)
    return out


@numba.njit(nogil=True, cache=True, boundscheck=False)
def _add_source(source: np.ndarray, kernel: np.ndarray,
                target: np.ndarray) -> None:  # pragma: no cover - compiled
    """``target[zc] += Σ_l Σ_d source[l, d] kernel[l, d, zc]`` (one source column).

    ``kernel`` (L, 6, Z × 6) and ``target`` (Z × 6): the targets' layers and components run
    in one contiguous loop.
    """
    for layer in range(source.shape[0]):
        for d in range(6):
            e = source[layer, d]
            if e == 0.0:
                continue
            row = kernel[layer, d]
            for k in range(target.size):
                target[k] += e * row[k]


@numba.njit(nogil=True, cache=True, boundscheck=False)
def _gather(eps: np.ndarray, active: np.ndarray, kernels: np.ndarray, out: np.ndarray,
            first: int, last: int) -> None:  # pragma: no cover - compiled (tested via Python)
    """``out[x, y] = Σ_ij Σ_l Σ_d eps[x − i + W, y − j + W, l, d] kernels[i, j, l, d]``.

    ``kernels`` (2W + 1, 2W + 1, L, 6, Z × 6); ``out`` (n1, n2, Z × 6).

    For the rows first ≤ x < last; sources whose columns are all zero (``active`` False) are
    skipped. ``out`` rows in range are overwritten.
    """
    n1, n2 = eps.shape[0], eps.shape[1]
    w = kernels.shape[0]
    W = w // 2
    for x in range(first, last):
        for y in range(n2):
            out[x, y] = 0.0
            for i in range(max(0, x + W - n1 + 1), min(w, x + W + 1)):
                sx = x - i + W
                for j in range(max(0, y + W - n2 + 1), min(w, y + W + 1)):
                    sy = y - j + W
                    if active[sx, sy]:
                        _add_source(eps[sx, sy], kernels[i, j], out[x, y])


class TractionStencil:
    """``Δ`` of an eigenstrain field on a box's first layers (module notes).

    Parameters
    ----------
    shape : (int, int, int)
        Cuboids of the box along x1, x2, x3.
    spacing : (float, float, float)
        Cuboid size [m].
    nu, mu : float
        Poisson's ratio and shear modulus [Pa].
    threads : int
        Threads of the application (ranges of x1 rows).
    sources, targets, window, gauss : int, optional
        Source layers, target layers, lateral half-width in cells and Gauss points per side;
        default :data:`SOURCE_LAYERS`, :data:`TARGET_LAYERS`, :func:`window_cells`,
        :data:`GAUSS_POINTS` (the layers at most the box's).
    """

    def __init__(self, shape: Sequence[int], spacing: Sequence[float], nu: float, mu: float,
                 threads: int = 1, *, sources: int | None = None, targets: int | None = None,
                 window: int | None = None, gauss: int = GAUSS_POINTS) -> None:
        n3 = int(shape[2])
        self.sources = min(SOURCE_LAYERS if sources is None else sources, n3)
        self.targets = min(TARGET_LAYERS if targets is None else targets, n3)
        self.window = window_cells(spacing, self.targets) if window is None else int(window)
        self.threads = int(threads)
        self.kernels = stencil_kernels(spacing, nu, mu, self.sources, self.targets, self.window,
                                       gauss)
        # laid out for the application: (i, j, source layer, source component, z × component)
        w = 2 * self.window + 1
        self._layout = np.ascontiguousarray(
            self.kernels.transpose(1, 2, 0, 4, 3, 5)).reshape(w, w, self.sources, 6, -1)

    def top(self, eps: np.ndarray) -> np.ndarray:
        """Return a copy of the first layers of ``eps`` (n1, n2, n3, 6): the stencil's sources."""
        return np.array(eps[:, :, :self.sources], dtype=float)

    def apply(self, top: np.ndarray) -> np.ndarray:
        """``Δ`` [Pa] on the first :attr:`targets` layers, (n1, n2, targets, 6), of ``top``."""
        n1, n2 = top.shape[:2]
        out = np.empty((n1, n2, self.targets * 6))
        active = np.ascontiguousarray((top != 0.0).any(axis=(2, 3)))
        work = (2 * self.window + 1) ** 2 * self.sources * self.targets * 36
        over_ranges(_gather, n1, self.threads, np.ascontiguousarray(top), active, self._layout,
                    out, weight=max(1, int(active.mean() * n2 * work)))
        return out.reshape(n1, n2, self.targets, 6)
