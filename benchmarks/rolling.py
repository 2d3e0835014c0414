"""Transient rolling over a smooth elastic-plastic flat (configs/rolling-smooth.toml).

Runs the case at the seed's resolution (24 × 24 surface cells, 11 cuboid layers, 170 rolling
steps; the cuboid box covers the whole rolled track) and at twice the resolution in each
direction (48 × 48 cells, 22 layers, 340 rolling steps). Prints JSON: wall time, time per
step, residual-stress applications and contact iterations per step, peak memory.

Usage: ``python benchmarks/rolling.py [--single] [--traction-beyond-box]`` (``--single``: seed
resolution only; ``--traction-beyond-box``: with ``solver.traction_beyond_box = true``, the
surface traction beyond the box removed by a second, coarse operator).
"""

from __future__ import annotations

import sys
import time

from _common import ROOT, emit, isolated


def measure(factor: int, beyond_box: bool = False) -> dict:
    import numpy as np

    from sacflow.config.solver_inputs import simulation_for
    from sacflow.storage.case_file import load_case

    overrides = [f"solver.traction_beyond_box={str(beyond_box).lower()}"]
    if factor > 1:
        overrides += [f"grid.nx={24 * factor}", f"grid.ny={24 * factor}",
                     f"grid.nz={11 * factor}", f"load_path.1.steps={170 * factor}"]
    case = load_case(ROOT / "configs/rolling-smooth.toml", overrides)
    t0 = time.perf_counter()
    sim = simulation_for(case)
    setup = time.perf_counter() - t0
    t0 = time.perf_counter()
    per_step = []
    for state in sim.run():
        per_step.append((state.plasticity_iterations, state.contact_iterations))
    wall = time.perf_counter() - t0
    apps = np.array([p for p, _ in per_step])
    return {
        "resolution": f"x{factor}",
        "traction_beyond_box": beyond_box,
        "surface_cells": f"{case.grid.nx}x{case.grid.ny}",
        "cuboid_box": "x".join(str(v) for v in sim.equivalent_plastic_strain.shape),
        "steps": len(per_step),
        "setup_s": round(setup, 3),
        "run_s": round(wall, 3),
        "time_per_step_s": round(wall / len(per_step), 4),
        "residual_stress_applications_per_step_mean": float(apps.mean()),
        "residual_stress_applications_per_step_max": int(apps.max()),
        "contact_iterations_per_step_mean": float(np.mean([c for _, c in per_step])),
        "max_equivalent_plastic_strain": float(sim.equivalent_plastic_strain.max()),
        "max_residual_displacement_m": float(sim.residual_displacement.max()),
    }


if __name__ == "__main__":
    factors = [1] if "--single" in sys.argv else [1, 2]
    beyond = "--traction-beyond-box" in sys.argv
    emit("rolling", [isolated(measure, f, beyond) for f in factors])
