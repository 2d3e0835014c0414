"""Compiled spectral products of the eigenstrain operator (one fused pass per spectral point).

The residual stress of an eigenstrain field is, in the operator's depth-frequency domain, a
6 × 6 matrix of kernel spectra applied at every spectral point (Liu & Wang 2005 by DC-FFT; see
:mod:`sacflow.kernels.eigenstrain`). Reciprocity leaves 21 distinct kernels, each real or purely
imaginary: the 4 × 4 block of the components even in x3 (11 22 33 12) and the 2 × 2 block of
the odd ones (13 23) are real and symmetric, the even–odd block is ``i`` times a real 4 × 2
block, antisymmetric under transposition. numpy needs one call per elementwise operation (about
150 per slab of spectral points); this compiled loop reads each input, kernel and output once,
several times faster (``docs/performance.md``). :func:`depth_sums` contracts the spectra over
depth frequency and component for the surface fields, where numpy's einsum was slow.

Each kernel is even or odd in x1 (the product of the parities of its two components), so its
spectrum at (−k1, k2) is ± that at (k1, k2): the kernels are stored for k1 = 0 … L1 // 2 only,
half the memory, and a row k1 > L1 // 2 reads row L1 − k1. With the parities ``P`` of the
components (:data:`PARITY_X1`: 12 and 13 odd), ``Σ_d K_cd(−k1) s_d = P_c Σ_d K_cd(k1) (P_d s_d)``:
the mirrored rows flip the 12 and 13 inputs and outputs, no kernel is touched.
"""

from __future__ import annotations

import numba
import numpy as np

from sacflow.kernels.cuboid import PARITY

__all__ = ["DEPTH_SUM_BLOCKS", "EVEN_PAIRS", "PAIRS", "PARITY_X1", "depth_sums", "pair_products"]

#: Storage order of the 21 kernels: pair (c, d) with c ≥ d (row c, column d of the weighted
#: matrix). The 13 pairs even in x3 (real spectra) come first, then the 8 even–odd pairs
#: (imaginary spectra): the set-up fills and transforms each group as one slice.
PAIRS = (
    (0, 0), (1, 0), (2, 0), (3, 0), (1, 1), (2, 1), (3, 1), (2, 2), (3, 2), (3, 3),
    (4, 4), (5, 4), (5, 5),
    (4, 0), (5, 0), (4, 1), (5, 1), (4, 2), (5, 2), (4, 3), (5, 3),
)
#: Number of leading pairs in :data:`PAIRS` even in x3 (real spectra).
EVEN_PAIRS = 13
#: Parity of each component (11 22 33 12 13 23) under x1 → −x1: the spectra of a kernel at
#: the lateral frequencies (−k1, k2) and (k1, k2) differ by the product of the parities of its
#: two components, so only the rows k1 = 0 … L1 // 2 are stored (module notes).
PARITY_X1 = PARITY[0]
# Slot of each pair in PAIRS, as compile-time constants of the loops below.
_00, _10, _20, _30, _11, _21, _31, _22, _32, _33, _44, _54, _55 = range(13)
_40, _50, _41, _51, _42, _52, _43, _53 = range(13, 21)


