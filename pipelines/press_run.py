"""Run the indentation press (600 N) on nx² × nz cells over the shipped box depth.

``python pipelines/press_run.py NX NZ SAMPLING [OVERRIDE ...] [--out DIR]``

SAMPLING is ``solver.stress_sampling`` (1: stresses at the cell centres; 2 or more: cell
means, as the press ships since issue #32). The increments are the 10 + 3 of the study's base
(those of ``notes/press-near-surface.md``; an override ``load_path.0.increments=20`` changes
them), and the surface traction beyond the box is left out as it was there (an override
``solver.traction_beyond_box=true`` removes it, as the press ships since), and so is the
contact on the surface cells (``solver.contact_subcells=2``: on sub-cells, as it ships
since). Prints the run
time, print depth, largest εp, peak pressure, the residual σ33 and εp on the axis (first 20
layers) and the first layer's σ33 (axis, minimum) and writes the final fields to
DIR/run_<tag>.npz (default DIR: runs/press-near-surface); a file already there is kept, and
the run refused.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from sacflow.config.solver_inputs import solver_inputs
from sacflow.errors import InputError
from sacflow.solver.history import light_history
from sacflow.solver.simulation import Simulation
from sacflow.studies.convergence import (
    STUDY_CASES,
    WITHOUT_FAR_TRACTION,
    WITHOUT_SUBCELLS,
    base_case,
    base_increments_overrides,
    shipped_discretisation,
)

CASE = STUDY_CASES["dent-from-indentation-press"]


def main(argv: list[str]) -> None:
    """Run one grid and print its numbers."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("nx", type=int, help="lateral cells per side")
    parser.add_argument("nz", type=int, help="layers")
    parser.add_argument("sampling", type=int, help="solver.stress_sampling (1 = centre)")
    parser.add_argument("extra", nargs="*", help="further overrides KEY=VALUE")
    parser.add_argument("--out", type=Path, default=Path("runs/press-near-surface"))
    args = parser.parse_args(argv)
    nx, nz, sampling, extra = args.nx, args.nz, args.sampling, args.extra
    tag = (f"{nx}x{nz}_s{sampling}"
           + "".join("_" + e.replace("=", "-") for e in extra))
    target = args.out / f"run_{tag}.npz"
    if target.exists():
        sys.exit(f"{target} exists: kept; remove it or pass another --out to run again")
    try:
        depth = shipped_discretisation(base_case(CASE)).depth
        case = base_case(CASE, [f"grid.nx={nx}", f"grid.ny={nx}", f"grid.nz={nz}",
                                f"grid.depth={depth!r}", f"solver.stress_sampling={sampling}",
                                *base_increments_overrides(CASE), WITHOUT_FAR_TRACTION,
                                WITHOUT_SUBCELLS, *extra])
    except InputError as exc:
        sys.exit(str(exc))
    start = time.time()
    sim = Simulation(solver_inputs(case))
    setup = time.time() - start
    states = light_history(sim.run())
    elapsed = time.time() - start
    residual = states[-1].volume["residual_stress"]
    x1, x2, x3 = sim.coords.x1, sim.coords.x2, sim.coords.x3
    i, j = int(np.argmin(np.abs(x1))), int(np.argmin(np.abs(x2)))
    ep = sim.equivalent_plastic_strain
    u = states[-1].surface["residual_displacement"]
    args.out.mkdir(parents=True, exist_ok=True)
    np.savez(target, res=residual, ep=ep, x1=x1, x2=x2, x3=x3, u=u,
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
