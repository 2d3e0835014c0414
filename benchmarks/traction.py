"""Cost of a surface shear traction: the seed's rolling case with and without it.

Runs ``configs/rolling-smooth.toml`` and ``configs/rolling-smooth-traction.toml`` (the same case
with a traction coefficient of 0.2) alternately, each in a fresh process, ``--repeat`` times
(default 3), and prints JSON: per run the set-up time (operators and kernel spectra), the wall
time of the whole run, the iteration counts and the peak memory; then the median ratio
traction / no traction. The traction rides on the pressure-to-stress kernel (one convolution),
so the set-up evaluates one more closed form and the steps cost what they cost without it,
apart from the plastic flow the traction adds.

Usage: ``python benchmarks/traction.py [--repeat N]``.
"""

from __future__ import annotations

import statistics
import sys
import time

from _common import ROOT, emit, isolated

CASES = ("rolling-smooth", "rolling-smooth-traction")


def run(name: str) -> dict:
    from sacflow.config.solver_inputs import simulation_for
    from sacflow.storage.case_file import load_case

    case = load_case(ROOT / "configs" / f"{name}.toml")
    t0 = time.perf_counter()
    sim = simulation_for(case)
    setup = time.perf_counter() - t0
    contact = plastic = 0
    for state in sim.run():
        contact += state.contact_iterations
        plastic += state.plasticity_iterations
    wall = time.perf_counter() - t0
    return {"case": name, "setup_s": setup, "wall_s": wall, "steps": sim.total_steps,
            "cells": [*sim.body_shape, sim.nz], "contact_iterations": contact,
            "plasticity_iterations": plastic}


def main() -> None:
    args = sys.argv[1:]
    repeat = int(args[args.index("--repeat") + 1]) if "--repeat" in args else 3
    results = [isolated(run, name) for _ in range(repeat) for name in CASES]
    walls = {name: [r["wall_s"] for r in results if r.get("case") == name] for name in CASES}
    setups = {name: [r["setup_s"] for r in results if r.get("case") == name] for name in CASES}
    ratio = statistics.median(walls[CASES[1]]) / statistics.median(walls[CASES[0]])
    results.append({"what": "median wall time ratio, traction / none", "ratio": ratio,
                    "median_wall_s": {k: statistics.median(v) for k, v in walls.items()},
                    "median_setup_s": {k: statistics.median(v) for k, v in setups.items()}})
    emit("traction", results)


if __name__ == "__main__":
    main()
