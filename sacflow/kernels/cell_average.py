"""Cell-averaged stress: the stress of a cuboid's field averaged over a target cell.

The eigenstrain operators sample the stress at the cell centres by default (collocation). The
plastic strain is uniform in each cell, so the energy-consistent (Galerkin) counterpart of a
cell's stress is its mean over the cell: with it the operator ``ε* → −σ`` is, like the elastic
energy ``−½ ∫ σ : ε* dV`` it derives from, positive semi-definite. Centre sampling is not: for
the axial compression of a plastic core (plastic strain ∝ (1, 1, −2)) the 3-D checkerboard of
cells (alternating sign along every axis) has a negative energy at aspect ratios
``dx/dz ≈ 1.1 … 1.6``, and a plastic problem whose hardening is smaller than that deficit has a
spurious checkerboard solution (docs: the press of the indentation-made dent).

Laterally the mean also reshapes the plastic strain: the half-space is invariant under lateral
translation, so the mean of a cuboid's stress over the target cell's lateral extent is the
stress at the target's centre of the cuboid's eigenstrain spread over the pyramid
``(1 − |u1|/dx)(1 − |u2|/dx)``: the operator collocates the cell values interpolated
bilinearly between the centres (``tests/test_cell_mean_as_bilinear_eigenstrain.py``). With
``s`` points per axis that pyramid is a staircase of ``2 s − 1`` steps.

The mean is taken with the product midpoint rule of ``sampling`` points per axis (the
sub-cell centres ``((q + ½) / s − ½) d``, q = 0 … s − 1): symmetric about the cell centre, so
every kernel keeps its parities, and never on a face of a cell (where the closed forms are
one-sided), as whole-cell offsets never are. ``sampling = 1`` is the centre, the default.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterator

import numpy as np

__all__ = ["cell_mean", "check_sampling", "sub_offsets", "sub_points"]

#: Largest number of points per axis (the kernel set-up evaluates ``sampling³`` times the
#: closed forms of the centre values).
MAX_SAMPLING = 8


def check_sampling(sampling: int) -> int:
    """Return ``sampling`` as an int; ``ValueError`` unless 1 ≤ sampling ≤ :data:`MAX_SAMPLING`."""
    s = int(sampling)
    if s != sampling or not 1 <= s <= MAX_SAMPLING:
        raise ValueError(f"stress sampling must be a whole number of points per axis from 1 to "
                         f"{MAX_SAMPLING}, got {sampling!r}")
    return s


def sub_offsets(sampling: int) -> np.ndarray:
    """Offsets of the sub-cell centres from the cell centre, in cells: ``(q + ½) / s − ½``."""
    s = check_sampling(sampling)
    return (np.arange(s) + 0.5) / s - 0.5


def sub_points(sampling: int, spacing: tuple[float, ...]) -> Iterator[tuple[float, ...]]:
    """Every sub-cell centre [m] relative to the cell centre (``sampling`` per axis)."""
    offsets = sub_offsets(sampling)
    for point in itertools.product(offsets, repeat=len(spacing)):
        yield tuple(float(q * d) for q, d in zip(point, spacing, strict=True))


def cell_mean(field: Callable[..., np.ndarray], sampling: int,
              spacing: tuple[float, ...]) -> np.ndarray:
    """Mean of ``field(*offset)`` over the sub-cell centres (:func:`sub_points`).

    ``field`` takes one offset [m] per axis of ``spacing`` (from the target cell's centre) and
    returns an array; with ``sampling = 1`` it is called once, at the centre.
    """
    points = list(sub_points(sampling, spacing))
    total = field(*points[0])
    for point in points[1:]:
        total = total + field(*point)
    mean: np.ndarray = np.asarray(total) / len(points)
    return mean
