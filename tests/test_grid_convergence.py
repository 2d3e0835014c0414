"""Grid convergence of the nano-indentation results (issue: three grids, differences shrink).

``nanoindentation-190mN`` at 48², 72² and 108² surface cells (ratio 1.5; 18, 27 and 40 layers
over the same automatic box depth): the maximum equivalent plastic strain (refined below the
cell size, :func:`sacflow.compare.fields.refined_peak`), its depth, the residual print depth and
the approach at maximum load must each change less between the two finer grids than between the
two coarser ones. Measured on this project's machine: max εp 0.6404 / 0.6437 / 0.6440 %, its
depth 2.126 / 2.112 / 2.109 µm (the raw cell maximum, 0.6343 / 0.6423 / 0.6435 %, converges too,
but its depth jumps between layer centres). About three minutes: marked slow.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sacflow.compare.fields import refined_peak
from sacflow.config import load_case
from sacflow.solver import Simulation

CONFIG = Path(__file__).parent.parent / "configs" / "nanoindentation-190mN.toml"
GRIDS = ((48, 18), (72, 27), (108, 40))


def results(nx: int, nz: int) -> dict[str, float]:
    case = load_case(CONFIG, [f"grid.nx={nx}", f"grid.ny={nx}", f"grid.nz={nz}"])
    sim = Simulation(case)
    states = list(sim.run())
    top = int(np.argmax([s.load for s in states]))
    peak, where = refined_peak(sim.eqps, (sim.coords.x1, sim.coords.x2, sim.coords.x3))
    return {
        "max_plastic_strain": peak,
        "max_plastic_strain_depth": where[2],
        "print_depth": float(states[-1].surface["residual_displacement"].max()),
        "approach_at_max_load": states[top].approach,
    }


@pytest.mark.slow
def test_nanoindentation_results_converge_under_refinement():
    runs = [results(nx, nz) for nx, nz in GRIDS]
    report = {k: [r[k] for r in runs] for k in runs[0]}
    for name, (coarse, medium, fine) in report.items():
        assert abs(fine - medium) < abs(medium - coarse), f"{name} does not converge: {report}"
