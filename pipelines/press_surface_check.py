"""A stored press's first two layers: centre sampling, the quadrature, and finer surfaces.

``python pipelines/press_surface_check.py RUN.npz [CROP]``

RUN.npz from ``pipelines/press_run.py`` (stress sampling 1). The residual stress of its final
plastic strain from the operator with the surface traction sampled at the cells' centres, with
the quadrature of ``solver.surface_correction = "quadrature"``
(:mod:`sacflow.kernels.traction_stencil`), and from the centre-sampled operator on surfaces 3
and 5 times finer laterally (the same piecewise-uniform field; the reference). CROP cells are
dropped from each lateral side first (the plastic zone stays inside). Prints σ33 on the axis
and its minimum and the largest |σ13| of the first two layers [MPa].
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from sacflow.kernels.eigenstrain import HalfSpaceEigenstrain

E, NU = 219e9, 0.3  # the press's steel (pipelines/dent-from-indentation-press.toml)
FINER = (3, 5)


def report(label: str, stress: np.ndarray, centre: int) -> None:
    """Print the first two layers' σ33 (axis, minimum) and largest |σ13| [MPa]."""
    for k in (0, 1):
        s33 = stress[:, :, k, 2] / 1e6
        print(f"  {label} layer {k}: s33 axis {s33[centre, centre]:.0f} min {s33.min():.0f} | "
              f"s13 max {np.abs(stress[:, :, k, 4]).max() / 1e6:.0f}")


def main(argv: list[str]) -> None:
    """Compare the three residual stresses of a stored plastic strain (module notes)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path, help="RUN.npz written by pipelines/press_run.py")
    parser.add_argument("crop", type=int, nargs="?", default=0, help="cells dropped per side")
    args = parser.parse_args(argv)
    if not args.run.is_file():
        parser.error(f"{args.run} is not a file: run pipelines/press_run.py first")
    data = np.load(args.run)
    eps, x1, x3 = data["eps"], data["x1"], data["x3"]
    keep = slice(args.crop, eps.shape[0] - args.crop)
    if np.abs(eps[keep, keep]).max() != np.abs(eps).max():
        parser.error("the crop cuts the plastic zone: crop fewer cells")
    eps, x1 = eps[keep, keep], x1[keep]
    d1, d3 = float(x1[1] - x1[0]), float(x3[1] - x3[0])
    shape, centre = eps.shape[:3], int(np.argmin(np.abs(x1)))
    report("centre", HalfSpaceEigenstrain(shape, (d1, d1, d3), E, NU).residual_stress(eps),
           centre)
    report("quadrature", HalfSpaceEigenstrain(shape, (d1, d1, d3), E, NU,
                                              traction_quadrature=True).residual_stress(eps),
           centre)
    for f in FINER:
        start = time.time()
        fine_eps = np.repeat(np.repeat(eps, f, 0), f, 1)
        fine = HalfSpaceEigenstrain(fine_eps.shape[:3], (d1 / f, d1 / f, d3), E,
                                    NU).residual_stress(fine_eps)[f // 2::f, f // 2::f]
        report(f"{f} x finer surface", fine, centre)
        print(f"    ({time.time() - start:.0f} s)")


if __name__ == "__main__":
    main(sys.argv[1:])
