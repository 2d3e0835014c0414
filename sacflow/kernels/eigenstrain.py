"""Residual stress and residual surface displacement of an eigenstrain field in a half-space.

Conventions
-----------
* Box of ``n1 × n2 × n3`` cuboids of size ``d1 × d2 × d3``, cuboid ``(i, j, k)`` centred at
  ``((i + ½) d1, (j + ½) d2, (k + ½) d3)`` relative to the box corner on the surface; the
  eigenstrain (plastic strain) is uniform in each cuboid. Arrays are indexed
  ``[x1, x2, x3, component]`` with components ``(11, 22, 33, 12, 13, 23)`` (tensor shear).
* x3 is depth, positive into the body; stress positive in tension; the residual surface
  displacement is normal, positive into the body (an indent is positive).
* FFTs: unnormalised forward transforms; all normalisations are folded into cached spectra.

Method
------
Residual stress (Liu & Wang, J. Appl. Mech. 72 (2005) 871, doi:10.1115/1.2047598; seed
appendix 1, Fig. 23): the half-space field is the sum of

1. the infinite-space field of the cuboids (Chiu 1977, :mod:`sacflow.kernels.cuboid`);
2. the field of the image cuboids at ``−x3`` carrying the eigenstrain with ``ε13, ε23``
   sign-flipped (their sum with 1 is free of shear traction on ``x3 = 0``);
3. the half-space response to the normal traction ``p = σ33^{(1+2)}(x1, x2, 0)`` that 1+2 leave
   on the surface (removing it makes the surface traction-free), computed with Love's rectangle
   stresses (:func:`sacflow.kernels.surface.rectangle_stress`).

Depth transforms. 1 + 2 is one infinite-space convolution of the eigenstrain extended to
``x3 < 0`` by its image: each component is even (11 22 33 12) or odd (13 23) in x3 about the
surface, and so is each kernel ``A_cd`` (parity ``s_c s_d``). A convolution of such sequences,
made periodic with period ``2N`` (``N ≥ 2 n3``: the extended input spans ``2 n3`` layers, the
kernel offsets ``|o| ≤ 2 n3 − 1``, so no period overlaps another), is a product in the basis
of cosines or sines (Martucci's symmetric convolution): cell-centred data by a DCT-II (even) or
DST-II (odd) of length N (FFTW ``REDFT10``/``RODFT10``), the kernel, sampled at whole offsets
``0 … N``, by a DCT-I or DST-I, the result back by a DCT-III or DST-III. Writing the DFT of an
odd sequence as ``−i`` times its sine transform, the products are real combinations
``R_c = Σ_d σ_cd G_cd S_d`` with ``σ_cd = −1`` for an even output and an odd input. Depth
frequency m = 0 … N (sines: 1 … N) is plane m of the spectra. The transforms run in place on the
footprint lines of the real buffer; FFTW's real-to-real transforms are slow on the spectral side
(no SIMD codelets: several times a complex pass), cheap on the ``n1 n2`` real footprint lines.
Then pruned 2-D real FFTs (x1, x2) on ``N + 1`` planes. This replaced a 3-D FFT with a separate
mirror kernel (a correlation in x3): one kernel set instead of two, all of them real.

Products. Reciprocity (Betti) makes the weighted kernels ``w_c A_cd`` (``w = 1`` for normal,
2 for shear components) symmetric; with ``σ`` the even–odd block is antisymmetric. Their
parities make every spectrum real (even pairs) or imaginary (even–odd pairs): 21 real arrays
are stored (reciprocity and the parity in x3 checked at set-up), and one compiled pass
(:mod:`sacflow.kernels.pair_products`) forms the six products and adds the traction
correction ``C_c p̂``, computed by 2-D FFTs (``C_c``: Love's stress of each layer, transformed
along depth like the output).

Lateral spectra of the kernels. Every kernel (pair, surface traction and displacement, the
correction) is even or odd along x1 and along x2, so its lateral spectrum follows from its
values at the offsets ``k1, k2 ≥ 0`` by cosine and sine transforms
(:mod:`sacflow.kernels.folded_fft`): the closed forms are evaluated on a quarter of the
wrap-around period, nothing is mirrored, and the spectra are real by construction.

The traction ``p`` of step 3 is taken over the box footprint (``n1 × n2`` cells): the box must
extend laterally beyond the plastic zone by a margin (the traction decays like ``r⁻³``); the
solver sizes it so. One application: 2 × 2 depth transforms of the ``n1 n2`` footprint lines,
6 forward and 6 inverse pruned 2-D FFTs on ``N + 1 ≈ 2 n3`` planes, two small 2-D FFTs, one
contraction over depth for the traction (and the displacement) and the compiled products.

Residual surface displacement (seed eqs. 1.23, 2.3; reciprocal theorem): ``u3(A) = Σ_cells
Σ_d D_d(A − x_c) ε_d``, with the closed-form kernels of
:func:`sacflow.kernels.residual_displacement.cuboid_surface_displacement`; summed over layers by
a contraction of the same depth spectra of the eigenstrain (the layer sum through the
synthesis basis of the depth transform). Exact (no traction truncation).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import scipy.fft

from sacflow.kernels.convolution import padded_length
from sacflow.kernels.cuboid import PARITY
from sacflow.kernels.cuboid_lattice import CuboidLattice
from sacflow.kernels.fft import RealFFT, RealToReal, default_threads
from sacflow.kernels.folded_fft import folded_spectra
from sacflow.kernels.residual_displacement import cuboid_surface_displacement
from sacflow.kernels.surface import rectangle_stress_grid
from sacflow.machine.kernel_cache import cached_arrays
from sacflow.machine.resources import available_memory

__all__ = [
    "HalfSpaceEigenstrain",
    "eigenstrain_operator",
    "kernel_bytes",
    "operator_bytes",
    "residual_displacement",
    "residual_stress",
    "setup_bytes",
]

#: Sign of each component under the reflection x3 → −x3 (13 and 23 flip).
MIRROR_SIGN = PARITY[2]
#: Components even (11 22 33 12) and odd (13 23) under x3 → −x3.
EVEN, ODD = slice(0, 4), slice(4, 6)
#: Reciprocity weights of the components (tensor shears count twice in σ : ε).
WEIGHT = np.array([1.0, 1.0, 1.0, 2.0, 2.0, 2.0])
#: Version of the kernel spectra's formulas and layout: part of their disk-cache key
#: (:mod:`sacflow.machine.kernel_cache`); increase it with any change of what the spectra hold.
KERNEL_VERSION = 3
#: Bytes of the contiguous blocks in which the pair kernels are transformed along depth.
_DEPTH_BLOCK_BYTES = 4 << 20
#: Planes of 21 pair kernels alive at once in a thread of the set-up (the kernels, the parity
#: classes' copies and transforms of :func:`~sacflow.kernels.folded_fft.folded_spectra`).
_PLANE_TEMPORARIES = 5
#: Blocks of that size alive at once in a depth transform (the block, a transform's input
#: and output, and a slice's copy).
_DEPTH_TEMPORARIES = 4


def _check_reciprocity(fields: np.ndarray) -> None:
    """Check ``w_c A_cd = w_d A_dc`` on one plane of kernels (Betti's reciprocity).

    ``fields`` (…, 36) holds every column (c, d) row-major. The weighted kernel matrix is
    symmetric in real space (its spectra then are too, up to the sign −1 that the depth
    transforms give the even–odd pairs, which :func:`sacflow.kernels.pair_products.pair_products`
    relies on); a kernel without it raises ``RuntimeError``.
    """
    weighted = (fields.reshape(*fields.shape[:-1], 6, 6) * WEIGHT[:, None]).reshape(fields.shape)
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


def _contiguous_ranges(count: int, parts: int) -> list[tuple[int, int]]:
    """Split ``0 … count − 1`` into ``min(parts, count)`` contiguous ranges ``(first, last)``."""
    parts = max(1, min(parts, count))
    bounds = np.linspace(0, count, parts + 1).round().astype(int)
    return [(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]


def _in_threads(function, threads: int, *arguments) -> None:
    """Call ``function`` on each tuple of ``arguments`` in up to ``threads`` threads, and wait.

    The set-up's loops over planes, layers, projections and blocks: numpy, scipy.fft and FFTW
    release the GIL; each call writes its own part of the result, so the result does not depend
    on the split.
    """
    count = len(arguments[0])
    with ThreadPoolExecutor(max(1, min(threads, count)), "sacflow-kernels") as pool:
        list(pool.map(function, *arguments))


def _depth_spectra(kernels: np.ndarray, even: int, scale: np.ndarray,
                   threads: int = 1) -> None:
    """Depth transforms, in place, of kernels given for depth offsets 0 … N (axis 0).

    The first ``even`` kernels (last axis) are even in x3: DCT-I over the N + 1 offsets (their
    period-2N DFT). The others are odd: DST-I over offsets 1 … N − 1 at depth frequencies
    1 … N − 1 (the DFT is −i times it; frequencies 0 and N vanish). Each kernel is then
    multiplied by its ``scale``. Done in blocks of x1 rows (axis 1), copied out contiguous and
    back: in the point-major layout a kernel is a strided view, slow to transform on its own.
    The blocks are shared out between ``threads`` (copies and transforms release the GIL).
    """
    rows = max(1, _DEPTH_BLOCK_BYTES // max(1, kernels[:, :1].nbytes))

    def transform(start: int) -> None:
        block = np.array(kernels[:, start:start + rows])
        block[..., :even] = scipy.fft.dct(block[..., :even], type=1, axis=0)
        block[1:-1, ..., even:] = scipy.fft.dst(block[1:-1, ..., even:], type=1, axis=0)
        block[[0, -1], ..., even:] = 0.0
        block *= scale
        kernels[:, start:start + rows] = block

    _in_threads(transform, threads, range(0, kernels.shape[1], rows))


def _depth_projection(layers: np.ndarray, N: int, odd: bool, factor: np.ndarray,
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


def _padded(shape: Sequence[int]) -> tuple[int, int, int]:
    """Return the padded lateral lengths (L1, L2) and the depth transform length N ≥ 2 n3."""
    n1, n2, n3 = shape
    return padded_length(n1, n1), padded_length(n2, n2), padded_length(n3, n3 + 1)


def operator_bytes(shape: Sequence[int]) -> int:
    """Bytes a built :class:`HalfSpaceEigenstrain` of ``shape`` keeps.

    Over the N + 1 depth frequencies: the 21 pair spectra and the 3 × 6 surface and correction
    spectra, all real and stored for the lateral rows k1 ≤ L1 // 2 (39 arrays of
    (L1 // 2 + 1) × (L2 // 2 + 1)), and the one in-place transform buffer (6 complex
    L1 × (L2 // 2 + 1) planes, the real planes a view of them).
    """
    L1, L2, N = _padded(shape)
    stored = 39 * 8 * (L1 // 2 + 1) * (L2 // 2 + 1)
    buffer = 6 * 16 * L1 * (L2 // 2 + 1)  # in place: the real planes share the spectra's memory
    return int((N + 1) * (stored + buffer))


def setup_bytes(shape: Sequence[int], threads: int | None = None) -> int:
    """Bytes the set-up of a :class:`HalfSpaceEigenstrain` of ``shape`` needs besides them.

    The layer kernels (3 × 6 × n3 real planes of the stored spectra's size) and the depth
    projections' temporaries (N such planes per thread) are freed before the pair spectra are
    made: they add what they exceed the pair spectra by. Then, per thread, a plane of the 21 pair
    kernels and the copies of its lateral transforms, and the blocks of their depth transforms.
    Measured (tracemalloc, two threads): 13, 24 and 43 MiB at 64 × 64 × 32, 96 × 96 × 48 and
    128 × 128 × 64 cuboids.
    """
    L1, L2, N = _padded(shape)
    threads = int(threads or default_threads())
    plane = 8 * (L1 // 2 + 1) * (L2 // 2 + 1)  # one real plane of stored spectra
    pairs = 21 * plane * (N + 1)
    layers = max(0, (18 * shape[2] + threads * N) * plane - pairs)
    per_thread = _PLANE_TEMPORARIES * 21 * plane
    blocks = _DEPTH_TEMPORARIES * min(_DEPTH_BLOCK_BYTES, pairs)  # no block beyond the array
    return int(layers + threads * (per_thread + blocks))


def kernel_bytes(shape: Sequence[int]) -> int:
    """Bytes a :class:`HalfSpaceEigenstrain` of ``shape`` needs at the peak of its set-up."""
    return operator_bytes(shape) + setup_bytes(shape)


class HalfSpaceEigenstrain:
    """Linear operators eigenstrain → residual stress and residual surface displacement.

    Parameters
    ----------
    shape : (int, int, int)
        Cuboids of the box along x1, x2, x3.
    spacing : (float, float, float)
        Cuboid size (d1, d2, d3) [m].
    E, nu : float
        Young's modulus [Pa] and Poisson's ratio of the half-space.
    threads : int, optional
        Threads of the FFTs and of the spectral products; default: ``SACFLOW_FFT_THREADS``
        or the number of cores.
    max_bytes : int, optional
        Memory budget; default: the memory available now. A larger need raises
        :class:`~sacflow.errors.GridTooLargeError` naming the bytes required.

    Notes
    -----
    Build once per (shape, spacing, E, ν) — :func:`eigenstrain_operator` caches instances — and
    apply many times; each application is O(N log N) in the number of cuboids.
    """

    def __init__(
        self,
        shape: Sequence[int],
        spacing: Sequence[float],
        E: float,
        nu: float,
        threads: int | None = None,
        max_bytes: int | None = None,
    ):
        from sacflow.errors import GridTooLargeError

        self.shape = tuple(int(n) for n in shape)
        self.spacing = tuple(float(d) for d in spacing)
        self.E, self.nu = float(E), float(nu)
        self.mu = self.E / (2.0 * (1.0 + self.nu))
        need = kernel_bytes(self.shape)
        budget = available_memory() if max_bytes is None else int(max_bytes)
        if need > budget:
            raise GridTooLargeError(
                f"a plastic-zone box of {self.shape[0]}×{self.shape[1]}×{self.shape[2]} cuboids "
                f"needs {need / 2**30:.2f} GiB for its kernels and FFT buffers, "
                f"but only {budget / 2**30:.2f} GiB are available: use fewer cells "
                f"(grid.nx/ny/nz) or a shallower box (grid.depth)"
            )
        self.nbytes = need
        n1, n2, n3 = self.shape
        d1, d2, d3 = self.spacing
        L1, L2, N = _padded(self.shape)
        self.padded = (N, L1, L2)
        # Depth transforms in place on the footprint lines of the real buffers (the padding of
        # each layer stays zero), then pruned lateral transforms (see RealFFT). Layout
        # (component, depth, x1, x2); depth frequency m is plane m for the even components and
        # the DST's frequencies 1 … N are planes 1 … N for the odd ones (module notes).
        # One buffer serves the forward and the inverse: the products overwrite the spectra.
        self._lateral = RealFFT((6, N + 1, L1, L2), 2, threads, in_extent=(n1, n2),
                                out_extent=(n1, n2), in_place=True)
        lines_in = lines_out = self._lateral.real[:, :, :n1, :n2]
        self._depth_forward = (
            RealToReal(lines_in[EVEN, :N], lines_in[EVEN, :N], 1, "FFTW_REDFT10", threads),
            RealToReal(lines_in[ODD, 1:], lines_in[ODD, 1:], 1, "FFTW_RODFT10", threads),
        )
        self._depth_inverse = (
            RealToReal(lines_out[EVEN, :N], lines_out[EVEN, :N], 1, "FFTW_REDFT01", threads),
            RealToReal(lines_out[ODD, 1:], lines_out[ODD, 1:], 1, "FFTW_RODFT01", threads),
        )
        lines_in[...] = 0.0  # measured planning wrote into them
        self._fft2 = RealFFT((1, L1, L2), 2, threads)
        # Threads of the spectral products (the compiled loop releases the GIL; a second
        # thread gains most on large grids, docs/performance.md).
        self.threads = int(threads or default_threads())
        self._executor: ThreadPoolExecutor | None = None
        # contiguous ranges of depth frequencies, one per thread
        self._ranges = _contiguous_ranges(N + 1, self.threads)
        self._inv_weight = 1.0 / WEIGHT
        self._spectra_of_eps = False  # the buffer holds the spectra surface_fields left
        # The 21 pair spectra; the surface kernels (traction, displacement) stacked for one
        # pass; the traction correction. From the disk cache when it has them.
        spectra = cached_arrays("eigenstrain", self.cache_parameters(),
                                lambda: self._spectra(threads))
        self._kernels, self._surface, self._correction = (
            np.asarray(spectra[name]) for name in ("pairs", "surface", "correction"))
        for arr in (self._kernels, self._surface, self._correction):
            arr.flags.writeable = False

    def cache_parameters(self) -> dict:
        """Everything that determines the kernel spectra (the key of the disk cache)."""
        return {"version": KERNEL_VERSION, "shape": list(self.shape),
                "spacing": list(self.spacing), "E": self.E, "nu": self.nu}

    def _spectra(self, threads: int | None) -> dict[str, np.ndarray]:
        """Compute the kernel spectra (a cache miss).

        BLAS on one thread: its calls here (the corner sums' small matrix products) are short,
        and its spinning worker threads would take the cores from the plane loops' threads.
        """
        from sacflow.machine.threads import single_threaded_blas

        with single_threaded_blas():
            surface, correction = self._layer_kernels(threads)
            return {"pairs": self._pair_kernels(threads), "surface": surface,
                    "correction": correction}

    def _folded_offsets(self) -> tuple[np.ndarray, np.ndarray]:
        """Lateral offsets [m] ``k d`` for ``k = 0 … n − 1``: those a kernel is needed at.

        The kernels are even or odd along x1 and x2: their spectra follow from these offsets
        (:func:`~sacflow.kernels.folded_fft.folded_spectra`); the larger offsets of the
        wrap-around period are not used by the convolution (zero).
        """
        n1, n2, _ = self.shape
        d1, d2, _ = self.spacing
        return np.arange(n1) * d1, np.arange(n2) * d2

    def _pair_kernels(self, threads: int | None):
        """Compute 21 stored pair spectra (weighted, normalised), point-major (N+1, L1h, L2h, 21).

        The infinite-space kernel ``A_cd(x1, x2, o d3)`` is evaluated for depth offsets
        ``o = 0 … N`` (zero at ``o = N``, which no pair of cells needs) on the corner lattice
        (:class:`~sacflow.kernels.cuboid_lattice.CuboidLattice`) at the lateral offsets ≥ 0,
        one depth plane at a time, and transformed laterally by the cosine and sine transforms
        its parities allow (:func:`~sacflow.kernels.folded_fft.folded_spectra`); then along
        depth by a DCT-I (even pairs) or a DST-I (odd pairs), which is its full period-2N DFT
        up to the factor −i of odd sequences; ``σ_cd = −1`` for an even output and an odd
        input collects those factors (module notes). Reciprocity and the parity in x3 are
        checked.
        """
        d1, d2, d3 = self.spacing
        N, L1, L2 = self.padded
        x1, x2 = self._folded_offsets()
        # numba is imported with the first operator (not with the solver: elastic runs and
        # campaign workers of elastic cases skip its slow import).
        from sacflow.kernels.pair_products import EVEN_PAIRS, PAIRS

        def lattice() -> CuboidLattice:
            return CuboidLattice(x1, x2, (d1 / 2, d2 / 2, d3 / 2), self.nu, self.mu)

        check = lattice()
        _check_depth_parity(check.folded_plane(-d3), check.folded_plane(d3))
        for m in (0, 1, N // 2):  # in real space; then only the stored columns are computed
            _check_reciprocity(check.folded_plane(m * d3))
        weights = np.array([WEIGHT[c] for c, _ in PAIRS])
        parities = np.array([[PARITY[a, c] * PARITY[a, d] for a in (0, 1)] for c, d in PAIRS])
        # Point-major storage (one contiguous run of 21 per spectral point), rows k1 ≤ L1 // 2
        # (the others are their mirror images): see pair_products.
        kernels = np.empty((N + 1, L1 // 2 + 1, L2 // 2 + 1, 21))
        kernels[N] = 0.0

        def planes(first: int, last: int) -> None:
            """Kernels of the depth offsets first … last − 1 (own lattice)."""
            own = lattice()
            for m in range(first, last):
                folded = own.folded_plane(m * d3, PAIRS)
                folded *= weights
                kernels[m] = folded_spectra(folded, parities, (L1, L2))

        # Depth offsets shared out between the threads, a contiguous range each (one lattice
        # per thread, whose planes of corner functions serve consecutive offsets).
        _in_threads(planes, self.threads, *zip(*_contiguous_ranges(N, self.threads),
                                               strict=True))
        sigma = np.array([-1.0 if MIRROR_SIGN[c] > 0 > MIRROR_SIGN[d] else 1.0
                          for c, d in PAIRS])
        _depth_spectra(kernels, EVEN_PAIRS, sigma / (2 * N * L1 * L2), self.threads)
        return kernels

    def _layer_kernels(self, threads: int | None) -> tuple[np.ndarray, np.ndarray]:
        """Compute the depth-frequency spectra of the surface terms and the traction correction.

        Spectra of the surface traction of 1+2 and of the surface displacement, stacked
        (2, 6, N + 1, L1h, L2h), and of the traction correction (6, N + 1, L1h, L2h); real
        arrays, the imaginary spectra (components 13, 23) divided by i.

        Traction and displacement: ``Σ_d Σ_m S_d(m) K_d(m)`` over the eigenstrain's depth
        spectra ``S`` equals the layer sum ``Σ_d Σ_j T_d(j) ε̂_d(j)`` with ``ε̂_d(j)`` the inverse
        depth transform of ``S_d`` (the basis of :func:`_depth_projection`). Correction: the stress
        of a unit surface traction at each layer, transformed along depth like the output.
        Component ``c`` of each has the lateral parities of component ``c`` (the surface
        traction and displacement are normal, the pressure even). All normalised for the
        unnormalised inverse transforms of an application.
        """
        n1, n2, n3 = self.shape
        d1, d2, d3 = self.spacing
        N, L1, L2 = self.padded
        h1, h2, h3 = d1 / 2, d2 / 2, d3 / 2
        x1, x2 = self._folded_offsets()
        o1, o2 = x1[:, None], x2[None, :]
        parities = PARITY[:2].T
        half = (L1 // 2 + 1, L2 // 2 + 1)
        layer = np.empty((3, 6, n3, *half))
        # The surface is the top face of the first layer, where the closed form is one-sided;
        # σ33 is continuous across a face, so take its limit at x3 = −η (η = 1e-10 d3).
        eta = 1e-10 * d3
        sigma33 = [(2, d) for d in range(6)]

        def layers(first: int, last: int) -> None:
            """Spectra of the layers first … last − 1 (own lattice)."""
            lattice = CuboidLattice(x1, x2, (h1, h2, h3), self.nu, self.mu)

            def spectra(fields: np.ndarray) -> np.ndarray:
                return np.moveaxis(folded_spectra(fields, parities, (L1, L2)), -1, 0)

            for j in range(first, last):
                zj = (j + 0.5) * d3
                # σ33 on the surface from the cuboid at depth zj and its image (13, 23 flipped)
                layer[0, :, j] = spectra(lattice.folded_plane(-zj - eta, sigma33)
                                         + MIRROR_SIGN * lattice.folded_plane(zj - eta, sigma33))
                layer[1, :, j] = spectra(
                    cuboid_surface_displacement(o1, o2, zj, h1, h2, h3, self.nu))
                layer[2, :, j] = spectra(rectangle_stress_grid(x1, x2, zj, h1, h2, self.nu))

        # Layers shared out between the threads, as the pair kernels' depth offsets.
        _in_threads(layers, self.threads, *zip(*_contiguous_ranges(n3, self.threads),
                                               strict=True))
        out = np.empty((3, 6, N + 1, *half))
        weight = np.full(N + 1, 2.0)
        weight[[0, N]] = 1.0
        norm = 1.0 / (2 * N * L1 * L2)

        def project(c: int, k: int) -> None:
            # inverse, for the layer sums: weights 1, 2, …, 2, 1 and 1/(2N); forward (the
            # correction): type II, 2 × the projection
            factor = weight * norm if k < 2 else np.full(N + 1, 2.0 * norm)
            _depth_projection(layer[k, c], N, MIRROR_SIGN[c] < 0, factor, out[k, c])

        # one projection per task, shared out between the threads (each writes its own part of
        # the result, so its first touch of those pages is spread over the cores too)
        tasks = [(c, k) for c in range(6) for k in range(3)]
        _in_threads(project, self.threads, *zip(*tasks, strict=True))
        return out[:2], out[2]

    # ------------------------------------------------------------------ application
    def _forward(self, eps: np.ndarray) -> np.ndarray:
        """Depth-frequency lateral spectra of the eigenstrain, layout (6, N + 1, L1, L2h)."""
        n1, n2, n3 = self.shape
        if eps.shape != (n1, n2, n3, 6):
            raise ValueError(f"eigenstrain must have shape {(n1, n2, n3, 6)}, got {eps.shape}")
        lines = self._lateral.real[:, :, :n1, :n2]
        layers = np.moveaxis(eps, (3, 2), (0, 1))
        lines[EVEN, :n3] = layers[EVEN]
        lines[EVEN, n3:] = 0.0
        lines[ODD, 1:n3 + 1] = layers[ODD]
        lines[ODD, n3 + 1:] = 0.0
        for transform in self._depth_forward:
            transform()
        return self._lateral.forward()

    def _surface_fields(self, spectrum: np.ndarray, kernels: np.ndarray) -> np.ndarray:
        """Surface fields on the box footprint, ``Σ_d Σ_m spectrum_d(m) kernels_qd(m)``.

        ``kernels`` stacks Q sets (traction, displacement); returns (Q, n1, n2).
        """
        n1, n2, _ = self.shape
        sums = np.empty((kernels.shape[0], *spectrum.shape[2:]), dtype=complex)
        from sacflow.kernels.pair_products import depth_sums

        depth_sums(spectrum, kernels, sums)
        fields = np.empty((kernels.shape[0], n1, n2))
        for q, spectrum2 in enumerate(sums):
            self._fft2.spectrum[0] = spectrum2
            fields[q] = self._fft2.inverse()[0, :n1, :n2]
        return fields

    def residual_displacement(self, eps: np.ndarray) -> np.ndarray:
        """Residual normal surface displacement [m] on the box footprint, shape (n1, n2).

        Parameters
        ----------
        eps : ndarray (n1, n2, n3, 6)
            Eigenstrain (plastic strain) per cuboid.
        """
        self._spectra_of_eps = False  # the buffer now holds other spectra
        return self._surface_fields(self._forward(eps), self._surface[1:])[0]

    def _multiply(self, spec: np.ndarray, p_hat: np.ndarray, out: np.ndarray) -> None:
        """Spectral products: ``out_c = Σ_d K_cd spec_d + C_c p̂`` (depth-frequency domain).

        Compiled (:func:`~sacflow.kernels.pair_products.pair_products`); the depth frequencies
        are shared out between the threads (the compiled loop releases the GIL).
        """
        from sacflow.kernels.pair_products import pair_products

        args = (spec, self._kernels, self._inv_weight, self._correction, p_hat, out)
        if len(self._ranges) == 1:
            pair_products(*args, *self._ranges[0])
            return
        futures = [self._pool().submit(pair_products, *args, m0, m1) for m0, m1 in self._ranges]
        for future in futures:
            future.result()

    def _pool(self) -> ThreadPoolExecutor:
        """Threads of the spectral products (made on first use)."""
        if self._executor is None:
            self._executor = ThreadPoolExecutor(self.threads, "sacflow-eigenstrain")
        return self._executor

    def residual_stress(self, eps: np.ndarray, with_displacement: bool = False):
        """Residual stress [Pa] at every cuboid centre, shape (n1, n2, n3, 6).

        With ``with_displacement=True`` returns ``(stress, displacement)`` sharing one forward
        transform.
        """
        traction, displacement = self.surface_fields(eps, with_displacement)
        stress = self.stress(traction)
        return (stress, displacement) if with_displacement else stress

    def surface_fields(self, eps: np.ndarray, with_displacement: bool = True
                       ) -> tuple[np.ndarray, np.ndarray | None]:
        """First half of an application: the surface fields of the eigenstrain ``eps``.

        Returns the normal surface traction [Pa] that the infinite-space fields (1 + 2 of the
        module notes) leave on the footprint and, if asked, the residual surface displacement
        [m], both (n1, n2). The eigenstrain's spectra stay in the operator for :meth:`stress`,
        which must come next (a contact solve may run in between: its transforms are others).
        """
        spec = self._forward(eps)
        fields = self._surface_fields(spec, self._surface if with_displacement
                                      else self._surface[:1])
        self._spectra_of_eps = True
        return fields[0], (fields[1] if with_displacement else None)

    def stress(self, traction: np.ndarray, pressure: np.ndarray | None = None) -> np.ndarray:
        """Second half: the residual stress [Pa] of the eigenstrain of :meth:`surface_fields`.

        The traction it returned is removed from the surface (step 3 of the module notes, Love's
        stresses of a surface pressure equal to it). With ``pressure`` [Pa] (n1, n2, compressive
        positive), the stress of that surface pressure is added in the same transforms: the
        residual stress plus the contact stress for the cost of the residual stress alone.
        """
        if not self._spectra_of_eps:
            raise RuntimeError("HalfSpaceEigenstrain.stress needs surface_fields first")
        self._spectra_of_eps = False
        n1, n2, n3 = self.shape
        self._fft2.real[0] = 0.0
        self._fft2.real[0, :n1, :n2] = traction if pressure is None else traction + pressure
        p_hat = self._fft2.forward()[0]
        spec = self._lateral.spectrum
        self._multiply(spec, p_hat, spec)  # in place, point by point
        self._lateral.inverse()
        for transform in self._depth_inverse:
            transform()
        lines = self._lateral.real[:, :, :n1, :n2]
        stress = np.empty((n1, n2, n3, 6))
        stress[..., EVEN] = np.moveaxis(lines[EVEN, :n3], (0, 1), (3, 2))
        stress[..., ODD] = np.moveaxis(lines[ODD, 1:n3 + 1], (0, 1), (3, 2))
        return stress


@functools.lru_cache(maxsize=4)
def eigenstrain_operator(
    shape: tuple[int, int, int], spacing: tuple[float, float, float], E: float, nu: float
) -> HalfSpaceEigenstrain:
    """Return the cached :class:`HalfSpaceEigenstrain` for (shape, spacing, E, ν)."""
    return HalfSpaceEigenstrain(shape, spacing, E, nu)  # threads: SACFLOW_FFT_THREADS or cores


def _operator_for(plastic_strain: np.ndarray, spacing, E: float, nu: float):
    eps = np.asarray(plastic_strain, dtype=float)
    if eps.ndim != 4 or eps.shape[-1] != 6:
        raise ValueError(
            "plastic_strain must be indexed [x1, x2, x3, component] with 6 components "
            f"(11 22 33 12 13 23); got shape {eps.shape}"
        )
    if len(spacing) != 3 or min(spacing) <= 0:
        raise ValueError(f"spacing must be (dx1, dx2, dx3) > 0 in metres; got {spacing}")
    if E <= 0 or not -1.0 < nu < 0.5:
        raise ValueError(f"need E > 0 and -1 < nu < 0.5; got E={E}, nu={nu}")
    shape = tuple(int(n) for n in eps.shape[:3])
    return eigenstrain_operator(shape, tuple(float(d) for d in spacing), float(E), float(nu)), eps


def residual_stress(plastic_strain: np.ndarray, spacing, E: float, nu: float) -> np.ndarray:
    """Residual stress [Pa] of a plastic-strain (eigenstrain) field in an elastic half-space.

    Parameters
    ----------
    plastic_strain : ndarray (n1, n2, n3, 6)
        Uniform strain per cuboid, components (11, 22, 33, 12, 13, 23) with tensor shears;
        cuboid (i, j, k) is centred at ((i+½) dx1, (j+½) dx2, (k+½) dx3) below the surface.
    spacing : (dx1, dx2, dx3)
        Cuboid size [m].
    E, nu : float
        Young's modulus [Pa] and Poisson's ratio.

    Returns
    -------
    ndarray (n1, n2, n3, 6)
        Stress at every cuboid centre [Pa], tension positive. Operators are cached per
        (shape, spacing, E, ν): repeated calls cost one application, O(N log N).
    """
    op, eps = _operator_for(plastic_strain, spacing, E, nu)
    return op.residual_stress(eps)


def residual_displacement(plastic_strain: np.ndarray, spacing, E: float, nu: float) -> np.ndarray:
    """Compute the normal surface displacement [m] (into the body) of a plastic-strain field.

    Same arguments as :func:`residual_stress`; returns an (n1, n2) array on the surface cells
    above the box (seed eq. 1.23, reciprocal theorem).
    """
    op, eps = _operator_for(plastic_strain, spacing, E, nu)
    return op.residual_displacement(eps)
