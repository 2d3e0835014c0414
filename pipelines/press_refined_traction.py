"""A press's final plastic strain: its residual stress on the grid and on a laterally finer one.

``python pipelines/press_refined_traction.py RUN.npz FACTOR [CROP]``

RUN.npz from ``pipelines/press_run.py`` at stress sampling 1. The same piecewise-uniform
plastic strain (each cell split into FACTOR × FACTOR laterally, FACTOR odd so the coarse
centres are fine centres; the layers unchanged) gives on the finer grid the same centre
stresses except for the surface traction that the half-space correction removes: sampled at
the centres of finer surface cells and applied uniformly over each. CROP cells are dropped
from each lateral side first (the plastic zone stays inside).
Prints the first layers' largest difference and the first layer's residual σ33 on the axis and
at its minimum.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from sacflow.kernels.eigenstrain import HalfSpaceEigenstrain

E, NU = 219e9, 0.3  # the press's steel (pipelines/dent-from-indentation-press.toml)


def load_press(path: Path, crop: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return the final plastic strain, x1 and x3 of RUN.npz, ``crop`` cells off each side.

    Raises ValueError with a one-line reason: not a run of ``pipelines/press_run.py``, or a
    crop that is negative or cuts the plastic zone.
    """
    try:
        with np.load(path) as data:
            eps, x1, x3 = data["eps"], data["x1"], data["x3"]
    except (OSError, ValueError, KeyError) as exc:
        raise ValueError(f"{path} is not a run written by pipelines/press_run.py ({exc})") from None
    n1 = eps.shape[0]
    if crop < 0 or 2 * crop >= n1:
        raise ValueError(f"crop must be from 0 to {(n1 - 1) // 2} cells, got {crop}")
    keep = slice(crop, n1 - crop)
    if np.abs(eps[keep, keep]).max() != np.abs(eps).max():
        raise ValueError(f"a crop of {crop} cells cuts the plastic zone: crop fewer")
    return eps[keep, keep], x1[keep], x3


def finer_surface_stress(eps: np.ndarray, spacing: tuple[float, float, float],
                         factor: int) -> np.ndarray:
    """Residual stress of ``eps`` at its cells' centres, computed on a ``factor`` finer surface.

    Each cell split ``factor`` × ``factor`` laterally (odd: the coarse centres are fine
    centres), the layers unchanged: the same piecewise-uniform field, the traction sampled at the
    finer cells' centres (the reference of the surface correction).
    """
    fine_eps = np.repeat(np.repeat(eps, factor, 0), factor, 1)
    fine = HalfSpaceEigenstrain(fine_eps.shape[:3], (spacing[0] / factor, spacing[1] / factor,
                                                     spacing[2]), E, NU, threads=1)
    return fine.residual_stress(fine_eps)[factor // 2::factor, factor // 2::factor]


def main(argv: list[str]) -> None:
    """Compare the coarse and the refined residual stress of a stored plastic strain."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path, help="RUN.npz written by pipelines/press_run.py")
    parser.add_argument("factor", type=int, help="lateral refinement (odd)")
    parser.add_argument("crop", type=int, nargs="?", default=0, help="cells dropped per side")
    args = parser.parse_args(argv)
    if not args.run.is_file():
        parser.error(f"{args.run} is not a file: run pipelines/press_run.py first")
    if args.factor < 1 or args.factor % 2 == 0:
        parser.error("factor must be an odd whole number >= 1 (coarse centres stay fine centres)")
    factor = args.factor
    try:
        eps, x1, x3 = load_press(args.run, args.crop)
    except ValueError as exc:
        parser.error(str(exc))
    d1, d3 = float(x1[1] - x1[0]), float(x3[1] - x3[0])
    shape = eps.shape[:3]
    coarse = HalfSpaceEigenstrain(shape, (d1, d1, d3), E, NU, threads=1).residual_stress(eps)
    fine = finer_surface_stress(eps, (d1, d1, d3), factor)
    centre = int(np.argmin(np.abs(x1)))
    for k in range(min(3, shape[2])):
        diff = np.abs(coarse[:, :, k] - fine[:, :, k]).max(axis=(0, 1)) / 1e6
        print(f"layer {k} ({x3[k] * 1e6:.1f} um): max |coarse - fine| per component [MPa] "
              f"{np.round(diff)}")
    for name, field in (("coarse", coarse), (f"fine x{factor}", fine)):
        first = field[:, :, 0, 2]
        print(f"  {name}: first-layer s33 axis {field[centre, centre, 0, 2] / 1e6:.0f} MPa, "
              f"min {first.min() / 1e6:.0f} MPa")


if __name__ == "__main__":
    main(sys.argv[1:])
