"""Where a sliding Hertz contact yields first, against the friction coefficient.

    python pipelines/friction_report.py [--cells 128] [--layers 64] [--mu 0 0.25 0.3 0.35 0.5]

Runs ``configs/sliding-hertz.toml`` (elastic steel ball on an elastic steel flat, Hertz
pressure with a shear traction q = μ p along +x1) once per μ on a window of ±1.25 a with
``--cells`` cells per side and ``--layers`` cuboid layers down to 1 a, and prints, per μ, the
largest von Mises stress over p0 of the cell centres, where it sits (x1/a: + is the leading
side, towards which the traction pulls the surface; depth/a, the first layer being at
0.5/layers), and the first-yield load p0/k = √3 p0/σ_vM,max (k the yield stress in shear, von
Mises), and the largest von Mises stress of the first layer (the surface as the grid sees it)
and its x1/a. One JSON line per μ. (The surface itself is not a cell centre: the tensile stress at
the trailing edge is checked against its closed form in ``tests/test_friction.py``.)
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

from sacflow.config.solver_inputs import simulation_for
from sacflow.solver.history import light_history
from sacflow.storage.case_file import load_case

CASE = Path(__file__).resolve().parents[1] / "configs" / "sliding-hertz.toml"
#: Half-width of the window and depth of the box, in contact radii.
HALF_WIDTH, DEPTH = 1.25, 1.0
#: Cells within this relative distance of the largest value tie with it: the mirror cells of a
#: field symmetric about the load's axis (μ = 0) differ only by rounding, which differs from one
#: processor to another.
TIE = 1e-9


def where_largest(values: np.ndarray, *coords: np.ndarray) -> tuple[float, ...]:
    """Position of the largest of ``values`` (one coordinate array per axis).

    Cells that tie with it (:data:`TIE`) are averaged: a maximum shared by mirror cells is read
    on the mirror plane between them, not in whichever cell rounding made the larger.
    """
    tied = np.nonzero(values >= values.max() * (1.0 - TIE))
    return tuple(float(np.mean(c[index])) for c, index in zip(coords, tied, strict=True))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cells", type=int, default=128)
    parser.add_argument("--layers", type=int, default=64)
    parser.add_argument("--mu", type=float, nargs="+", default=[0.0, 0.25, 0.3, 0.35, 0.5])
    args = parser.parse_args(argv)
    for mu in args.mu:
        print(json.dumps(report(mu, args.cells, args.layers)))
    return 0


def report(mu: float, cells: int, layers: int) -> dict[str, float]:
    """The numbers of the module docstring for one friction coefficient."""
    a = load_case(CASE).hertz().a
    case = load_case(CASE, [f"friction.coefficient={mu}", f"grid.nx={cells}",
                            f"grid.ny={cells}", f"grid.nz={layers}",
                            f"grid.half_width={HALF_WIDTH}", f"grid.depth={DEPTH * a!r}"])
    sim = simulation_for(case)
    state = light_history(sim.run())[-1]
    p0 = sim.hertz.p0
    vm = state.volume["von_mises"] / p0
    c = sim.coords
    x1, x2, x3 = where_largest(vm, c.x1, c.x2, c.x3)
    vm_max = float(vm.max())
    top = vm[..., 0]  # the first layer, 0.5/layers deep: the surface as the grid sees it
    top_x1, _ = where_largest(top, c.x1, c.x2)
    return {"mu": mu, "cells": cells, "layers": layers, "von_mises_max_over_p0": vm_max,
            "x1_over_a": x1 / a, "x2_over_a": x2 / a,
            "depth_over_a": x3 / a, "first_yield_p0_over_k": math.sqrt(3) / vm_max,
            "first_layer_max_over_p0": float(top.max()), "first_layer_x1_over_a": top_x1 / a,
            "first_layer_depth_over_a": float(c.x3[0] / a)}


if __name__ == "__main__":
    sys.exit(main())
