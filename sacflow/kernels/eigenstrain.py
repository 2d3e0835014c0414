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
``L1 × L2 × L3 ≈ 2n1 × 2n2 × 2n3`` grid, 2 small 2-D FFTs and ``2 × 36 + 12`` spectral
multiply–adds; the stored spectra of the infinite-space kernels are purely real or purely
imaginary (each kernel is even or odd in every axis) and are kept as real arrays.

Residual surface displacement (seed eqs. 1.23, 2.3; reciprocal theorem): ``u3(A) = Σ_cells
Σ_d D_d(A − x_c) ε_d``, with the closed-form kernels of
:func:`sacflow.kernels.residual_displacement.cuboid_surface_displacement`; summed over layers by
a contraction of the same 3-D spectrum of the eigenstrain. Exact (no traction truncation).
"""

from __future__ import annotations

import functools
import os
from collections.abc import Sequence

import numpy as np

from sacflow.kernels.cuboid import cuboid_stress_component
from sacflow.kernels.fft import RealFFT, padded_length, wraparound_offsets
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
#: Number of axes (x1, x2, x3) along which component c is odd: parity of the kernel A_cd is the
#: sum for c and d; used to store real spectra (see :func:`_parity`).
_ODD_AXES = {0: (), 1: (), 2: (), 3: (0, 1), 4: (0, 2), 5: (1, 2)}


def _parity(c: int, d: int) -> tuple[int, int, int]:
    """Parity (0 even, 1 odd) of the infinite-space kernel A_cd along (x3, x1, x2)."""
    odd = [0, 0, 0]  # along x1, x2, x3
    for comp in (c, d):
        for axis in _ODD_AXES[comp]:
            odd[axis] ^= 1
    return odd[2], odd[0], odd[1]


def kernel_bytes(shape: Sequence[int]) -> int:
    """Bytes of cached spectra and FFT buffers a :class:`HalfSpaceEigenstrain` of ``shape`` needs.

    Counts the 36 real infinite-space spectra, the 36 complex mirror spectra, the 3 × 6 complex
    surface spectra, the FFT buffers (6 real + 6 complex grids, twice) and working arrays.
    """
    n1, n2, n3 = shape
    L1, L2, L3 = padded_length(n1, n1), padded_length(n2, n2), padded_length(n3, n3)
    spec = L3 * L1 * (L2 // 2 + 1)
    real = L3 * L1 * L2
    return int(8 * (36 * spec + 2 * 36 * spec + 2 * 3 * 6 * spec + 2 * 6 * (real + 2 * spec)
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
        FFT threads.
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
        self._fft3 = RealFFT((6, L3, L1, L2), 3, threads)
        self._out3 = RealFFT((6, L3, L1, L2), 3, threads)
        self._fft2 = RealFFT((1, L1, L2), 2, threads)
        norm3 = 1.0 / (L1 * L2 * L3)
        spec_shape = self._fft3.spectrum_shape[1:]
        self._inf = np.empty((6, 6, *spec_shape))  # real: value · i^(odd count) below
        self._inf_imag = np.zeros((6, 6), dtype=bool)
        self._mir = np.empty((6, 6, *spec_shape), dtype=complex)
        scratch = RealFFT((1, L3, L1, L2), 3, threads)
        # Mirror: field depth (i+½)d3, source at −(j+½)d3, input reversed (j = n3−1−j'):
        # offset (i − j' + n3) d3 for i − j' = o3.
        x3m = ((o3 + n3) * d3)[:, None, None]
        for d in range(6):
            inf = cuboid_stress_component(x1, x2, x3, h1, h2, h3, self.nu, self.mu, d)
            mir = cuboid_stress_component(x1, x2, x3m, h1, h2, h3, self.nu, self.mu, d)
            for c in range(6):
                scratch.real[0] = np.where(valid, inf[..., c], 0.0)
                spec = scratch.forward()[0] * norm3
                odd = sum(_parity(c, d)) % 2
                self._inf_imag[c, d] = bool(odd)
                self._inf[c, d] = spec.imag if odd else spec.real
                scratch.real[0] = np.where(valid, MIRROR_SIGN[d] * mir[..., c], 0.0)
                self._mir[c, d] = scratch.forward()[0] * norm3
            del inf, mir
        m = np.arange(L3)
        self._rev_index = np.mod(-m, L3)
        self._rev_phase = np.exp(-2j * np.pi * (n3 - 1) * m / L3)[:, None, None]
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
        reversed_spec = spec[:, self._rev_index] * self._rev_phase
        out = self._out3.spectrum
        acc_re = np.empty(out.shape[1:])
        acc_im = np.empty(out.shape[1:])
        for c in range(6):
            acc = out[c]
            np.multiply(self._correction[c], p_hat, out=acc)
            for d in range(6):
                acc += self._mir[c, d] * reversed_spec[d]
            acc_re[...] = 0.0
            acc_im[...] = 0.0
            for d in range(6):
                k = self._inf[c, d]
                if self._inf_imag[c, d]:  # i·k·E = k·(−Im E) + i k·Re E
                    acc_re -= k * spec[d].imag
                    acc_im += k * spec[d].real
                else:
                    acc_re += k * spec[d].real
                    acc_im += k * spec[d].imag
            acc.real += acc_re
            acc.imag += acc_im
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
    threads = int(os.environ.get("SACFLOW_FFT_THREADS", "0")) or None
    return HalfSpaceEigenstrain(shape, spacing, E, nu, threads=threads)


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
