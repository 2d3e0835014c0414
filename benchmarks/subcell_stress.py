"""The sub-cells' pressure → stress operator, with all its kernels and folded by mirror symmetry.

Builds the operator of a contact on 2 × 2 sub-cells (``solver.contact_subcells = 2``) for the
press's body grid (``pipelines/dent-from-indentation-press.toml``: 96² × 128 cells of 7.1 µm ×
4.0 µm, cell-averaged stresses) both ways, each in a fresh process, alternately ``--repeat``
times (default 3), and prints JSON: the set-up time (kernel coefficients and spectra, the kernel
cache bypassed), the median of ``--apply`` applications (default 7) to one random sub-cell
pressure, the bytes of kernel spectra and the process's peak memory; then the medians.
``--cells N --layers M`` size another grid.

Usage: ``python benchmarks/subcell_stress.py [--repeat N] [--apply N] [--cells N] [--layers M]``.
"""

from __future__ import annotations

import statistics
import sys
import time

from _common import emit, isolated

SUBCELLS, SAMPLING, NU = 2, 2, 0.3
#: The press's cells [m]: 7.1 µm laterally (±3 Hertz radii over 96 cells), 4.0 µm deep.
CELL, LAYER = 7.067e-6, 4.007e-6
KINDS = ("all kernels", "folded")


def run(kind: str, cells: int, layers: int, applications: int) -> dict:
    import numpy as np

    from sacflow.kernels.convolution import Convolution
    from sacflow.kernels.shear import subcell_load_stress_coefficients
    from sacflow.kernels.subcell_stress import MirroredSubcellStress

    depths = (np.arange(layers) + 0.5) * LAYER
    shape = (cells, cells)
    t0 = time.perf_counter()
    if kind == "folded":
        op: Convolution = MirroredSubcellStress(
            subcell_load_stress_coefficients((CELL, CELL), SUBCELLS, depths, NU, None, SAMPLING,
                                             LAYER, only=MirroredSubcellStress.kept(SUBCELLS)),
            shape, SUBCELLS, block=6)
    else:
        op = Convolution(subcell_load_stress_coefficients((CELL, CELL), SUBCELLS, depths, NU,
                                                          None, SAMPLING, LAYER),
                         shape, shape, block=6)
    setup = time.perf_counter() - t0
    pressure = np.random.default_rng(0).uniform(0.0, 1e9, (SUBCELLS**2, *shape))
    op(pressure)  # the first application compiles the folded product (numba's disk cache)
    times = []
    for _ in range(applications):
        t0 = time.perf_counter()
        op(pressure)
        times.append(time.perf_counter() - t0)
    return {"kind": kind, "cells": [cells, cells, layers], "setup_s": setup,
            "apply_median_s": statistics.median(times), "apply_s": times,
            "spectra_mb": op.spectra.nbytes / 2**20}


def option(args: list[str], name: str, default: int) -> int:
    return int(args[args.index(name) + 1]) if name in args else default


def main() -> None:
    args = sys.argv[1:]
    repeat, applications = option(args, "--repeat", 3), option(args, "--apply", 7)
    cells, layers = option(args, "--cells", 96), option(args, "--layers", 128)
    results = [isolated(run, kind, cells, layers, applications)
               for _ in range(repeat) for kind in KINDS]
    summary = {}
    for kind in KINDS:
        mine = [r for r in results if r.get("kind") == kind]
        summary[kind] = {key: statistics.median(r[key] for r in mine)
                         for key in ("setup_s", "apply_median_s", "peak_memory_mb")}
    results.append({"what": "medians over the repeats", **summary})
    emit("subcell_stress", results)


if __name__ == "__main__":
    main()
