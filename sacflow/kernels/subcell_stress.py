"""The stress of a pressure on sub-cells, its kernels folded by the sub-cells' mirror symmetry.

A contact solved on s × s sub-cells of each surface cell loads the body with one Love
rectangle per sub-cell (:func:`sacflow.kernels.shear.subcell_load_stress_coefficients`): s²
inputs, each with its own 6 · nz kernel spectra. Without a shear traction the kernels of the
sub-cells are mirror images of each other. Sub-cell ``o1`` sits at ``c = (o1 + ½)/s − ½`` of a
cell from the cell's centre, and sub-cell ``s − 1 − o1`` at ``−c``; a pressure on a rectangle is
symmetric about the rectangle's two mid-planes, and the stress sampled at (or averaged
symmetrically about) the body cells' centres follows it:

    K_{s−1−o1, o2}(d1, d2) = M₁ · K_{o1, o2}(−d1, d2),

with M₁ the sign of each component under x1 → −x1 (σ12 and σ13 change sign), and likewise in
x2 (σ12 and σ23). Only the kernels of the sub-cells with ``c ≤ 0`` along both axes are kept,
⌈s/2⌉² instead of s²: a quarter of the spectra for s = 2.

A circular convolution with a reversed kernel is the reversal of the convolution of the reversed
input. The DC-FFT grid keeps the offsets ``d`` and ``−d`` at the indices ``j`` and ``L − j``
(the unused ones, zeroed, are symmetric too), so the reversal is that of the padded grid, and on
the real-to-complex spectra (the last axis halved) the mirrored kernel's spectrum is the kept
one's read at ``−k1`` (x1), at ``−k1`` and conjugated (x2: the real kernel's Hermitian
symmetry), or conjugated (both). The stress's spectrum at (k1, k2) is then

    Σ_o  M_c(o) · K̃_o[c, kept(o)](k1, k2) · q̂_o(k1, k2),

the sum over the s² sub-cells' pressure spectra q̂_o, with the component signs M_c of their
mirror: the unfolded operator's multiply-adds, on a quarter of the spectra, each kernel read at
its row or the mirrored row (:func:`folded_products`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numba
import numpy as np

from sacflow.kernels.convolution import Convolution
from sacflow.kernels.cuboid import PARITY
from sacflow.kernels.fft import RealFFT

__all__ = ["MirroredSubcellStress", "folded_products", "representative"]

#: Kinds of mirror of a sub-cell onto its kept one: none, x1, x2, both (the codes of
#: :func:`folded_products`).
MIRRORS = ((False, False), (True, False), (False, True), (True, True))


def representative(offset: int, subcells: int) -> tuple[int, bool]:
    """Return the kept sub-cell index along one axis for sub-cell ``offset``, and its mirror.

    Sub-cell ``offset`` mirrors sub-cell ``subcells − 1 − offset``; the one nearer the cell's
    low side (centre offset ≤ 0) is kept.
    """
    mirrored = 2 * offset > subcells - 1
    return (subcells - 1 - offset if mirrored else offset), mirrored


@numba.njit(nogil=True, fastmath=True, cache=True, boundscheck=False)
def folded_products(kernels: np.ndarray, inputs: np.ndarray, kept: np.ndarray,
                    mirror: np.ndarray, signs: np.ndarray,
                    out: np.ndarray) -> None:  # pragma: no cover - compiled (tested via Python)
    """``out[c] = Σ_o signs[mirror_o, c] · K̃_o[c, kept_o] · inputs[o]`` on the spectra.

    Parameters
    ----------
    kernels : complex ndarray (b, n_kept, L1, L2h)
        The kept sub-cells' kernel spectra of ``b`` output components.
    inputs : complex ndarray (s², L1, L2h)
        The sub-cells' pressure spectra.
    kept, mirror : int ndarray (s²,)
        Per sub-cell: the index of its kept sub-cell's kernels, and its mirror's code
        (:data:`MIRRORS`: 0 none, 1 x1, 2 x2, 3 both). K̃ is the kernel at row ``k1`` (0, 3)
        or ``L1 − k1`` (1, 2), conjugated for 2 and 3 (module docstring).
    signs : float ndarray (4, 6)
        Sign of each stress component under each mirror; output ``c`` is component ``c % 6``
        (a block of whole layers).
    out : complex ndarray (b, L1, L2h)
        Overwritten.
    """
    b, _, l1, l2h = kernels.shape
    for c in range(b):
        for k1 in range(l1):
            mirrored_row = (l1 - k1) % l1
            for j in range(l2h):
                out[c, k1, j] = 0.0
            for o in range(inputs.shape[0]):
                code = mirror[o]
                sign = signs[code, c % signs.shape[1]]
                row = mirrored_row if code == 1 or code == 2 else k1
                kernel = kernels[c, kept[o], row]
                if code >= 2:
                    for j in range(l2h):
                        out[c, k1, j] += sign * np.conj(kernel[j]) * inputs[o, k1, j]
                else:
                    for j in range(l2h):
                        out[c, k1, j] += sign * kernel[j] * inputs[o, k1, j]


class MirroredSubcellStress(Convolution):
    """Stress at the body cells of the pressures on s × s sub-cells, kernels folded by symmetry.

    Applied as :class:`~sacflow.kernels.convolution.Convolution` with s² inputs, channel
    ``o1 · s + o2`` the pressure on sub-cell (o1, o2) of every cell, and ``6 · nz`` outputs
    (depth major, components (11, 22, 33, 12, 13, 23) minor). It keeps the spectra of the
    ⌈s/2⌉² sub-cells nearest the cells' low corner (module docstring).

    Parameters
    ----------
    coefficients : callable
        ``coefficients(d1, d2)`` of the kept sub-cells only, ``(6 · nz, ⌈s/2⌉², *shape)``,
        channel ``r1 · ⌈s/2⌉ + r2`` (for instance
        :func:`~sacflow.kernels.shear.subcell_load_stress_coefficients` with ``only =``
        :meth:`kept`). They must be those of a pressure without shear traction, sampled
        symmetrically about the body cells' centres: the symmetry is assumed, not checked.
    shape : (int, int)
        Lateral shape of the body grid (input and output).
    subcells : int
        Sub-cells per cell and axis, s.
    threads, block, cache
        As :class:`~sacflow.kernels.convolution.Convolution`; ``block`` a multiple of 6.
    """

    def __init__(self, coefficients: Callable[..., np.ndarray], shape: tuple[int, int],
                 subcells: int, threads: int | None = None, block: int | None = None,
                 cache: tuple[str, Mapping[str, Any]] | None = None):
        if cache is not None:
            kind, parameters = cache
            cache = (kind, {**parameters, "mirror_folded": True})
        super().__init__(coefficients, shape, shape, threads=threads, block=block, cache=cache)
        kept = (subcells + 1) // 2
        components = PARITY.shape[1]
        if self.n_in != kept * kept or self.n_out % components or self.block % components:
            raise ValueError(f"need (6 · nz, {kept * kept}, …) coefficients for {subcells} × "
                             f"{subcells} sub-cells and blocks of whole layers; got "
                             f"{self.n_out} × {self.n_in}, blocks of {self.block}")
        self.subcells = subcells
        self._forward = RealFFT((subcells * subcells, *self.padded), self.ndim, threads,
                                in_extent=shape)
        codes = []
        for o1 in range(subcells):
            r1, m1 = representative(o1, subcells)
            for o2 in range(subcells):
                r2, m2 = representative(o2, subcells)
                codes.append((r1 * kept + r2, MIRRORS.index((m1, m2))))
        self._kept = np.array([k for k, _ in codes], dtype=np.int64)
        self._mirror = np.array([m for _, m in codes], dtype=np.int64)
        self._signs = np.array([PARITY[0] ** m1 * PARITY[1] ** m2 for m1, m2 in MIRRORS])

    @staticmethod
    def kept(subcells: int) -> list[tuple[int, int]]:
        """Return the sub-cells (o1, o2) whose kernels are kept, channel ``r1 · ⌈s/2⌉ + r2``."""
        kept = (subcells + 1) // 2
        return [(r1, r2) for r1 in range(kept) for r2 in range(kept)]

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """Apply to ``x`` of shape ``(s², n1, n2)``; returns ``(6 · nz, n1, n2)``."""
        self._forward.real[self._in_window] = x.reshape((-1, *self.in_shape))
        spectra = self._forward.forward()
        out = np.empty((self.n_out, *self.out_shape))
        for k0, k1 in self._blocks:
            acc = self._inverse.spectrum[: k1 - k0]
            folded_products(self.spectra[k0:k1], spectra, self._kept, self._mirror,
                            self._signs, acc)
            if k1 - k0 < self.block:  # a last, shorter block: the rest of the batch is unused
                self._inverse.spectrum[k1 - k0:] = 0.0
            real = self._inverse.inverse()
            out[k0:k1] = real[(slice(0, k1 - k0), *self._out_index)]
        return out
