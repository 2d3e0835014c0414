"""Run the indentation press (600 N) on nx² × nz cells over the shipped box depth.

``python pipelines/press_run.py NX NZ SAMPLING [OVERRIDE ...]``

SAMPLING is ``SolverSettings.stress_sampling`` (1: stresses at the cell centres, as shipped;
2 or more: cell means). Prints the run time, print depth, largest εp, peak pressure, the
residual σ33 and εp on the axis (first 20 layers) and the first layer's σ33 (axis, minimum)
and writes the final fields to /tmp/press/run_<tag>.npz.
"""

from __future__ import annotations

import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

from sacflow.config.solver_inputs import solver_inputs
from sacflow.solver.simulation import Simulation
from sacflow.studies.convergence import STUDY_CASES, base_case, shipped_discretisation

CASE = STUDY_CASES["dent-from-indentation-press"]


def main(argv: list[str]) -> None:
    """Run one grid and print its numbers."""
    nx, nz, sampling = int(argv[0]), int(argv[1]), int(argv[2])
    extra = argv[3:]
    depth = shipped_discretisation(base_case(CASE)).depth
    case = base_case(CASE, [f"grid.nx={nx}", f"grid.ny={nx}", f"grid.nz={nz}",
                            f"grid.depth={depth!r}", *extra])
    start = time.time()
    inputs = solver_inputs(case)
    settings = dataclasses.replace(inputs.settings, stress_sampling=sampling)
    sim = Simulation(dataclasses.replace(inputs, settings=settings))
    setup = time.time() - start
    states = list(sim.run())
    elapsed = time.time() - start
    residual = states[-1].volume["residual_stress"]
    x1, x2, x3 = sim.coords.x1, sim.coords.x2, sim.coords.x3
    i, j = int(np.argmin(np.abs(x1))), int(np.argmin(np.abs(x2)))
    ep = sim.equivalent_plastic_strain
    u = states[-1].surface["residual_displacement"]
    tag = (f"{nx}x{nz}_s{sampling}"
           + "".join("_" + e.replace("=", "-") for e in extra))
    Path("/tmp/press").mkdir(exist_ok=True)
    np.savez(f"/tmp/press/run_{tag}.npz", res=residual, ep=ep, x1=x1, x2=x2, x3=x3, u=u,
             eps=states[-1].volume["plastic_strain"])
    converged = all(s.scalars().get("converged", True) for s in states)
    peak = max(s.max_pressure for s in states)
    print(f"{tag}: {elapsed:.0f} s (set-up {setup:.0f} s), converged {converged}, print depth "
          f"{u.max() * 1e6:.3f} um, max ep {ep.max() * 100:.2f} %, peak p {peak / 1e9:.3f} GPa, "
          f"dx/dz {(x1[1] - x1[0]) / (x3[1] - x3[0]):.2f}")
    print("  s33 axis [MPa]:", np.round(residual[i, j, :20, 2] / 1e6))
    print("  ep axis [%]:", np.round(ep[i, j, :20] * 100, 2))
    first = residual[:, :, 0, 2]
    r = np.hypot(*np.meshgrid(x1, x2, indexing="ij"))[np.unravel_index(np.argmin(first),
                                                                        first.shape)]
    print(f"  first layer ({x3[0] * 1e6:.1f} um): s33 min {first.min() / 1e6:.0f} MPa at "
          f"r = {r * 1e6:.0f} um, max {first.max() / 1e6:.0f} MPa; axis "
          f"{residual[i, j, 0, 2] / 1e6:.0f} MPa")


if __name__ == "__main__":
    main(sys.argv[1:])
