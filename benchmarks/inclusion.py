"""Elastic inhomogeneity: one elastic-plastic load step with and without a stiff sphere.

The one-step case of ``elastic_plastic.py`` (rigid sphere R = 105 µm, W = 0.65 N, Hertz
p0 = 8.47 GPa, E = 210 GPa, ν = 0.3, ``mild`` linear hardening, n × n cells, n × n × n/2 box),
with and without a sphere of E_k = 380 GPa (alumina in steel), radius ``RADIUS_CELLS`` cells
(a few hundred cells) centred under the load at the depth of the largest shear, 0.48 a.
Each configuration runs ``REPEAT`` times in one fresh process (a new simulation per repeat,
the step alone timed); prints the median step times, their ratio, the iteration counts and the
pressure rise. Target of issue #33: the step with the inhomogeneity within 2× the one without.

Usage: ``python benchmarks/inclusion.py [n]`` (default 64).
"""

from __future__ import annotations

import statistics
import sys
import time

from _common import emit, hertz_step_case, isolated

#: Radius of the sphere in cells (about 270 cells at any n).
RADIUS_CELLS = 4.0
#: Depth of the sphere's centre [Hertz radii]: that of the largest shear (ν = 0.3).
DEPTH = 0.48
#: Modulus of the sphere [Pa] (alumina).
MODULUS = 380e9
#: Step runs per configuration (the median is reported).
REPEAT = 3


def one_step(n: int, with_sphere: bool) -> dict:
    from dataclasses import replace

    import numpy as np

    from sacflow.config.solver_inputs import simulation_for
    from sacflow.solver.inputs import Inhomogeneity
    from sacflow.solver.simulation import Simulation
    from sacflow.storage.case_file import case_from_dict

    case = case_from_dict(hertz_step_case(n, "coupled", "mild"))
    inputs = simulation_for(case).inputs
    a = case.hertz().a
    radius = RADIUS_CELLS * inputs.grid.cell[0]
    if with_sphere:
        sphere = Inhomogeneity("sphere", (0.0, 0.0, DEPTH * a), (radius,) * 3, MODULUS, 0.25)
        inputs = replace(inputs, inhomogeneities=(sphere,))
    times, state, sim = [], None, None
    for _ in range(REPEAT):
        sim = Simulation(inputs)
        t0 = time.perf_counter()
        state = next(iter(sim.run()))
        times.append(time.perf_counter() - t0)
    assert state is not None and sim is not None
    cells = int((state.volume["phase"] > 0).sum()) if with_sphere else 0
    return {
        "case": f"one load step, mild hardening, box {n}x{n}x{n // 2}",
        "inhomogeneity": (f"sphere E = {MODULUS / 1e9:.0f} GPa, {cells} cells, centre "
                          f"{DEPTH} a deep" if with_sphere else None),
        "step_s_median": round(statistics.median(times), 3),
        "step_s": [round(t, 3) for t in times],
        "residual_stress_applications": state.plasticity_iterations,
        "inclusion_iterations": state.inclusion_iterations,
        "contact_iterations": state.contact_iterations,
        "max_pressure_pa": state.max_pressure,
        "max_equivalent_plastic_strain": float(np.max(sim.equivalent_plastic_strain)),
        "converged": state.converged,
    }


if __name__ == "__main__":
    sizes = [int(a) for a in sys.argv[1:]] or [64]
    results = []
    for n in sizes:
        without, with_ = isolated(one_step, n, False), isolated(one_step, n, True)
        results += [without, with_]
        if "error" not in without and "error" not in with_:
            results.append({
                "n": n,
                "time_ratio_with_over_without": round(
                    with_["step_s_median"] / without["step_s_median"], 3),
                "pressure_rise": round(with_["max_pressure_pa"] / without["max_pressure_pa"]
                                       - 1.0, 4),
            })
    emit("inclusion", results)
