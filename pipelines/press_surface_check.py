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
from press_refined_traction import NU, E, finer_surface_stress, load_press

from sacflow.kernels.eigenstrain import HalfSpaceEigenstrain

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
    try:
        eps, x1, x3 = load_press(args.run, args.crop)
    except ValueError as exc:
        parser.error(str(exc))
    d1, d3 = float(x1[1] - x1[0]), float(x3[1] - x3[0])
    shape, centre = eps.shape[:3], int(np.argmin(np.abs(x1)))
    report("centre", HalfSpaceEigenstrain(shape, (d1, d1, d3), E, NU).residual_stress(eps),
           centre)
    report("quadrature", HalfSpaceEigenstrain(shape, (d1, d1, d3), E, NU,
                                              traction_quadrature=True).residual_stress(eps),
           centre)
    for f in FINER:
        start = time.time()
        report(f"{f} x finer surface", finer_surface_stress(eps, (d1, d1, d3), f), centre)
        print(f"    ({time.time() - start:.0f} s)")


if __name__ == "__main__":
    main(sys.argv[1:])
