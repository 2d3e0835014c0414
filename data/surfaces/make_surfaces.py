"""Write the small SYNTHETIC height maps of this folder (none of them is measured).

    python data/surfaces/make_surfaces.py [OUT_DIR]      (default: this folder)

Each file is a text surface as sacflow reads it (``[surface] kind = "measured"``, format
``text``): three columns x1 x2 height [m], one grid point per line, ``#`` header lines saying
that the surface is synthetic and how it was made. Heights are positive where the surface is
higher (a dent is negative). Text with fixed formatting, so that the files are reproduced byte
for byte (``tests/test_data_folder.py`` checks it).

* ``dent-cap.txt``: a spherical-cap dent, depth 2 µm, radius 60 µm, on 48 x 48 points 5 µm apart;
* ``dent-rims.txt``: the dent profile of Jacq et al. (2002), eq. 27, A cos(2π r/w)
  exp(−13 r²/w²) with A = 2 µm, w = 120 µm: a hollow with a low rim around it (same grid);
* ``roughness.txt``: Gaussian random heights, RMS 0.1 µm, Gaussian autocorrelation of length
  10 µm (filtered white noise, numpy's PCG64 generator, seed 20261125), on 32 x 32 points 2.5 µm
  apart.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
SEED = 20261125


def _grid(n: int, step: float) -> tuple[np.ndarray, np.ndarray]:
    x = (np.arange(n) - (n - 1) / 2.0) * step
    return np.meshgrid(x, x, indexing="ij")


def dent_cap(depth: float = 2e-6, radius: float = 60e-6) -> tuple[np.ndarray, ...]:
    """Return a spherical cap of the given depth and footprint radius, pressed in."""
    x1, x2 = _grid(48, 5e-6)
    r2 = x1**2 + x2**2
    sphere = (radius**2 + depth**2) / (2.0 * depth)  # radius of the sphere through the rim
    height = np.where(r2 < radius**2, -(np.sqrt(sphere**2 - r2) - (sphere - depth)), 0.0)
    return x1, x2, height


def dent_rims(amplitude: float = 2e-6, width: float = 120e-6,
              decay: float = 13.0) -> tuple[np.ndarray, ...]:
    """Return the seed's dent profile: a hollow of depth ``amplitude``, a low rim."""
    x1, x2 = _grid(48, 5e-6)
    r = np.hypot(x1, x2)
    height = -amplitude * np.cos(2.0 * np.pi * r / width) * np.exp(-decay * r**2 / width**2)
    return x1, x2, height


def roughness(rms: float = 0.1e-6, length: float = 10e-6) -> tuple[np.ndarray, ...]:
    """Return Gaussian random heights with a Gaussian autocorrelation (filtered noise)."""
    n, step = 32, 2.5e-6
    x1, x2 = _grid(n, step)
    noise = np.random.Generator(np.random.PCG64(SEED)).standard_normal((n, n))
    k = 2.0 * np.pi * np.fft.fftfreq(n, d=step)
    k1, k2 = np.meshgrid(k, k, indexing="ij")
    # filter exp(−k² l²/8): its square is the spectrum of exp(−r²/l²) autocorrelation
    filtered = np.fft.ifft2(np.fft.fft2(noise) * np.exp(-(k1**2 + k2**2) * length**2 / 8.0)).real
    filtered -= filtered.mean()
    return x1, x2, filtered * (rms / filtered.std())


SURFACES = {
    "dent-cap.txt": (dent_cap, "spherical-cap dent, depth 2 um, footprint radius 60 um"),
    "dent-rims.txt": (dent_rims, "A cos(2 pi r/w) exp(-13 r^2/w^2), A = 2 um, w = 120 um"),
    "roughness.txt": (roughness, f"Gaussian heights, RMS 0.1 um, correlation 10 um, seed {SEED}"),
}


def write(out: Path) -> list[Path]:
    """Write every surface into ``out``; return the files."""
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for name, (make, what) in SURFACES.items():
        x1, x2, height = make()
        lines = [
            "# SYNTHETIC surface, not measured: made by data/surfaces/make_surfaces.py",
            f"# {what}",
            f"# {x1.shape[0]} x {x1.shape[1]} points; columns: x1 [m] x2 [m] height [m]",
        ]
        lines += [f"{a:.6e} {b:.6e} {h:.9e}" for a, b, h in
                  zip(x1.ravel(), x2.ravel(), height.ravel(), strict=True)]
        path = out / name
        path.write_text("\n".join(lines) + "\n")
        written.append(path)
    return written


if __name__ == "__main__":
    for path in write(Path(sys.argv[1]) if len(sys.argv) > 1 else HERE):
        print(path)
