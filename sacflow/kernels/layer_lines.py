"""Compiled copies between the cuboid box and the eigenstrain operator's transform lines.

The eigenstrain operator (:mod:`sacflow.kernels.eigenstrain`) transforms each component along
depth as a line of its buffer: the box ``eps[i, j, k, c]`` (cell-major, six components last)
goes to ``lines[c, k, i, j]`` (component-major, depth before the lateral axes), the components
odd in x3 (13, 23) one row down, since their depth transform (a sine series) starts at row 1;
the rows below the box are zero padding of the depth transform. The stress comes back the
same way. numpy's strided copy of that transposition jumps between distant pages at every
element; these loops take one box plane ``eps[i]`` at a time (it stays in cache) and write
(or read) the lines in runs of the last axis, and each call handles a range of the first
axis, so that threads share the work (:func:`sacflow.machine.threads.over_ranges`).

The layout is that of :data:`sacflow.kernels.eigenstrain_spectra.EVEN` (components 0–3, even
in x3) and ``ODD`` (4–5).
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["box_from_lines", "lines_from_box"]

#: Components 0 … EVEN_COMPONENTS − 1 are even in x3 (11 22 33 12), the others odd (13 23).
EVEN_COMPONENTS = 4


@numba.njit(nogil=True, cache=True, boundscheck=False)
def _copy(box: np.ndarray, lines: np.ndarray, into_lines: bool, first: int,
          last: int) -> None:  # pragma: no cover - compiled
    """Copy box planes first ≤ i < last into the lines (``into_lines``) or back."""
    box, lines = box[first:last], lines[:, :, first:last]  # from 0: no negative-index checks
    n2, n3 = box.shape[1], box.shape[2]
    for i in range(box.shape[0]):  # box[i] stays in cache while its lines are written or read
        for k in range(n3):
            for c in range(6):
                row = k if c < EVEN_COMPONENTS else k + 1
                if into_lines:
                    for j in range(n2):
                        lines[c, row, i, j] = box[i, j, k, c]
                else:
                    for j in range(n2):
                        box[i, j, k, c] = lines[c, row, i, j]


@numba.njit(nogil=True, cache=True, boundscheck=False)
def lines_from_box(eps: np.ndarray, lines: np.ndarray, first: int,
                   last: int) -> None:  # pragma: no cover - compiled (tested via Python)
    """Write ``eps[i]`` (first ≤ i < last) into the depth lines, and zero their padding.

    Parameters
    ----------
    eps : float ndarray (n1, n2, n3, 6)
        Eigenstrain per cuboid.
    lines : float ndarray (6, D, n1, n2), D > n3
        The operator's real buffer over the box footprint: row k of an even component holds
        layer k, row k + 1 of an odd one; rows k ≥ n3 (even) and k ≥ n3 + 1 (odd) are set to
        zero, row 0 of an odd component is left as it is (its sine transform does not read it).
    """
    _copy(eps, lines, True, first, last)
    n2, n3 = eps.shape[1], eps.shape[2]
    lines = lines[:, :, first:last]
    for c in range(6):
        below = n3 if c < EVEN_COMPONENTS else n3 + 1
        for k in range(below, lines.shape[1]):
            for i in range(lines.shape[2]):
                for j in range(n2):
                    lines[c, k, i, j] = 0.0


@numba.njit(nogil=True, cache=True, boundscheck=False)
def box_from_lines(lines: np.ndarray, out: np.ndarray, first: int,
                   last: int) -> None:  # pragma: no cover - compiled (tested via Python)
    """Read the box back from the lines, ``out[i]`` for first ≤ i < last (the inverse copy).

    ``out`` (n1, n2, n3, 6) receives row k of the even components' lines and row k + 1 of the
    odd ones'.
    """
    _copy(out, lines, False, first, last)
