"""Set-up of the eigenstrain operator: the kernel spectra it multiplies by.

The pair spectra (the infinite-space field of a cuboid and of its image, 21 weighted kernels by
reciprocity), the surface spectra (normal traction of 1 + 2 and residual surface displacement)
and the traction correction of :class:`~sacflow.kernels.eigenstrain.HalfSpaceEigenstrain`, in its
depth-frequency, folded-lateral layout (module notes of :mod:`sacflow.kernels.eigenstrain`):
closed forms on the corner lattice at the lateral offsets ≥ 0, folded lateral transforms
(:mod:`sacflow.kernels.folded_fft`), then depth transforms (DCT-I/DST-I of the kernels, half
DCT-II/DST-II projections of the layers). The loops over depth offsets, layers, projections and
blocks are shared out between threads (:func:`sacflow.machine.threads.in_threads`).

With ``sampling`` > 1 every stress kernel (pairs and correction) is the mean over the
``sampling³`` sub-cell centres of the target cell and the surface traction the mean over the
surface cell's ``sampling²`` sub-cell centres (:mod:`sacflow.kernels.cell_average`): the
operator gives cell-averaged stresses; ``sampling = 1`` (the default) samples the centres.
The sub-points of every target form one lattice of corners (for two points per axis, the odd
multiples of a quarter cell), evaluated once and averaged on its folded offsets
(:class:`~sacflow.kernels.lattice.SampledAxis`); the corner sums of the depth sub-points are
added before the stresses are formed from them (the closed form is linear in them).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.fft

from sacflow.kernels.cell_average import sub_offsets
from sacflow.kernels.cuboid import PARITY, SHEAR_WEIGHTS
from sacflow.kernels.cuboid_lattice import CuboidLattice
from sacflow.kernels.eigenstrain_memory import DEPTH_BLOCK_BYTES, padded_lengths
from sacflow.kernels.folded_fft import folded_spectra
from sacflow.kernels.residual_displacement import cuboid_surface_displacement
from sacflow.kernels.surface import rectangle_stress_sampled
from sacflow.machine.threads import contiguous_ranges, in_threads, single_threaded_blas

__all__ = [
    "EVEN",
    "KERNEL_VERSION",
    "MIRROR_SIGN",
    "ODD",
    "SURFACE_ABOVE",
    "depth_projection",
    "depth_spectra",
    "folded_offsets",
    "kernel_spectra",
    "layer_spectra",
    "pair_spectra",
]

#: Sign of each component under the reflection x3 → −x3 (13 and 23 flip).
MIRROR_SIGN = PARITY[2]
#: Height above the surface, in layers, at which the surface traction of 1 + 2 is evaluated:
#: the closed form is one-sided on the first layer's top face, σ33 continuous across it.
SURFACE_ABOVE = 1e-10
#: Components even (11 22 33 12) and odd (13 23) under x3 → −x3.
EVEN, ODD = slice(0, 4), slice(4, 6)
#: Version of the kernel spectra's formulas and layout: part of their disk-cache key
#: (:mod:`sacflow.machine.kernel_cache`); increase it with any change of what the spectra hold.
KERNEL_VERSION = 3


def _check_reciprocity(fields: np.ndarray) -> None:
    """Check ``w_c A_cd = w_d A_dc`` on one plane of kernels (Betti's reciprocity).

    ``fields`` (…, 36) holds every column (c, d) row-major. The weighted kernel matrix is
    symmetric in real space (its spectra then are too, up to the sign −1 that the depth
    transforms give the even–odd pairs, which :func:`sacflow.kernels.pair_products.pair_products`
    relies on); a kernel without it raises ``RuntimeError``.
    """
    matrix = fields.reshape(*fields.shape[:-1], 6, 6)
    weighted = (matrix * SHEAR_WEIGHTS[:, None]).reshape(fields.shape)
    index = np.arange(36).reshape(6, 6)
    _raise_if_broken(float(np.abs(weighted - weighted[..., index.T.ravel()]).max()),
                     float(np.abs(weighted).max()), "reciprocity")


def _raise_if_broken(mismatch: float, scale: float, what: str) -> None:
    """Raise ``RuntimeError`` when ``mismatch`` exceeds 1e-9 of ``scale``: a broken kernel."""
    if mismatch > 1e-9 * max(scale, 1e-300):  # pragma: no cover - not a user error
        raise RuntimeError(f"eigenstrain kernels violate {what} (mismatch {mismatch:.3e} "
                           f"against values up to {scale:.3e})")


def _check_depth_parity(below: np.ndarray, above: np.ndarray) -> None:
    """Check ``A_cd(x1, x2, −x3) = s_c s_d A_cd(x1, x2, x3)`` (s: :data:`MIRROR_SIGN`).

    ``below`` and ``above`` (…, 36) hold every column one layer below and above the cuboid.
    The depth transforms rely on this parity; a kernel without it raises ``RuntimeError``.
    """
    signs = np.outer(MIRROR_SIGN, MIRROR_SIGN).ravel()
    _raise_if_broken(float(np.abs(above - signs * below).max()), float(np.abs(below).max()),
                     "their parity in x3")


def depth_spectra(kernels: np.ndarray, even: int, scale: np.ndarray, threads: int = 1) -> None:
    """Depth transforms, in place, of kernels given for depth offsets 0 … N (axis 0).

    The first ``even`` kernels (last axis) are even in x3: DCT-I over the N + 1 offsets (their
    period-2N DFT). The others are odd: DST-I over offsets 1 … N − 1 at depth frequencies
    1 … N − 1 (the DFT is −i times it; frequencies 0 and N vanish). Each kernel is then
    multiplied by its ``scale``. Done in blocks of x1 rows (axis 1), copied out contiguous and
    back: in the point-major layout a kernel is a strided view, slow to transform on its own.
    The blocks are shared out between ``threads`` (copies and transforms release the GIL).
    """
    rows = max(1, DEPTH_BLOCK_BYTES // max(1, kernels[:, :1].nbytes))

    def transform(start: int) -> None:
        block = np.array(kernels[:, start:start + rows])
        block[..., :even] = scipy.fft.dct(block[..., :even], type=1, axis=0)
        block[1:-1, ..., even:] = scipy.fft.dst(block[1:-1, ..., even:], type=1, axis=0)
        block[[0, -1], ..., even:] = 0.0
        block *= scale
        kernels[:, start:start + rows] = block

    in_threads(transform, threads, range(0, kernels.shape[1], rows))


def depth_projection(layers: np.ndarray, N: int, odd: bool, factor: np.ndarray,
                     out: np.ndarray) -> None:
    """Project layers on the depth basis: ``Σ_j cos`` (even) or ``sin`` (odd) ``(π m (j + ½) / N)``.

    Layers j < n3 along axis 0, depth frequencies m = 0 … N into ``out`` (N + 1 planes), each
    multiplied by ``factor[m]``: half a DCT-II (even) or DST-II (odd, frequencies 1 … N) of the
    layers zero-padded to N. Times 2 it is the analysis of FFTW's REDFT10/RODFT10; with weights
    1, 2, …, 2, 1 and 1/(2N) the synthesis of REDFT01/RODFT01.
    """
    shape = (-1,) + (1,) * (layers.ndim - 1)
    if odd:
        out[0] = 0.0
        spectrum = scipy.fft.dst(layers, type=2, n=N, axis=0)
        np.multiply(spectrum, 0.5 * factor[1:].reshape(shape), out=out[1:])
    else:
        out[N] = 0.0
        spectrum = scipy.fft.dct(layers, type=2, n=N, axis=0)
        np.multiply(spectrum, 0.5 * factor[:N].reshape(shape), out=out[:N])


def folded_offsets(shape: Sequence[int], spacing: Sequence[float]
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Lateral offsets [m] ``k d`` for ``k = 0 … n − 1``: those a kernel is needed at.

    The kernels are even or odd along x1 and x2: their spectra follow from these offsets
    (:func:`~sacflow.kernels.folded_fft.folded_spectra`); the larger offsets of the
    wrap-around period are not used by the convolution (zero).
    """
    n1, n2, _ = shape
    d1, d2, _ = spacing
    return np.arange(n1) * d1, np.arange(n2) * d2


def kernel_spectra(shape: Sequence[int], spacing: Sequence[float], nu: float, mu: float,
                   threads: int, sampling: int = 1) -> dict[str, np.ndarray]:
    """Compute the kernel spectra of an operator (a miss of the disk cache).

    ``pairs`` (:func:`pair_spectra`), ``surface`` and ``correction`` (:func:`layer_spectra`),
    the stresses sampled at ``sampling`` points per axis of the target cell.
    BLAS on one thread: its calls here (the corner sums' small matrix products) are short, and
    its spinning worker threads would take the cores from the plane loops' threads.
    """
    with single_threaded_blas():
        surface, correction = layer_spectra(shape, spacing, nu, mu, threads, sampling)
        return {"pairs": pair_spectra(shape, spacing, nu, mu, threads, sampling),
                "surface": surface, "correction": correction}


class SampledLattices:
    """Cuboid stresses at whole-cell offsets, averaged over sub-cell points of the target.

    One :class:`~sacflow.kernels.cuboid_lattice.CuboidLattice` on the union of the lateral
    sub-points ``k d + ξ`` (averaged on its folded offsets with the kernels' parities), its
    corner sums summed over the depth sub-points; with ``sampling = 1`` the centre lattice
    (folded offsets: the values at ``k d``, ``k ≥ 0``).
    """

    def __init__(self, x1: np.ndarray, x2: np.ndarray, spacing: Sequence[float], nu: float,
                 mu: float, sampling: int, depth_points: bool = True):
        d1, d2, d3 = spacing
        half = (d1 / 2, d2 / 2, d3 / 2)
        self.sampling = sampling
        offsets = sub_offsets(sampling)
        sub = (offsets * d1, offsets * d2) if sampling > 1 else None
        self.lattice = CuboidLattice(x1, x2, half, nu, mu, sub=sub)
        self.depths = tuple(offsets * d3) if depth_points else (0.0,)

    def plane(self, x3: float, columns: Sequence[tuple[int, int]] | None = None) -> np.ndarray:
        """Mean of the columns over the sub-points, (len(x1), len(x2), columns), at ``x3``."""
        if self.sampling == 1:
            return self.lattice.folded_plane(x3, columns, self.depths)
        columns = ([(c, d) for c in range(6) for d in range(6)] if columns is None
                   else list(columns))
        return self.lattice.mean_plane(x3, columns, self.depths)


def pair_spectra(shape: Sequence[int], spacing: Sequence[float], nu: float, mu: float,
                 threads: int, sampling: int = 1) -> np.ndarray:
    """Compute 21 stored pair spectra (weighted, normalised), point-major (N+1, L1h, L2h, 21).

    The infinite-space kernel ``A_cd(x1, x2, o d3)`` (Poisson's ratio ``nu``, shear modulus
    ``mu``) is evaluated for depth offsets ``o = 0 … N`` (zero at ``o = N``, which no pair of
    cells needs) on the corner lattice (:class:`~sacflow.kernels.cuboid_lattice.CuboidLattice`)
    at the lateral offsets ≥ 0, one depth plane at a time, and transformed laterally by the
    cosine and sine transforms its parities allow
    (:func:`~sacflow.kernels.folded_fft.folded_spectra`); then along depth by a DCT-I (even
    pairs) or a DST-I (odd pairs), which is its full period-2N DFT up to the factor −i of odd
    sequences; ``σ_cd = −1`` for an even output and an odd input collects those factors (module
    notes of :mod:`sacflow.kernels.eigenstrain`). Reciprocity and the parity in x3 are checked
    (on the averaged kernels with ``sampling`` > 1: the sub-points are symmetric).
    """
    d1, d2, d3 = spacing
    L1, L2, N = padded_lengths(shape)
    x1, x2 = folded_offsets(shape, spacing)
    # numba is imported with the first operator (not with the solver: elastic runs and
    # campaign workers of elastic cases skip its slow import).
    from sacflow.kernels.pair_products import EVEN_PAIRS, PAIRS

    def lattice() -> SampledLattices:
        return SampledLattices(x1, x2, spacing, nu, mu, sampling)

    check = lattice()
    _check_depth_parity(check.plane(-d3), check.plane(d3))
    for m in (0, 1, N // 2):  # in real space; then only the stored columns are computed
        _check_reciprocity(check.plane(m * d3))
    weights = np.array([SHEAR_WEIGHTS[c] for c, _ in PAIRS])
    parities = np.array([[PARITY[a, c] * PARITY[a, d] for a in (0, 1)] for c, d in PAIRS])
    # Point-major storage (one contiguous run of 21 per spectral point), rows k1 ≤ L1 // 2
    # (the others are their mirror images): see pair_products.
    kernels = np.empty((N + 1, L1 // 2 + 1, L2 // 2 + 1, 21))
    kernels[N] = 0.0

    def planes(first: int, last: int) -> None:
        """Kernels of the depth offsets first … last − 1 (own lattice)."""
        own = lattice()
        for m in range(first, last):
            folded = own.plane(m * d3, PAIRS)
            folded *= weights
            kernels[m] = folded_spectra(folded, parities, (L1, L2))

    # Depth offsets shared out between the threads, a contiguous range each (one lattice
    # per thread, whose planes of corner functions serve consecutive offsets).
    in_threads(planes, threads, *zip(*contiguous_ranges(N, threads), strict=True))
    sigma = np.array([-1.0 if MIRROR_SIGN[c] > 0 > MIRROR_SIGN[d] else 1.0
                      for c, d in PAIRS])
    depth_spectra(kernels, EVEN_PAIRS, sigma / (2 * N * L1 * L2), threads)
    return kernels


def layer_spectra(shape: Sequence[int], spacing: Sequence[float], nu: float, mu: float,
                  threads: int, sampling: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Compute the depth-frequency spectra of the surface terms and the traction correction.

    Spectra of the surface traction of 1+2 and of the surface displacement, stacked
    (2, 6, N + 1, L1h, L2h), and of the traction correction (6, N + 1, L1h, L2h); real
    arrays, the imaginary spectra (components 13, 23) divided by i.

    Traction and displacement: ``Σ_d Σ_m S_d(m) K_d(m)`` over the eigenstrain's depth
    spectra ``S`` equals the layer sum ``Σ_d Σ_j T_d(j) ε̂_d(j)`` with ``ε̂_d(j)`` the inverse
    depth transform of ``S_d`` (the basis of :func:`depth_projection`). Correction: the stress
    of a unit surface traction at each layer, transformed along depth like the output.
    Component ``c`` of each has the lateral parities of component ``c`` (the surface
    traction and displacement are normal, the pressure even). All normalised for the
    unnormalised inverse transforms of an application. With ``sampling`` > 1 the traction is
    the mean over the surface cell and the correction the mean over the target cell.
    """
    n1, n2, n3 = shape
    d1, d2, d3 = spacing
    L1, L2, N = padded_lengths(shape)
    h1, h2, h3 = d1 / 2, d2 / 2, d3 / 2
    x1, x2 = folded_offsets(shape, spacing)
    o1, o2 = x1[:, None], x2[None, :]
    parities = PARITY[:2].T
    half = (L1 // 2 + 1, L2 // 2 + 1)
    layer = np.empty((3, 6, n3, *half))
    # The surface is the top face of the first layer, where the closed form is one-sided;
    # σ33 is continuous across a face, so take its limit at x3 = −η.
    eta = SURFACE_ABOVE * d3
    sigma33 = [(2, d) for d in range(6)]

    def layers(first: int, last: int) -> None:
        """Spectra of the layers first … last − 1 (own lattice)."""
        lattice = SampledLattices(x1, x2, spacing, nu, mu, sampling, depth_points=False)

        def spectra(fields: np.ndarray) -> np.ndarray:
            return np.moveaxis(folded_spectra(fields, parities, (L1, L2)), -1, 0)

        for j in range(first, last):
            zj = (j + 0.5) * d3
            # σ33 on the surface from the cuboid at depth zj and its image (13, 23 flipped)
            layer[0, :, j] = spectra(lattice.plane(-zj - eta, sigma33)
                                     + MIRROR_SIGN * lattice.plane(zj - eta, sigma33))
            layer[1, :, j] = spectra(cuboid_surface_displacement(o1, o2, zj, h1, h2, h3, nu))
            layer[2, :, j] = spectra(cell_mean_love_stress(x1, x2, zj, spacing, nu, sampling))

    # Layers shared out between the threads, as the pair kernels' depth offsets.
    in_threads(layers, threads, *zip(*contiguous_ranges(n3, threads), strict=True))
    out = np.empty((3, 6, N + 1, *half))
    weight = np.full(N + 1, 2.0)
    weight[[0, N]] = 1.0
    norm = 1.0 / (2 * N * L1 * L2)

    def project(c: int, k: int) -> None:
        # inverse, for the layer sums: weights 1, 2, …, 2, 1 and 1/(2N); forward (the
        # correction): type II, 2 × the projection
        factor = weight * norm if k < 2 else np.full(N + 1, 2.0 * norm)
        depth_projection(layer[k, c], N, MIRROR_SIGN[c] < 0, factor, out[k, c])

    # one projection per task, shared out between the threads (each writes its own part of
    # the result, so its first touch of those pages is spread over the cores too)
    tasks = [(c, k) for c in range(6) for k in range(3)]
    in_threads(project, threads, *zip(*tasks, strict=True))
    return out[:2], out[2]


def cell_mean_love_stress(x1: np.ndarray, x2: np.ndarray, depth: float,
                          spacing: Sequence[float], nu: float, sampling: int) -> np.ndarray:
    """Love's stress of a unit pressure on a surface cell, at ``x1 × x2`` and ``depth`` [m].

    Its value at the centre (``sampling = 1``) or its mean over the target cell's
    ``sampling³`` sub-cell centres (:func:`~sacflow.kernels.surface.rectangle_stress_sampled`);
    (len(x1), len(x2), 6).
    """
    d1, d2, d3 = spacing
    q = sub_offsets(sampling)
    return rectangle_stress_sampled(x1, x2, depth + q * d3, (q * d1, q * d2), d1 / 2, d2 / 2, nu)
