"""Cost of repeated rolling: time per pass on the seed's rolling grid.

Runs ``configs/rolling-smooth.toml`` (the seed's Fig. 18 case: 24 × 24 surface cells, 11 cuboid
layers, 170 roll steps; the cuboid box covers the whole track) with its roll segment repeated
``--passes`` times (default 4, the ball lifted between passes), once with the seed's isotropic
Swift law and once with Armstrong–Frederick kinematic hardening added (``--kinematic C,GAMMA``,
default 100e9,400: an illustrative parameter set, the one of ``configs/dent-rolling-cycles.toml``),
each in a fresh process. Prints JSON: per pass the wall time, steps, contact iterations,
plasticity sweeps (residual-stress applications) and the largest equivalent plastic strain at its
end; the ratio of each later pass's time to the first's; set-up time and peak memory.

Usage: ``python benchmarks/passes.py [--passes N] [--kinematic C,GAMMA]``.
"""

from __future__ import annotations

import sys
import time
from collections import defaultdict

from _common import ROOT, emit, isolated


def measure(passes: int, kinematic: tuple[float, float] | None) -> dict:
    from sacflow.config.solver_inputs import simulation_for
    from sacflow.storage.case_file import load_case

    overrides = [f"load_path.1.passes={passes}", "output.volume_every=100000"]
    if kinematic is not None:
        overrides += [f"body.hardening.kinematic.modulus={kinematic[0]}",
                      f"body.hardening.kinematic.recall={kinematic[1]}"]
    case = load_case(ROOT / "configs/rolling-smooth.toml", overrides)
    t0 = time.perf_counter()
    sim = simulation_for(case)
    setup = time.perf_counter() - t0
    wall: dict[int, float] = defaultdict(float)
    steps: dict[int, int] = defaultdict(int)
    contact: dict[int, int] = defaultdict(int)
    plastic: dict[int, int] = defaultdict(int)
    peak: dict[int, float] = {}
    t0 = time.perf_counter()
    for state in sim.run():
        now = time.perf_counter()
        wall[state.pass_index] += now - t0
        steps[state.pass_index] += 1
        contact[state.pass_index] += state.contact_iterations
        plastic[state.pass_index] += state.plasticity_iterations
        peak[state.pass_index] = float(sim.equivalent_plastic_strain.max())
        t0 = time.perf_counter()
    rows = [{"pass": p, "wall_s": round(wall[p], 3), "steps": steps[p],
             "contact_iterations": contact[p], "plasticity_sweeps": plastic[p],
             "max_equivalent_plastic_strain_at_end": peak[p]} for p in sorted(wall)]
    first = rows[0]["wall_s"]
    return {
        "hardening": "swift" if kinematic is None else
        f"swift + armstrong-frederick C={kinematic[0]:g} Pa, gamma={kinematic[1]:g}",
        "cuboid_box": "x".join(str(v) for v in sim.equivalent_plastic_strain.shape),
        "setup_s": round(setup, 3),
        "passes": rows,
        "later_pass_time_over_first": [round(r["wall_s"] / first, 3) for r in rows[1:]],
    }


def main() -> None:
    args = sys.argv[1:]
    passes = int(args[args.index("--passes") + 1]) if "--passes" in args else 4
    kinematic = (100e9, 400.0)
    if "--kinematic" in args:
        c, gamma = args[args.index("--kinematic") + 1].split(",")
        kinematic = (float(c), float(gamma))
    emit("passes", [isolated(measure, passes, None), isolated(measure, passes, kinematic)])


if __name__ == "__main__":
    main()
