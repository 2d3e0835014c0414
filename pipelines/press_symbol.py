"""Energy of the eigenstrain operator's Fourier modes in infinite space, per cell aspect ratio.

``python pipelines/press_symbol.py L SAMPLING RATIO [RATIO ...]``

The stress at the cell centres (SAMPLING 1) or averaged over SAMPLING³ sub-cell centres of the
target cell, of a unit cuboid (Chiu's closed form), at the offsets of an L³ lattice (cells
dx × dx × 1 with dx = RATIO); its lattice Fourier transform K(k) = −W Ŝ(k) / 2μ is the energy
per unit ε:ε of the mode exp(i k·x) ε. Prints the smallest over k of the energy of the axial
compression n = (1, 1, −2)/√6 (the plastic core under an indenter), its value at the 3-D
checkerboard k = (π/dx, π/dx, π/dz), and the hardening modulus below which that mode softens
the J2 plastic problem (3/2 · 2μ · |min|).
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from sacflow.kernels.cell_average import sub_points
from sacflow.kernels.cuboid import SHEAR_WEIGHTS, cuboid_stress

E, NU = 219e9, 0.3
MU = E / (2 * (1 + NU))
COMPRESSION = np.array([1.0, 1.0, -2.0, 0.0, 0.0, 0.0]) / np.sqrt(6.0)


def mode_energy(size: int, sampling: int, ratio: float) -> np.ndarray:
    """n:K(k):n of the compression on the size³ lattice of wave vectors."""
    spacing = (ratio, ratio, 1.0)
    offsets = np.fft.fftfreq(size) * size
    kernel = np.zeros((size, size, size, 6, 6))
    for point in sub_points(sampling, spacing):
        x = [(offsets + p / d) * d for p, d in zip(point, spacing, strict=True)]
        grid = (x[0][:, None, None], x[1][None, :, None], x[2][None, None, :])
        kernel += np.broadcast_to(cuboid_stress(*grid, *(d / 2 for d in spacing), NU, MU),
                                  kernel.shape)
    kernel /= sampling ** 3
    spectrum = np.fft.fftn(kernel, axes=(0, 1, 2)).real
    energy = -(SHEAR_WEIGHTS[:, None] * spectrum) / (2 * MU)
    result: np.ndarray = np.einsum("c,...cd,d->...", COMPRESSION, energy, COMPRESSION)
    return result


def main(argv: list[str]) -> None:
    """Print the compression mode's energies for each aspect ratio."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("size", type=int, help="lattice points per axis")
    parser.add_argument("sampling", type=int, help="points per axis of the cell mean (1 = centre)")
    parser.add_argument("ratios", type=float, nargs="+", help="cell aspect ratios dx/dz")
    args = parser.parse_args(argv)
    size, sampling, ratios = args.size, args.sampling, args.ratios
    half = size // 2
    for ratio in ratios:
        nn = mode_energy(size, sampling, ratio)
        threshold = -1.5 * 2 * MU * min(float(nn.min()), 0.0)
        print(f"s={sampling} dx/dz={ratio}: min n:K:n {nn.min():+.4f}, checkerboard "
              f"{nn[half, half, half]:+.4f}, softening below H = {threshold / 1e9:.2f} GPa")


if __name__ == "__main__":
    main(sys.argv[1:])
