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
   stresses (:func:`sacflow.kernels.surface.rectangle_stress`). The traction is sampled at
   each surface cell's centre and removed uniformly over the cell; with
   ``traction_quadrature`` its variation within the cells, for the first layers' cuboids, is
   added by a short-range stencil (:mod:`sacflow.kernels.traction_stencil`).

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
solver sizes it so. What lies beyond is missing from the stress (at the shipped windows up to
a few per cent of the residual stress on the axis); with ``traction_beyond_box`` a coarse,
wider operator adds it (:mod:`sacflow.kernels.far_traction`).

One application: 2 × 2 depth transforms of the ``n1 n2`` footprint lines,
6 forward and 6 inverse pruned 2-D FFTs on ``N + 1 ≈ 2 n3`` planes, two small 2-D FFTs, one
contraction over depth for the traction (and the displacement) and the compiled products.

Residual surface displacement (seed eqs. 1.23, 2.3; reciprocal theorem): ``u3(A) = Σ_cells
Σ_d D_d(A − x_c) ε_d``, with the closed-form kernels of
:func:`sacflow.kernels.residual_displacement.cuboid_surface_displacement`; summed over layers by
a contraction of the same depth spectra of the eigenstrain (the layer sum through the
synthesis basis of the depth transform). Exact (no traction truncation).

Here the operator and its application; the kernel spectra are made by
:mod:`sacflow.kernels.eigenstrain_spectra`, and the memory it needs is counted by
:mod:`sacflow.kernels.eigenstrain_memory`.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import TYPE_CHECKING, Any, Literal, overload

import numpy as np

from sacflow.kernels.cell_average import check_sampling
from sacflow.kernels.cuboid import SHEAR_WEIGHTS
from sacflow.kernels.eigenstrain_memory import kernel_bytes, padded_lengths
from sacflow.kernels.eigenstrain_spectra import EVEN, KERNEL_VERSION, ODD, kernel_spectra
from sacflow.kernels.fft import RealFFT, RealToReal, default_threads
from sacflow.machine.kernel_cache import cached_arrays
from sacflow.machine.resources import available_memory
from sacflow.machine.threads import contiguous_ranges, over_ranges

if TYPE_CHECKING:
    from sacflow.kernels.far_traction import FarTraction
    from sacflow.kernels.traction_stencil import TractionStencil

