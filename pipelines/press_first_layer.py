"""A first-layer cuboid's stress: the operator against the same field on a finer grid.

``python pipelines/press_first_layer.py RATIO``

A uniform eigenstrain (1e-3 of component 11, 33 or 13) in one first-layer cell (dx/dz = RATIO)
of a 9 × 9 × 6 box. Centre sampling against the operator on a grid 9 times finer laterally
(the coarse centres are fine centres; only the surface traction's sampling differs); the cell
mean (sampling 2) against the mean over each coarse cell of a grid 4 times finer along every
axis (sampling 2 there: 8 points per axis). Prints the largest first-layer error per stress
component [MPa per 1e-3] and the reference's largest value.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from sacflow.kernels.eigenstrain import HalfSpaceEigenstrain

E, NU = 219e9, 0.3
CELLS, LAYERS = 9, 6
CASES = (("centre", 1, 1, 1), ("centre ref", 9, 1, 1), ("mean s2", 1, 1, 2),
         ("mean ref", 4, 4, 2))


def stresses(ratio: float, source: int) -> dict[str, np.ndarray]:
    """Return the coarse cells' stresses [MPa] under each sampling."""
    c = CELLS // 2
    out = {}
    for label, f, fz, sampling in CASES:
        op = HalfSpaceEigenstrain((CELLS * f, CELLS * f, LAYERS * fz),
                                  (ratio / f, ratio / f, 1.0 / fz), E, NU, threads=1,
                                  stress_sampling=sampling)
        eps = np.zeros((CELLS * f, CELLS * f, LAYERS * fz, 6))
        eps[c * f:(c + 1) * f, c * f:(c + 1) * f, :fz, source] = 1e-3
        stress = op.residual_stress(eps)
        if label.startswith("centre"):
            stress = stress[f // 2::f, f // 2::f]
        else:
            stress = stress.reshape(CELLS, f, CELLS, f, LAYERS, fz, 6).mean(axis=(1, 3, 5))
        out[label] = stress / 1e6
    return out


def main(argv: list[str]) -> None:
    """Print the first-layer errors of both samplings for sources 11, 33 and 13."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("ratio", type=float, help="cell aspect ratio dx/dz")
    ratio = parser.parse_args(argv).ratio
    for source in (0, 2, 4):
        out = stresses(ratio, source)
        for a, b in (("centre", "centre ref"), ("mean s2", "mean ref")):
            error = np.abs(out[a][:, :, 0] - out[b][:, :, 0]).max(axis=(0, 1))
            scale = np.abs(out[b]).max(axis=(0, 1, 2))
            print(f"dx/dz={ratio} source {source}: {a:7s} error {np.round(error, 2)} "
                  f"of {np.round(scale, 1)}")


if __name__ == "__main__":
    main(sys.argv[1:])
