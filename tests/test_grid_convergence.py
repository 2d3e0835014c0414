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
from sacflow.config.solver_inputs import simulation_for
from sacflow.storage.case_file import load_case

CONFIG = Path(__file__).parent.parent / "configs" / "nanoindentation-190mN.toml"
GRIDS = ((48, 18), (72, 27), (108, 40))


def results(nx: int, nz: int) -> dict[str, float]:
    case = load_case(CONFIG, [f"grid.nx={nx}", f"grid.ny={nx}", f"grid.nz={nz}"])
    sim = simulation_for(case)
    states = list(sim.run())
    top = int(np.argmax([s.load for s in states]))
    peak, where = refined_peak(sim.equivalent_plastic_strain,
                               (sim.coords.x1, sim.coords.x2, sim.coords.x3))
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


#: Grids doubling the cell count per direction (layers nested: same automatic box depth).
DOUBLING = ((16, 6), (32, 12), (64, 24))


def coarse_results(nx: int, nz: int) -> dict[str, float]:
    """``nanoindentation-190mN`` loaded in 2 increments and unloaded in 1, on nx² × nz cells."""
    case = load_case(CONFIG, [f"grid.nx={nx}", f"grid.ny={nx}", f"grid.nz={nz}",
                              "load_path.0.increments=2", "load_path.1.increments=1"])
    sim = simulation_for(case)
    *_, last = sim.run()
    return {"max_plastic_strain": float(sim.equivalent_plastic_strain.max()),
            "print_depth": float(last.surface["residual_displacement"].max())}


@pytest.mark.slow
def test_observed_order_of_convergence():
    """Richardson's observed order p = log2((f_2h − f_4h) / (f_h − f_2h)) on three grids of
    ratio 2 (16, 32, 64 cells across, layers nested; about 35 s: slow).

    The print depth, an integral of the plastic strain, converges at the operators' formal
    order 2 (every operator samples piecewise-constant fields at cell centres, a midpoint
    rule): asserted 1.5 <= p <= 3, three grids giving one estimate with its pre-asymptotic
    drift. The cell maximum of εp is a sample, not an integral: where the peak sits between
    layer centres it converges at first order (the convergence study, docs/convergence.md,
    measures p = 1.05 for it under layer refinement at 650 mN): asserted p >= 1 and a shrinking
    change. Measured on this project's machine with the step-doubled return: max εp
    0.6154 / 0.6341 / 0.6415 %, p = 1.34; print depth 10.80 / 12.49 / 12.77 nm, p = 2.55
    (with one backward-Euler step per increment: 0.6131 / 0.6374 / 0.6444 %, p = 1.80, and
    10.65 / 12.26 / 12.53 nm, p = 2.55).
    """
    runs = [coarse_results(nx, nz) for nx, nz in DOUBLING]
    lowest = {"print_depth": 1.5, "max_plastic_strain": 1.0}
    for name in runs[0]:
        coarse, medium, fine = (r[name] for r in runs)
        assert (medium - coarse) * (fine - medium) > 0, f"{name} not monotone: {runs}"
        order = np.log2((medium - coarse) / (fine - medium))
        assert lowest[name] <= order <= 3.0, f"{name}: observed order {order:.2f}, {runs}"


#: The perfectly plastic case of the convergence study: the 650 mN indentation with the Swift
#: law's initial yield stress and no hardening.
PERFECT = ["body.hardening={law = \"perfectly_plastic\", yield_stress = 1655682245.9028928}"]


@pytest.mark.slow
def test_perfect_plasticity_converges_with_cell_averaged_stresses():
    """Without hardening nothing offsets a mode that centre-sampled stresses give a negative
    energy; with the cell mean (``solver.stress_sampling = 2``) the operator is energy-consistent
    and the print depth converges at the formal order: asserted monotone with
    1.5 <= p <= 3 on the three doubling grids (2 + 1 increments). Measured on this project's
    machine: 144.58 / 163.80 / 168.92 nm, p = 1.91 (about 15 s). Centre values give p = 1.97
    on these coarse grids (144.34 / 164.06 / 169.11 nm): their spurious mode shows at finer
    layers (the 48-layer level of the convergence study does not finish), not here."""
    config = CONFIG.parent / "nanoindentation-650mN.toml"
    depths = []
    for nx, nz in DOUBLING:
        case = load_case(config, [*PERFECT, f"grid.nx={nx}", f"grid.ny={nx}", f"grid.nz={nz}",
                                  "load_path.0.increments=2", "load_path.1.increments=1",
                                  "solver.stress_sampling=2"])
        *_, last = simulation_for(case).run()
        depths.append(float(last.surface["residual_displacement"].max()))
    coarse, medium, fine = depths
    assert (medium - coarse) * (fine - medium) > 0, f"not monotone: {depths}"
    order = np.log2((medium - coarse) / (fine - medium))
    assert 1.5 <= order <= 3.0, f"observed order {order:.2f}: {depths}"