__all__ = [
    "HalfSpaceEigenstrain",
    "eigenstrain_operator",
    "residual_displacement",
    "residual_stress",
]


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
    stress_sampling : int, optional
        Points per axis of each cell at which the stress is averaged
        (:mod:`sacflow.kernels.cell_average`): 1 (default) the centre value, more the cell
        mean (energy-consistent; the kernel set-up evaluates ``stress_sampling³`` times more
        closed forms, on one corner lattice of the sub-points; an application costs the same).
    traction_quadrature : bool, optional
        Add the part of the surface-traction correction that centre sampling misses near the
        surface (:class:`~sacflow.kernels.traction_stencil.TractionStencil`); needs
        ``stress_sampling = 1``. The kernel spectra (and their cache) are the same.
    traction_beyond_box : bool, optional
        Also remove the surface traction beyond the box's footprint, computed by a coarse,
        wider operator (:class:`~sacflow.kernels.far_traction.FarTraction`); without it the
        box must reach far beyond the plastic zone (module notes).

    Attributes
    ----------
    pair_spectra, surface_spectra, correction_spectra : ndarray
        The kernel spectra (:mod:`sacflow.kernels.eigenstrain_spectra`), read-only; memory-mapped
        from the disk cache (:mod:`sacflow.machine.kernel_cache`) when it had them.

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
        stress_sampling: int = 1,
        traction_quadrature: bool = False,
        traction_beyond_box: bool = False,
    ):
        from sacflow.errors import GridTooLargeError

        self.shape = tuple(int(n) for n in shape)
        self.spacing = tuple(float(d) for d in spacing)
        self.E, self.nu = float(E), float(nu)
        self.mu = self.E / (2.0 * (1.0 + self.nu))
        self.stress_sampling = check_sampling(stress_sampling)
        if traction_quadrature and self.stress_sampling != 1:
            raise ValueError("the traction quadrature is made for centre values: "
                             "stress_sampling must be 1")
        need = kernel_bytes(self.shape)
        budget = available_memory() if max_bytes is None else int(max_bytes)
        if need > budget:
            raise GridTooLargeError(
                f"a plastic-zone box of {self.shape[0]}×{self.shape[1]}×{self.shape[2]} cuboids "
                f"needs {need / 2**30:.2f} GiB for its kernels and FFT buffers, "
                f"but only {budget / 2**30:.2f} GiB are available: use fewer cells "
                f"(grid.nx/ny/nz) or a shallower box (grid.depth)"
            )
        n1, n2, n3 = self.shape
        L1, L2, N = padded_lengths(self.shape)
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
        self._ranges = contiguous_ranges(N + 1, self.threads)
        self._inv_weight = 1.0 / SHEAR_WEIGHTS
        self._spectra_of_eps = False  # the buffer holds the spectra surface_fields left
        # The 21 pair spectra; the surface kernels (traction, displacement) stacked for one
        # pass; the traction correction. From the disk cache when it has them.
        spectra = cached_arrays("eigenstrain", self.cache_parameters(),
                                lambda: kernel_spectra(self.shape, self.spacing, self.nu,
                                                       self.mu, self.threads,
                                                       self.stress_sampling))
        self.pair_spectra, self.surface_spectra, self.correction_spectra = (
            np.asarray(spectra[name]) for name in ("pairs", "surface", "correction"))
        for arr in (self.pair_spectra, self.surface_spectra, self.correction_spectra):
            arr.flags.writeable = False
        self._stencil: TractionStencil | None = None
        self._top: np.ndarray | None = None  # the stencil's sources, from surface_fields
        if traction_quadrature:
            from sacflow.kernels.traction_stencil import TractionStencil  # compiled (numba)

            self._stencil = TractionStencil(self.shape, self.spacing, self.nu, self.mu,
                                            self.threads)
        self._far: FarTraction | None = None
        self._far_stress: np.ndarray | None = None  # its stress, from surface_fields
        if traction_beyond_box:
            from sacflow.kernels.far_traction import FarTraction

            self._far = FarTraction(self.shape, self.spacing, self.E, self.nu, self.threads,
                                    max_bytes)

    def cache_parameters(self) -> dict[str, Any]:
        """Everything that determines the kernel spectra (the key of the disk cache).

        The stress sampling enters only when it is not the centre (the keys of centre-sampled
        operators stay those of the kernels already cached).
        """
        parameters: dict[str, Any] = {"version": KERNEL_VERSION, "shape": list(self.shape),
                                      "spacing": list(self.spacing), "E": self.E,
                                      "nu": self.nu}
        if self.stress_sampling != 1:
            parameters["stress_sampling"] = self.stress_sampling
        return parameters

    # ------------------------------------------------------------------ application
    def _forward(self, eps: np.ndarray) -> np.ndarray:
        """Depth-frequency lateral spectra of the eigenstrain, layout (6, N + 1, L1, L2h)."""
        n1, n2, n3 = self.shape
        if eps.shape != (n1, n2, n3, 6):
            raise ValueError(f"eigenstrain must have shape {(n1, n2, n3, 6)}, got {eps.shape}")
        from sacflow.kernels.layer_lines import lines_from_box

        over_ranges(lines_from_box, n1, self.threads, np.ascontiguousarray(eps),
                    self._lateral.real[:, :, :n1, :n2], weight=n2 * n3 * 6)
        for transform in self._depth_forward:
            transform()
        return self._lateral.forward()

    def _surface_fields(self, spectrum: np.ndarray, kernels: np.ndarray) -> np.ndarray:
        """Surface fields on the box footprint, ``Σ_d Σ_m spectrum_d(m) kernels_qd(m)``.

        ``kernels`` stacks Q sets (traction, displacement); returns (Q, n1, n2).
        """
        n1, n2, _ = self.shape
        from sacflow.kernels.pair_products import DEPTH_SUM_BLOCKS, depth_sums

        partial = np.empty((DEPTH_SUM_BLOCKS, kernels.shape[0], *spectrum.shape[2:]),
                           dtype=complex)
        over_ranges(depth_sums, DEPTH_SUM_BLOCKS, self.threads, spectrum, kernels, partial,
                    weight=spectrum.size // DEPTH_SUM_BLOCKS)
        sums = partial.sum(axis=0)  # the blocks in order: the same bits whatever the threads
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
        return self._surface_fields(self._forward(eps), self.surface_spectra[1:])[0, ...]

    def _multiply(self, spec: np.ndarray, p_hat: np.ndarray, out: np.ndarray) -> None:
        """Spectral products: ``out_c = Σ_d K_cd spec_d + C_c p̂`` (depth-frequency domain).

        Compiled (:func:`~sacflow.kernels.pair_products.pair_products`); the depth frequencies
        are shared out between the threads (the compiled loop releases the GIL).
        """
        from sacflow.kernels.pair_products import pair_products

        args = (spec, self.pair_spectra, self._inv_weight, self.correction_spectra, p_hat, out)
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

    @overload
    def residual_stress(self, eps: np.ndarray,
                        with_displacement: Literal[False] = False) -> np.ndarray: ...

    @overload
    def residual_stress(self, eps: np.ndarray,
                        with_displacement: Literal[True]) -> tuple[np.ndarray, np.ndarray]: ...

    def residual_stress(self, eps: np.ndarray, with_displacement: bool = False
                        ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """Residual stress [Pa] of every cuboid (centre or cell mean), shape (n1, n2, n3, 6).

        With ``with_displacement=True`` returns ``(stress, displacement)`` sharing one forward
        transform.
        """
        traction, displacement = self.surface_fields(eps, with_displacement)
        stress = self.stress(traction)
        if displacement is None:
            return stress
        return stress, displacement

    def surface_fields(self, eps: np.ndarray, with_displacement: bool = True
                       ) -> tuple[np.ndarray, np.ndarray | None]:
        """First half of an application: the surface fields of the eigenstrain ``eps``.

        Returns the normal surface traction [Pa] that the infinite-space fields (1 + 2 of the
        module notes) leave on the footprint and, if asked, the residual surface displacement
        [m], both (n1, n2). The eigenstrain's spectra stay in the operator for :meth:`stress`,
        which must come next (a contact solve may run in between: its transforms are others).
        """
        spec = self._forward(eps)
        if self._stencil is not None:
            self._top = self._stencil.top(eps)
        fields = self._surface_fields(spec, self.surface_spectra if with_displacement
                                      else self.surface_spectra[:1])
        if self._far is not None:  # its own operator and buffers: the spectra here stay
            self._far_stress = self._far.stress(eps)
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
        stress = self._back(traction if pressure is None else traction + pressure)
        if self._stencil is not None and self._top is not None:
            stress[:, :, :self._stencil.targets] += self._stencil.apply(self._top)
        if self._far is not None and self._far_stress is not None:
            stress += self._far_stress
            self._far_stress = None
        return stress

    def traction_stress(self, traction: np.ndarray) -> np.ndarray:
        """Stress [Pa] (n1, n2, n3, 6) of removing the surface traction ``traction`` alone.

        Love's stresses of a surface pressure equal to ``traction`` [Pa] (n1, n2), without any
        eigenstrain (the products of :meth:`stress` on zero spectra).
        """
        self._lateral.spectrum[...] = 0.0
        return self._back(traction)

    def _back(self, load: np.ndarray) -> np.ndarray:
        """Transform the buffer's spectra and the surface ``load`` back to the cuboids.

        The products of the spectra in the buffer and of ``load`` (n1, n2), then the inverse
        transforms: the stress (n1, n2, n3, 6). The buffer is spent.
        """
        self._spectra_of_eps = False
        n1, n2, n3 = self.shape
        self._fft2.real[0] = 0.0
        self._fft2.real[0, :n1, :n2] = load
        p_hat = self._fft2.forward()[0]
        spec = self._lateral.spectrum
        self._multiply(spec, p_hat, spec)  # in place, point by point
        self._lateral.inverse()
        for transform in self._depth_inverse:
            transform()
        from sacflow.kernels.layer_lines import box_from_lines

        stress = np.empty((n1, n2, n3, 6))
        over_ranges(box_from_lines, n1, self.threads, self._lateral.real[:, :, :n1, :n2],
                    stress, weight=n2 * n3 * 6)
        return stress


@functools.lru_cache(maxsize=4)
def eigenstrain_operator(
    shape: tuple[int, int, int], spacing: tuple[float, float, float], E: float, nu: float
) -> HalfSpaceEigenstrain:
    """Return the cached :class:`HalfSpaceEigenstrain` for (shape, spacing, E, ν)."""
    return HalfSpaceEigenstrain(shape, spacing, E, nu)  # threads: SACFLOW_FFT_THREADS or cores


def _operator_for(plastic_strain: np.ndarray, spacing: Sequence[float], E: float, nu: float
                  ) -> tuple[HalfSpaceEigenstrain, np.ndarray]:
    """Check the arguments of the notebook functions; return the cached operator and ``eps``."""
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
    n1, n2, n3 = eps.shape[:3]
    d1, d2, d3 = spacing
    operator = eigenstrain_operator((int(n1), int(n2), int(n3)),
                                    (float(d1), float(d2), float(d3)), float(E), float(nu))
    return operator, eps


def residual_stress(plastic_strain: np.ndarray, spacing: Sequence[float], E: float,
                    nu: float) -> np.ndarray:
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


def residual_displacement(plastic_strain: np.ndarray, spacing: Sequence[float], E: float,
                          nu: float) -> np.ndarray:
    """Compute the normal surface displacement [m] (into the body) of a plastic-strain field.

    Same arguments as :func:`residual_stress`; returns an (n1, n2) array on the surface cells
    above the box (seed eq. 1.23, reciprocal theorem).
    """
    op, eps = _operator_for(plastic_strain, spacing, E, nu)
    return op.residual_displacement(eps)
