"""Elastic-plastic solver: one load step, mildly and strongly plastic, and a full indentation.

The single step, with the coupled scheme and with the seed's nested loops: rigid sphere
R = 105 µm on E = 210 GPa, ν = 0.3, W = 0.65 N (Hertz p0 = 8.47 GPa), loaded in one increment,
plasticity tolerance 1e-6, on n × n surface cells (±1.5 a) with an n × n × n/2 cuboid box, on
two linear-hardening materials (``_common.HARDENING``): ``mild`` (σ_Y = p0/2, H = 0.05 E) and
``strong`` (σ_Y = 1655.6 MPa, H = 21 GPa, the nano-indentation steel: a plastic zone of about
half the box). Also the same load in two increments, the second timed: an increment that starts
from a loaded state, where the step-doubled return (``solver.return_integration =
"extrapolated"``, the default) integrates the flow along the increment's path (a first
increment from rest is a straight path from zero: one return). Prints JSON, with the time per
plastic iteration and the plastic zone's share.

With ``--traction-beyond-box`` every run sets ``solver.traction_beyond_box = true`` (the
surface traction beyond the box removed by a second, coarse operator): the cost of that option.

Usage: ``python benchmarks/elastic_plastic.py [--skip-case] [--traction-beyond-box] [n ...]``
(default 32 64).
"""

from __future__ import annotations

import sys
import time

from _common import ROOT, emit, hertz_step_case, isolated


def one_step(n: int, scheme: str = "coupled", hardening: str = "mild",
             increments: int = 1, beyond_box: bool = False) -> dict:
    import numpy as np

    from sacflow.config.solver_inputs import simulation_for
    from sacflow.storage.case_file import case_from_dict

    spec = hertz_step_case(n, scheme, hardening, increments)
    spec["solver"]["traction_beyond_box"] = beyond_box
    case = case_from_dict(spec)
    t0 = time.perf_counter()
    sim = simulation_for(case)
    setup = time.perf_counter() - t0
    steps = iter(sim.run())
    for _ in range(increments - 1):  # the earlier increments, untimed
        next(steps)
    t0 = time.perf_counter()
    state = next(steps)
    wall = time.perf_counter() - t0
    cuboids = int(np.prod(sim.equivalent_plastic_strain.shape))
    plastic = int((sim.equivalent_plastic_strain > 0).sum())
    return {
        "case": (f"one load step, {hardening} hardening, box {n}x{n}x{n // 2}" if increments == 1
                 else f"last of {increments} load increments, {hardening} hardening, box "
                      f"{n}x{n}x{n // 2}"),
        "scheme": scheme,
        "hardening": hardening,
        "traction_beyond_box": beyond_box,
        "cuboids": cuboids,
        "setup_s": round(setup, 3),
        "step_s": round(wall, 3),
        "residual_stress_applications": state.plasticity_iterations,
        "step_s_per_plastic_iteration": round(wall / max(state.plasticity_iterations, 1), 4),
        "contact_iterations": state.contact_iterations,
        "plastic_cells": plastic,
        "plastic_share": round(plastic / cuboids, 4),
        "max_equivalent_plastic_strain": float(sim.equivalent_plastic_strain.max()),
        "box_depth_over_a": float(sim.dz * sim.nz / case.hertz().a),
    }


def full_case(path: str, beyond_box: bool = False) -> dict:
    import numpy as np

    from sacflow.config.solver_inputs import simulation_for
    from sacflow.storage.case_file import load_case

    case = load_case(path, [f"solver.traction_beyond_box={str(beyond_box).lower()}"])
    t0 = time.perf_counter()
    sim = simulation_for(case)
    setup = time.perf_counter() - t0
    t0 = time.perf_counter()
    iterations = [(s.plasticity_iterations, s.contact_iterations) for s in sim.run()]
    wall = time.perf_counter() - t0
    return {
        "case": case.name,
        "traction_beyond_box": beyond_box,
        "cuboids": int(np.prod(sim.equivalent_plastic_strain.shape)),
        "steps": len(iterations),
        "setup_s": round(setup, 3),
        "run_s": round(wall, 3),
        "residual_stress_applications_per_step": [i for i, _ in iterations],
        "contact_iterations_per_step": [c for _, c in iterations],
        "max_equivalent_plastic_strain": float(sim.equivalent_plastic_strain.max()),
    }


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    sizes = [int(a) for a in args] or [32, 64]
    beyond = "--traction-beyond-box" in sys.argv
    # both schemes: the single coupled fixed point against the seed's nested loops
    results = [isolated(one_step, n, scheme, hardening, 1, beyond) for n in sizes
               for hardening in ("mild", "strong") for scheme in ("coupled", "nested")]
    # the step-doubled increment (the second of two), coupled scheme
    results += [isolated(one_step, n, "coupled", hardening, 2, beyond) for n in sizes
                for hardening in ("mild", "strong")]
    if "--skip-case" not in sys.argv:
        results.append(isolated(full_case, str(ROOT / "configs/nanoindentation-650mN.toml"),
                                beyond))
    emit("elastic_plastic", results)
