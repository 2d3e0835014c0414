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
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["PAIRS", "depth_sums", "pair_products"]

#: Storage order of the 21 kernels: pair (c, d) with c ≥ d (row c, column d of the weighted
#: matrix); the products below are written for this order.
PAIRS = (
    (0, 0), (1, 0), (2, 0), (3, 0), (4, 0), (5, 0),
    (1, 1), (2, 1), (3, 1), (4, 1), (5, 1),
    (2, 2), (3, 2), (4, 2), (5, 2),
    (3, 3), (4, 3), (5, 3),
    (4, 4), (5, 4),
    (5, 5),
)


@numba.njit(nogil=True, fastmath=True, cache=True, boundscheck=False)
def pair_products(spec: np.ndarray, kernels: np.ndarray, inv_weight: np.ndarray,
                  correction: np.ndarray, p_hat: np.ndarray, out: np.ndarray,
                  m0: int, m1: int) -> None:  # pragma: no cover - compiled (tested via Python)
    """``out_c = (1/w_c) Σ_d K_cd spec_d + correction_c p̂`` for depth frequencies m0 … m1 − 1.

    Parameters
    ----------
    spec : complex ndarray (6, M, L1, L2h)
        Eigenstrain spectra (depth frequency, lateral frequencies).
    kernels : float ndarray (M, L1, L2h, 21)
        The weighted kernels ``w_c K_cd`` in :data:`PAIRS` order: the real ones as they are,
        the imaginary (even–odd) ones divided by ``i``. Transposes: ``w_d K_dc = w_c K_cd``
        for real pairs, ``−w_c K_cd`` for the imaginary ones.
    inv_weight : float ndarray (6,)
        ``1 / w_c`` (tensor shears count twice in σ : ε).
    correction : complex ndarray (6, M, L1, L2h); p_hat : complex ndarray (L1, L2h)
        Surface-traction correction spectra and the traction's lateral spectrum.
    out : complex ndarray (6, M, L1, L2h)
        Written for m0 ≤ m < m1 (threads share the depth frequencies out between them).
    """
    L1, L2h = spec.shape[2], spec.shape[3]
    w0, w1, w2, w3, w4, w5 = inv_weight[0], inv_weight[1], inv_weight[2], inv_weight[3], \
        inv_weight[4], inv_weight[5]
    for m in range(m0, m1):
        for i in range(L1):
            for j in range(L2h):
                g = kernels[m, i, j]
                s0, s1, s2 = spec[0, m, i, j], spec[1, m, i, j], spec[2, m, i, j]
                s3, s4, s5 = spec[3, m, i, j], spec[4, m, i, j], spec[5, m, i, j]
                p = p_hat[i, j]
                # Rows of the even components: real 4 × 4 block, −i × the even–odd block.
                e0 = (g[0] * s0 + g[1] * s1 + g[2] * s2 + g[3] * s3
                      - 1j * (g[4] * s4 + g[5] * s5))
                e1 = (g[1] * s0 + g[6] * s1 + g[7] * s2 + g[8] * s3
                      - 1j * (g[9] * s4 + g[10] * s5))
                e2 = (g[2] * s0 + g[7] * s1 + g[11] * s2 + g[12] * s3
                      - 1j * (g[13] * s4 + g[14] * s5))
                e3 = (g[3] * s0 + g[8] * s1 + g[12] * s2 + g[15] * s3
                      - 1j * (g[16] * s4 + g[17] * s5))
                # Rows of the odd components: +i × the transposed block, real 2 × 2 block.
                o4 = (1j * (g[4] * s0 + g[9] * s1 + g[13] * s2 + g[16] * s3)
                      + g[18] * s4 + g[19] * s5)
                o5 = (1j * (g[5] * s0 + g[10] * s1 + g[14] * s2 + g[17] * s3)
                      + g[19] * s4 + g[20] * s5)
                out[0, m, i, j] = w0 * e0 + correction[0, m, i, j] * p
                out[1, m, i, j] = w1 * e1 + correction[1, m, i, j] * p
                out[2, m, i, j] = w2 * e2 + correction[2, m, i, j] * p
                out[3, m, i, j] = w3 * e3 + correction[3, m, i, j] * p
                out[4, m, i, j] = w4 * o4 + correction[4, m, i, j] * p
                out[5, m, i, j] = w5 * o5 + correction[5, m, i, j] * p


@numba.njit(nogil=True, fastmath=True, cache=True, boundscheck=False)
def depth_sums(spec: np.ndarray, kernels: np.ndarray,
               out: np.ndarray) -> None:  # pragma: no cover - compiled (tested via Python)
    """``out_q = Σ_d Σ_m spec_d(m) kernels_qd(m)``: surface fields from depth spectra.

    Parameters
    ----------
    spec : complex ndarray (6, M, L1, L2h)
        Eigenstrain spectra.
    kernels : complex ndarray (Q, 6, M, L1, L2h)
        Q sets of surface kernels (e.g. traction and displacement), summed in one pass.
    out : complex ndarray (Q, L1, L2h)
        The lateral spectra of the Q surface fields (overwritten).
    """
    Q, M, L1, L2h = kernels.shape[0], spec.shape[1], spec.shape[2], spec.shape[3]
    out[...] = 0.0
    for d in range(6):
        for m in range(M):
            for i in range(L1):
                for q in range(Q):
                    for j in range(L2h):
                        out[q, i, j] += spec[d, m, i, j] * kernels[q, d, m, i, j]
