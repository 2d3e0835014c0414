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

E, NU = 219e9, 0.3


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
    data = np.load(args.run)
    factor, crop = args.factor, args.crop
    eps = data["eps"]
    n1 = eps.shape[0]
    keep = slice(crop, n1 - crop)
    eps = eps[keep, keep]
    x1, x3 = data["x1"][keep], data["x3"]
    assert np.abs(data["eps"]).max() == np.abs(eps).max(), "the crop cuts the plastic zone"
    d1, d3 = float(x1[1] - x1[0]), float(x3[1] - x3[0])
    shape = eps.shape[:3]
    coarse = HalfSpaceEigenstrain(shape, (d1, d1, d3), E, NU, threads=1).residual_stress(eps)
    fine_eps = np.repeat(np.repeat(eps, factor, 0), factor, 1)
    fine = HalfSpaceEigenstrain(fine_eps.shape[:3], (d1 / factor, d1 / factor, d3), E, NU,
                                threads=1).residual_stress(fine_eps)
    fine = fine[factor // 2::factor, factor // 2::factor]
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
