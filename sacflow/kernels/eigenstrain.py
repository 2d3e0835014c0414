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

1. the infinite-space field of the cuboids (Chiu 1977, :mod:`sacflow.kernels.cuboid`): a 3-D
   convolution in (x1, x2, x3);
2. the field of the mirror cuboids at ``−x3`` carrying the eigenstrain with ``ε13, ε23``
   sign-flipped (their sum with 1 is free of shear traction on ``x3 = 0``): a convolution in
   (x1, x2) and a *correlation* in x3. The correlation is a convolution with the input reversed
   in x3; with x3 a complex FFT axis of length ``L3`` the reversal costs no FFT:
   ``FFT[ε(n3 − 1 − k)](m) = e^{−2πi (n3 − 1) m / L3} · FFT[ε](−m)``;
3. the half-space response to the normal traction ``p = σ33^{(1+2)}(x1, x2, 0)`` that 1+2 leave
   on the surface (removing it makes the surface traction-free), computed with Love's rectangle
   stresses (:func:`sacflow.kernels.surface.rectangle_stress`).

The traction ``p`` of step 3 is taken over the box footprint (``n1 × n2`` cells): the box must
extend laterally beyond the plastic zone by a margin (the traction decays like ``r⁻³``); the
solver sizes it so. One application costs 6 forward and 6 inverse 3-D FFTs of the
``L1 × L2 × L3 ≈ 2n1 × 2n2 × 2n3`` grid, 2 small 2-D FFTs and ``2 × 36 + 6`` spectral
multiply–adds. Reciprocity (Betti) makes the weighted kernels ``w_c A_cd`` (``w = 1`` for
normal, 2 for shear components) symmetric up to a sign in (c, d), for the mirror kernels too:
21 of the 36 spectra of each kind are stored, the signs are checked numerically at set-up, and
the products run slab by slab over x3-frequencies so that each stored spectrum is read from
memory once per application. Measured on a 2-core machine, the products are then bound by
numpy's one-operation-at-a-time arithmetic (about 60 ms for 64 × 64 × 32 cuboids), not by
memory.

Residual surface displacement (seed eqs. 1.23, 2.3; reciprocal theorem): ``u3(A) = Σ_cells
Σ_d D_d(A − x_c) ε_d``, with the closed-form kernels of
:func:`sacflow.kernels.residual_displacement.cuboid_surface_displacement`; summed over layers by
a contraction of the same 3-D spectrum of the eigenstrain. Exact (no traction truncation).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from sacflow.kernels.cuboid import cuboid_stress_component
from sacflow.kernels.fft import RealFFT, default_threads, padded_length, wraparound_offsets
from sacflow.kernels.residual_displacement import cuboid_surface_displacement
from sacflow.kernels.surface import rectangle_stress

__all__ = [
    "HalfSpaceEigenstrain",
    "eigenstrain_operator",
    "kernel_bytes",
    "residual_displacement",
    "residual_stress",
]

#: Sign of each component under the reflection x3 → −x3 (13 and 23 flip).
MIRROR_SIGN = np.array([1.0, 1.0, 1.0, 1.0, -1.0, -1.0])
#: Spectral points per slab of the spectral products (cache-sized; see _multiply).
_SLAB_POINTS = 32768
#: Reciprocity weights of the components (tensor shears count twice in σ : ε).
WEIGHT = np.array([1.0, 1.0, 1.0, 2.0, 2.0, 2.0])
def _pair_sign(stored: np.ndarray, other: np.ndarray, which: str, c: int, d: int) -> float:
    """Sign s with ``other = s · stored`` (weighted kernels Σ_dc and Σ_cd); checked, not assumed.

    Raises ``RuntimeError`` if the two spectra are not equal up to a sign to 1e-9 of their
    magnitude: reciprocity would then not hold and the 21-pair storage would be wrong.
    """
    scale = max(float(np.abs(stored).max()), float(np.abs(other).max()), 1e-300)
    for sign in (1.0, -1.0):
        if float(np.abs(other - sign * stored).max()) <= 1e-9 * scale:
            return sign
    raise RuntimeError(  # pragma: no cover - a broken kernel, not a user error
        f"{which} eigenstrain kernels ({c}, {d}) and ({d}, {c}) violate reciprocity"
    )


