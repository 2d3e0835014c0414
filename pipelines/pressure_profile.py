"""The contact pressure at the largest load along x1 through the axis, for a case file.

    python pipelines/pressure_profile.py CASE.toml [KEY=VALUE ...] [--cells N]

Runs the case (with ``--set``-style overrides) and prints, as JSON, the step of the largest
pressure, the cell holding it and the pressure [GPa] of the ``--cells`` cells nearest the axis
along x1 on the side x1 > 0, in the row of cells nearest x2 = 0 (default: out to the contact
edge). ``docs/convergence.md`` reads the linear-hardening nano-indentation's ring of maxima off
it: with centre-sampled stresses its pressure zigzags from cell to cell, with the cell mean
(``solver.stress_sampling=2``) it does not.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

GPA = 1e9


def parse(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("case", type=Path, help="a case file (TOML)")
    parser.add_argument("overrides", nargs="*", help="KEY=VALUE overrides, as sacflow run --set")
    parser.add_argument("--cells", type=int, default=0,
                        help="cells printed from the axis outwards (default: to the contact edge)")
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse(argv)
    from sacflow.config.solver_inputs import simulation_for
    from sacflow.errors import SacflowError
    from sacflow.solver.history import light_history
    from sacflow.storage.case_file import load_case
    from sacflow.studies.pressure_profile import row_profile

    if args.cells < 0:
        print(f"error: --cells must be 0 (to the contact edge) or more, not {args.cells}",
              file=sys.stderr)
        return 2
    try:
        case = load_case(args.case, list(args.overrides))
        sim = simulation_for(case)
        states = light_history(sim.run(), fields_of=lambda s: s.max_pressure)
    except SacflowError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    top = int(np.argmax([s.max_pressure for s in states]))
    pressure = np.asarray(states[top].surface["pressure"], dtype=float)
    x1, x2 = sim.coords.x1, sim.coords.x2
    along, profile = row_profile(pressure, x1, x2, (states[top].load_x1, states[top].load_x2))
    cells = args.cells or int(np.count_nonzero(profile > 0.0))
    peak = np.unravel_index(int(np.argmax(pressure)), pressure.shape)
    print(json.dumps({
        "case": str(args.case), "overrides": list(args.overrides), "step": top,
        "peak_pressure_GPa": float(pressure[peak]) / GPA,
        "peak_cell_x1_um": float(x1[peak[0]]) * 1e6, "peak_cell_x2_um": float(x2[peak[1]]) * 1e6,
        "x1_um": [round(float(x) * 1e6, 4) for x in along[:cells]],
        "pressure_GPa": [round(float(p) / GPA, 4) for p in profile[:cells]],
    }))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