@numba.njit(nogil=True, fastmath=True, cache=True, boundscheck=False)
def pair_products(spec: np.ndarray, kernels: np.ndarray, inv_weight: np.ndarray,
                  correction: np.ndarray, p_hat: np.ndarray, out: np.ndarray,
                  m0: int, m1: int) -> None:  # pragma: no cover - compiled (tested via Python)
    """``out_c = (1/w_c) Σ_d K_cd spec_d + correction_c p̂`` for depth frequencies m0 … m1 − 1.

    Parameters
    ----------
    spec : complex ndarray (6, M, L1, L2h)
        Eigenstrain spectra (depth frequency, lateral frequencies).
    kernels : float ndarray (M, L1 // 2 + 1, L2h, 21)
        The weighted kernels ``w_c K_cd`` in :data:`PAIRS` order: the real ones as they are,
        the imaginary (even–odd) ones divided by ``i``. Transposes: ``w_d K_dc = w_c K_cd``
        for real pairs, ``−w_c K_cd`` for the imaginary ones. Rows k1 ≤ L1 // 2 only: row
        ``L1 − k1`` is ``P_c P_d`` times row ``k1`` (:data:`PARITY_X1`).
    inv_weight : float ndarray (6,)
        ``1 / w_c`` (tensor shears count twice in σ : ε).
    correction : float ndarray (6, M, L1 // 2 + 1, L2h); p_hat : complex ndarray (L1, L2h)
        Surface-traction correction spectra (those of 13 and 23 imaginary, stored divided by
        ``i``) and the traction's lateral spectrum.
    out : complex ndarray (6, M, L1, L2h)
        Written for m0 ≤ m < m1 (threads share the depth frequencies out between them).
    """
    L1, L2h, half = spec.shape[2], spec.shape[3], kernels.shape[1]
    w0, w1, w2, w3, w4, w5 = inv_weight[0], inv_weight[1], inv_weight[2], inv_weight[3], \
        inv_weight[4], inv_weight[5]
    for m in range(m0, m1):
        for i in range(L1):
            # Rows i >= half are the mirror images of rows L1 - i (module notes): the 12 and 13
            # components (odd in x1) change sign on the way in and on the way out.
            ii, flip = (i, 1.0) if i < half else (L1 - i, -1.0)
            for j in range(L2h):
                g = kernels[m, ii, j]
                s0, s1, s2 = spec[0, m, i, j], spec[1, m, i, j], spec[2, m, i, j]
                s3, s4, s5 = flip * spec[3, m, i, j], flip * spec[4, m, i, j], spec[5, m, i, j]
                p = p_hat[i, j]
                # Rows of the even components: real 4 × 4 block, −i × the even–odd block.
                e0 = (g[_00] * s0 + g[_10] * s1 + g[_20] * s2 + g[_30] * s3
                      - 1j * (g[_40] * s4 + g[_50] * s5))
                e1 = (g[_10] * s0 + g[_11] * s1 + g[_21] * s2 + g[_31] * s3
                      - 1j * (g[_41] * s4 + g[_51] * s5))
                e2 = (g[_20] * s0 + g[_21] * s1 + g[_22] * s2 + g[_32] * s3
                      - 1j * (g[_42] * s4 + g[_52] * s5))
                e3 = (g[_30] * s0 + g[_31] * s1 + g[_32] * s2 + g[_33] * s3
                      - 1j * (g[_43] * s4 + g[_53] * s5))
                # Rows of the odd components: +i × the transposed block, real 2 × 2 block.
                o4 = (1j * (g[_40] * s0 + g[_41] * s1 + g[_42] * s2 + g[_43] * s3)
                      + g[_44] * s4 + g[_54] * s5)
                o5 = (1j * (g[_50] * s0 + g[_51] * s1 + g[_52] * s2 + g[_53] * s3)
                      + g[_54] * s4 + g[_55] * s5)
                # The correction spectra of 13 and 23 are imaginary, stored divided by i.
                ip = 1j * p
                out[0, m, i, j] = w0 * e0 + correction[0, m, ii, j] * p
                out[1, m, i, j] = w1 * e1 + correction[1, m, ii, j] * p
                out[2, m, i, j] = w2 * e2 + correction[2, m, ii, j] * p
                out[3, m, i, j] = flip * (w3 * e3 + correction[3, m, ii, j] * p)
                out[4, m, i, j] = flip * (w4 * o4 + correction[4, m, ii, j] * ip)
                out[5, m, i, j] = w5 * o5 + correction[5, m, ii, j] * ip


#: Blocks of depth frequencies of :func:`depth_sums`, each summed into its own partial result
#: (threads take whole blocks). Fixed, not one per thread: the partial sums, and so the surface
#: fields, do not depend on the number of threads; four blocks keep up to four threads busy.
DEPTH_SUM_BLOCKS = 4


@numba.njit(nogil=True, fastmath=True, cache=True, boundscheck=False)
def depth_sums(spec: np.ndarray, kernels: np.ndarray, partial: np.ndarray, first: int,
               last: int) -> None:  # pragma: no cover - compiled (tested via Python)
    """Partial surface fields ``partial_b,q = Σ_d Σ_{m in block b} spec_d(m) kernels_qd(m)``.

    Written for the blocks first ≤ b < last of :data:`DEPTH_SUM_BLOCKS` contiguous ranges of
    depth frequencies; the surface fields are ``partial.sum(axis=0)``. Each thread streams its
    own planes of the spectra and the kernels, whole and in order, into a partial result that
    stays in its core's cache (split by rows of the result instead, the two threads' four
    interleaved streams, the spectra and two kernel sets, did not gain from the second thread:
    ``docs/performance.md``). Each sum runs in the same order whatever the threads.

    Parameters
    ----------
    spec : complex ndarray (6, M, L1, L2h)
        Eigenstrain spectra.
    kernels : float ndarray (Q, 6, M, L1 // 2 + 1, L2h)
        Q sets of surface kernels (e.g. traction and displacement), summed in one pass; those
        of the components 13 and 23 are imaginary, stored divided by ``i``. Row ``L1 − r`` of
        the result reads stored row ``r`` (module notes).
    partial : complex ndarray (DEPTH_SUM_BLOCKS, Q, L1, L2h)
        Blocks first ≤ b < last overwritten.
    """
    Q, M, L1, L2h = kernels.shape[0], spec.shape[1], spec.shape[2], spec.shape[3]
    half = kernels.shape[3]
    blocks = partial.shape[0]
    for b in range(first, last):
        out = partial[b]
        out[...] = 0.0
        for d in range(6):
            # kernels of the components even in x3 are real; of 13 and 23 imaginary, stored / i
            factor = 1.0 + 0j if d < 4 else 1j
            mirror = factor * PARITY_X1[d]  # the kernels of 12 and 13 (odd in x1) change sign
            for m in range(b * M // blocks, (b + 1) * M // blocks):
                for r in range(half):
                    for q in range(Q):
                        for j in range(L2h):
                            out[q, r, j] += factor * (spec[d, m, r, j] * kernels[q, d, m, r, j])
                # the mirrored rows i = L1 - r of the stored rows r, swept ascending: the
                # memory prefetches an ascending stream better than a descending one
                for i in range(half, L1):
                    r = L1 - i
                    for q in range(Q):
                        for j in range(L2h):
                            out[q, i, j] += mirror * (spec[d, m, i, j] * kernels[q, d, m, r, j])