def kernel_bytes(shape: Sequence[int]) -> int:
    """Bytes of cached spectra and FFT buffers a :class:`HalfSpaceEigenstrain` of ``shape`` needs.

    Counts the 21 + 21 complex pair spectra (infinite space and mirror), the 3 × 6 complex layer
    spectra, the FFT buffers (6 real + 6 complex grids, twice) and working arrays.
    """
    n1, n2, n3 = shape
    L1, L2, L3 = padded_length(n1, n1), padded_length(n2, n2), padded_length(n3, n3)
    spec = L3 * L1 * (L2 // 2 + 1)
    real = L3 * L1 * L2
    return int(8 * (2 * 2 * 21 * spec + 2 * 3 * 6 * spec + 2 * 6 * (real + 2 * spec)
                    + 4 * 6 * spec))


def _available_bytes() -> int:
    """Physical memory available to this process (Linux ``MemAvailable``), or a large number."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:  # pragma: no cover
        pass
    return 1 << 62  # pragma: no cover


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
        budget = _available_bytes() if max_bytes is None else int(max_bytes)
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
        self.padded = (padded_length(n3, n3), padded_length(n1, n1), padded_length(n2, n2))
        L3, L1, L2 = self.padded
        # Wrap-around cell offsets along (x3, x1, x2), as a sparse broadcast grid.
        o3 = wraparound_offsets(n3, n3, 0, L3)
        o1 = wraparound_offsets(n1, n1, 0, L1)
        o2 = wraparound_offsets(n2, n2, 0, L2)
        valid = (
            (np.abs(o3) <= n3 - 1)[:, None, None]
            & (np.abs(o1) <= n1 - 1)[None, :, None]
            & (np.abs(o2) <= n2 - 1)[None, None, :]
        )
        x3 = (o3 * d3)[:, None, None]
        x1 = (o1 * d1)[None, :, None]
        x2 = (o2 * d2)[None, None, :]
        h1, h2, h3 = d1 / 2, d2 / 2, d3 / 2
        # The eigenstrain fills (n3, n1, n2) of the padded grid and the stress is read there:
        # pruned transforms skip the zero lines (see RealFFT).
        self._fft3 = RealFFT((6, L3, L1, L2), 3, threads, in_extent=(n3, n1, n2))
        self._out3 = RealFFT((6, L3, L1, L2), 3, threads, out_extent=(n3, n1, n2))
        self._fft2 = RealFFT((1, L1, L2), 2, threads)
        # Work space of the slab-wise spectral products (see _multiply): one array per thread
        # (numpy releases the GIL inside each product).
        lateral = (L1, L2 // 2 + 1)
        self.threads = int(threads or default_threads())
        # Slab thickness: cache-sized, and at least two slabs per thread to balance them.
        # Measured on a quiet 2-core machine, two threads vs one: 65×24×11 cuboids 6.2 vs
        # 10.2 ms, 64×64×32 34 vs 58 ms (on a machine busy with other work they gain nothing).
        workers = self.threads
        self._chunk = max(1, min(_SLAB_POINTS // (lateral[0] * lateral[1]),
                                 -(-(L3 - 1) // (2 * workers))))
        self._tmp_c = [np.empty((self._chunk, *lateral), dtype=complex)
                       for _ in range(workers)]
        self._executor: ThreadPoolExecutor | None = None
        norm3 = 1.0 / (L1 * L2 * L3)
        spec_shape = self._fft3.spectrum_shape[1:]
        # Reciprocity: with weights w = (1, 1, 1, 2, 2, 2) (tensor shears), Σ_cd = w_c A_cd is
        # symmetric up to a sign, Σ_dc = ±Σ_cd, for the infinite-space and the mirror kernels
        # alike (Betti's theorem for two cuboids of eigenstrain; checked by _pair_sign). Only one
        # orientation of each of the 21 pairs is stored; each is read once per application and
        # used twice.
        self._pairs = [(c, d) for c in range(6) for d in range(c, 6)]
        slot = {pair: k for k, pair in enumerate(self._pairs)}
        self._inf = np.empty((21, *spec_shape), dtype=complex)
        self._mir = np.empty((21, *spec_shape), dtype=complex)
        self._inf_sign = np.ones(21)
        self._mir_sign = np.ones(21)
        scratch = RealFFT((1, L3, L1, L2), 3, threads)
        # Mirror: field depth (i+½)d3, source at −(j+½)d3, input reversed (j = n3−1−j'):
        # offset (i − j' + n3) d3 for i − j' = o3.
        x3m = ((o3 + n3) * d3)[:, None, None]
        seen: set[int] = set()
        for d in range(6):
            inf = cuboid_stress_component(x1, x2, x3, h1, h2, h3, self.nu, self.mu, d)
            mir = cuboid_stress_component(x1, x2, x3m, h1, h2, h3, self.nu, self.mu, d)
            for c in range(6):
                k = slot[min(c, d), max(c, d)]
                first = k not in seen
                if first:  # the orientation stored: row c, column d (the other is ± it)
                    seen.add(k)
                    self._pairs[k] = (c, d)
                scratch.real[0] = np.where(valid, WEIGHT[c] * inf[..., c], 0.0)
                spec = scratch.forward()[0] * norm3
                if first:
                    self._inf[k] = spec
                else:
                    self._inf_sign[k] = _pair_sign(self._inf[k], spec, "infinite-space", c, d)
                scratch.real[0] = np.where(valid, WEIGHT[c] * MIRROR_SIGN[d] * mir[..., c], 0.0)
                spec = scratch.forward()[0] * norm3
                if first:
                    self._mir[k] = spec
                else:
                    self._mir_sign[k] = _pair_sign(self._mir[k], spec, "mirror", c, d)
            del inf, mir
        # Fold the reversal's phase into the mirror spectra (see the module notes).
        m = np.arange(L3)
        self._mir *= np.exp(-2j * np.pi * (n3 - 1) * m / L3)[:, None, None]
        self._inv_weight = 1.0 / WEIGHT
        # Layer kernels on the footprint: surface traction of 1+2, residual displacement.
        z = (np.arange(n3) + 0.5) * d3
        o1s, o2s = (o1 * d1)[:, None], (o2 * d2)[None, :]
        lateral_valid = (np.abs(o1) <= n1 - 1)[:, None] & (np.abs(o2) <= n2 - 1)[None, :]
        self._traction = np.zeros((6, *spec_shape), dtype=complex)
        self._displacement = np.zeros((6, *spec_shape), dtype=complex)
        self._correction = np.zeros((6, *spec_shape), dtype=complex)
        phase_plus = np.exp(2j * np.pi * np.outer(np.arange(n3), m) / L3)  # (layer j, m)
        norm2 = 1.0 / (L1 * L2)
        for j, zj in enumerate(z):
            # σ33 on the surface from the cuboid at depth zj and its mirror (13, 23 flipped).
            # The surface is the top face of the first layer, where the closed form is one-sided;
            # σ33 is continuous across a face, so take its limit at x3 = −η (η = 1e-10 d3).
            eta = 1e-10 * d3
            t_layer = np.stack(
                [
                    self._sigma33(o1s, o2s, -zj - eta, d)
                    + MIRROR_SIGN[d] * self._sigma33(o1s, o2s, zj - eta, d)
                    for d in range(6)
                ]
            )
            disp = np.moveaxis(
                cuboid_surface_displacement(o1s, o2s, zj, h1, h2, h3, self.nu), -1, 0
            )
            stress = np.moveaxis(rectangle_stress(o1s, o2s, zj, h1, h2, self.nu), -1, 0)
            phase = phase_plus[j][:, None, None]
            for d in range(6):
                self._traction[d] += (
                    self._spectrum2(t_layer[d] * lateral_valid) * phase * (norm2 / L3)
                )
                self._displacement[d] += (
                    self._spectrum2(disp[d] * lateral_valid) * phase * (norm2 / L3)
                )
                self._correction[d] += (
                    self._spectrum2(stress[d] * lateral_valid) * np.conj(phase) * norm3
                )
        for arr in (self._inf, self._mir, self._traction, self._displacement, self._correction):
            arr.flags.writeable = False

    def _sigma33(self, x1: np.ndarray, x2: np.ndarray, x3: float, source: int) -> np.ndarray:
        """σ33 of the infinite-space cuboid of unit eigenstrain ``source`` at (x1, x2, x3)."""
        d1, d2, d3 = self.spacing
        return cuboid_stress_component(
            x1, x2, x3, d1 / 2, d2 / 2, d3 / 2, self.nu, self.mu, source
        )[..., 2]

    def _spectrum2(self, field: np.ndarray) -> np.ndarray:
        """Unnormalised 2-D spectrum of a wrap-around lateral field (copy)."""
        self._fft2.real[0] = field
        return self._fft2.forward()[0].copy()

    # ------------------------------------------------------------------ application
    def _forward(self, eps: np.ndarray) -> np.ndarray:
        """3-D spectrum of the zero-padded eigenstrain, layout (6, L3, L1, L2h)."""
        n1, n2, n3 = self.shape
        if eps.shape != (n1, n2, n3, 6):
            raise ValueError(f"eigenstrain must have shape {(n1, n2, n3, 6)}, got {eps.shape}")
        buf = self._fft3.real
        buf[:, :n3, :n1, :n2] = np.moveaxis(eps, (3, 2), (0, 1))
        return self._fft3.forward()

    def _layer_sum(self, spectrum: np.ndarray, kernels: np.ndarray) -> np.ndarray:
        """Σ_d Σ_m spectrum_d(m) kernels_d(m): a 2-D lateral spectrum (L1, L2h)."""
        acc = np.zeros(spectrum.shape[2:], dtype=complex)
        for d in range(6):
            acc += np.einsum("mij,mij->ij", spectrum[d], kernels[d])
        return acc

    def _lateral_field(self, spectrum2: np.ndarray) -> np.ndarray:
        """Real field on the box footprint from an unnormalised 2-D spectrum (copy)."""
        n1, n2, _ = self.shape
        self._fft2.spectrum[0] = spectrum2
        return self._fft2.inverse()[0, :n1, :n2].copy()

    def residual_displacement(self, eps: np.ndarray, spectrum: np.ndarray | None = None):
        """Residual normal surface displacement [m] on the box footprint, shape (n1, n2).

        Parameters
        ----------
        eps : ndarray (n1, n2, n3, 6)
            Eigenstrain (plastic strain) per cuboid.
        spectrum : ndarray, optional
            Its 3-D spectrum if already computed (internal reuse).
        """
        spec = self._forward(eps) if spectrum is None else spectrum
        return self._lateral_field(self._layer_sum(spec, self._displacement))

    def _multiply(self, spec: np.ndarray, p_hat: np.ndarray, out: np.ndarray) -> None:
        """Spectral products of one application: ``out_c = Σ_d (A_cd S_d + M_cd S_d(−m)) + C_c p̂``.

        Works through slabs of a few x3-frequencies so that the six input slabs and the six
        accumulators stay in cache while each of the 21 stored pair kernels is read once and used
        for both ``(c, d)`` and ``(d, c)``. The kernels carry the weight ``w_c`` (see
        ``__init__``), removed from each accumulator before the traction correction is added. The
        mirror's input ``S_d(−m)`` of a slab ``[m0, m1)`` is the slab ``(L3 − m0) … (L3 − m1 +
        1)``: a reversed view, no copy. Slabs are independent: with several threads they are
        shared out between them (numpy releases the GIL inside each product).
        """
        L3 = spec.shape[1]
        chunk = self._chunk
        pairs = self._pairs
        kernels = ((self._mir, self._mir_sign, True), (self._inf, self._inf_sign, False))

        def block(sl: slice, rsl: slice, tmp: np.ndarray) -> None:
            t_c = tmp[: sl.stop - sl.start]
            acc = out[:, sl]
            acc[...] = 0.0
            for k, (c, d) in enumerate(pairs):
                both = ((c, d), (d, c)) if c != d else ((c, d),)
                for spectra, signs, mirror in kernels:
                    kernel = spectra[k, sl]
                    for i, (row, col) in enumerate(both):
                        np.multiply(kernel, spec[col, rsl if mirror else sl], out=t_c)
                        if i and signs[k] < 0:
                            acc[row] -= t_c
                        else:
                            acc[row] += t_c
            for c in range(6):
                acc_c = acc[c]
                if self._inv_weight[c] != 1.0:
                    acc_c *= self._inv_weight[c]
                np.multiply(self._correction[c, sl], p_hat, out=t_c)
                acc_c += t_c

        slabs = [(slice(0, 1), slice(0, 1))] + [
            (slice(m0, min(m0 + chunk, L3)), slice(L3 - m0, L3 - min(m0 + chunk, L3), -1))
            for m0 in range(1, L3, chunk)
        ]
        workers = min(len(self._tmp_c), len(slabs))
        if workers == 1:
            for sl, rsl in slabs:
                block(sl, rsl, self._tmp_c[0])
            return

        def run(worker: int) -> None:
            for sl, rsl in slabs[worker::workers]:
                block(sl, rsl, self._tmp_c[worker])

        for future in [self._pool().submit(run, w) for w in range(workers)]:
            future.result()

    def _pool(self) -> ThreadPoolExecutor:
        """Threads of the spectral products (made on first use)."""
        if self._executor is None:
            self._executor = ThreadPoolExecutor(len(self._tmp_c), "sacflow-eigenstrain")
        return self._executor

    def residual_stress(self, eps: np.ndarray, with_displacement: bool = False):
        """Residual stress [Pa] at every cuboid centre, shape (n1, n2, n3, 6).

        With ``with_displacement=True`` returns ``(stress, displacement)`` sharing one forward
        transform.
        """
        n1, n2, n3 = self.shape
        spec = self._forward(eps)
        displacement = self.residual_displacement(eps, spec) if with_displacement else None
        # Surface traction of 1 + 2 on the footprint, then its spectrum for the correction.
        traction = self._lateral_field(self._layer_sum(spec, self._traction))
        self._fft2.real[0] = 0.0
        self._fft2.real[0, :n1, :n2] = traction
        p_hat = self._fft2.forward()[0]
        self._multiply(spec, p_hat, self._out3.spectrum)
        real = self._out3.inverse()
        stress = np.moveaxis(real[:, :n3, :n1, :n2], (0, 1), (3, 2)).copy()
        if with_displacement:
            return stress, displacement
        return stress


@functools.lru_cache(maxsize=4)
def eigenstrain_operator(
    shape: tuple[int, int, int], spacing: tuple[float, float, float], E: float, nu: float
) -> HalfSpaceEigenstrain:
    """Cached :class:`HalfSpaceEigenstrain` for (shape, spacing, E, ν)."""
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
    """Normal surface displacement [m] (positive into the body) of a plastic-strain field.

    Same arguments as :func:`residual_stress`; returns an (n1, n2) array on the surface cells
    above the box (seed eq. 1.23, reciprocal theorem).
    """
    op, eps = _operator_for(plastic_strain, spacing, E, nu)
    return op.residual_displacement(eps)
