"""Memory model of the eigenstrain operator: what it keeps, what its set-up needs.

What a built :class:`~sacflow.kernels.eigenstrain.HalfSpaceEigenstrain` keeps
(:func:`operator_bytes`), what its set-up needs besides (:func:`setup_bytes`) and their sum,
the peak (:func:`kernel_bytes`): the operator refuses a grid whose peak exceeds the memory
available, and the solver's memory estimate counts them before anything is allocated. The figures
follow from the array shapes of :mod:`sacflow.kernels.eigenstrain_spectra` and of the operator's
transform buffer; the set-up's were checked against tracemalloc (``docs/performance.md``).
"""

from __future__ import annotations

from collections.abc import Sequence

from sacflow.kernels.convolution import padded_length
from sacflow.kernels.fft import default_threads

__all__ = [
    "DEPTH_BLOCK_BYTES",
    "DEPTH_TEMPORARIES",
    "PLANE_TEMPORARIES",
    "kernel_bytes",
    "operator_bytes",
    "padded_lengths",
    "setup_bytes",
]

#: Bytes of the contiguous blocks in which the pair kernels are transformed along depth.
DEPTH_BLOCK_BYTES = 4 << 20
#: Planes of 21 pair kernels alive at once in a thread of the set-up (the kernels, the parity
#: classes' copies and transforms of :func:`~sacflow.kernels.folded_fft.folded_spectra`).
PLANE_TEMPORARIES = 5
#: Blocks of that size alive at once in a depth transform (the block, a transform's input
#: and output, and a slice's copy).
DEPTH_TEMPORARIES = 4


def padded_lengths(shape: Sequence[int]) -> tuple[int, int, int]:
    """Return the padded lateral lengths (L1, L2) and the depth transform length N ≥ 2 n3."""
    n1, n2, n3 = shape
    return padded_length(n1, n1), padded_length(n2, n2), padded_length(n3, n3 + 1)


def operator_bytes(shape: Sequence[int]) -> int:
    """Bytes a built :class:`~sacflow.kernels.eigenstrain.HalfSpaceEigenstrain` of ``shape`` keeps.

    Over the N + 1 depth frequencies: the 21 pair spectra and the 3 × 6 surface and correction
    spectra, all real and stored for the lateral rows k1 ≤ L1 // 2 (39 arrays of
    (L1 // 2 + 1) × (L2 // 2 + 1)), and the one in-place transform buffer (6 complex
    L1 × (L2 // 2 + 1) planes, the real planes a view of them).
    """
    L1, L2, N = padded_lengths(shape)
    stored = 39 * 8 * (L1 // 2 + 1) * (L2 // 2 + 1)
    buffer = 6 * 16 * L1 * (L2 // 2 + 1)  # in place: the real planes share the spectra's memory
    return int((N + 1) * (stored + buffer))


def setup_bytes(shape: Sequence[int], threads: int | None = None) -> int:
    """Bytes the set-up of an operator of ``shape`` needs besides :func:`operator_bytes`.

    The layer kernels (3 × 6 × n3 real planes of the stored spectra's size) and the depth
    projections' temporaries (N such planes per thread) are freed before the pair spectra are
    made: they add what they exceed the pair spectra by. Then, per thread, a plane of the 21 pair
    kernels and the copies of its lateral transforms, and the blocks of their depth transforms.
    """
    L1, L2, N = padded_lengths(shape)
    threads = int(threads or default_threads())
    plane = 8 * (L1 // 2 + 1) * (L2 // 2 + 1)  # one real plane of stored spectra
    pairs = 21 * plane * (N + 1)
    layers = max(0, (18 * shape[2] + threads * N) * plane - pairs)
    per_thread = PLANE_TEMPORARIES * 21 * plane
    blocks = DEPTH_TEMPORARIES * min(DEPTH_BLOCK_BYTES, pairs)  # no block beyond the array
    return int(layers + threads * (per_thread + blocks))


def kernel_bytes(shape: Sequence[int]) -> int:
    """Bytes an operator of ``shape`` needs at the peak of its set-up."""
    return operator_bytes(shape) + setup_bytes(shape)
