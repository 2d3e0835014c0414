"""Run a case file with overrides at a stress sampling; count the extrema of εp on the axis.

``python pipelines/press_case.py CASE.toml SAMPLING [OVERRIDE ...]``
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from sacflow.config.solver_inputs import solver_inputs
from sacflow.errors import InputError
from sacflow.solver.history import light_history
from sacflow.solver.simulation import Simulation
from sacflow.storage.case_file import load_case


def main(argv: list[str]) -> None:
    """Run and print the largest εp and the number of extrema of its axis profile."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("path", help="case file (TOML)")
    parser.add_argument("sampling", type=int, help="solver.stress_sampling (1 = centre)")
    parser.add_argument("overrides", nargs="*", help="overrides KEY=VALUE")
    args = parser.parse_args(argv)
    sampling, overrides = args.sampling, args.overrides
    try:
        case = load_case(args.path, [*overrides, f"solver.stress_sampling={sampling}"])
    except InputError as exc:
        sys.exit(str(exc))
    start = time.time()
    sim = Simulation(solver_inputs(case))
    states = light_history(sim.run())
    elapsed = time.time() - start
    x1, x3 = sim.coords.x1, sim.coords.x3
    ep = sim.equivalent_plastic_strain
    centre = int(np.argmin(np.abs(x1)))
    axis = ep[centre, centre]
    steps = np.diff(axis[axis > 0.05 * axis.max()])
    extrema = int(np.sum(np.sign(steps[1:]) != np.sign(steps[:-1])))
    converged = all(s.scalars().get("converged", True) for s in states)
    ratio = (x1[1] - x1[0]) / (x3[1] - x3[0])
    print(f"s={sampling} {overrides}: {elapsed:.1f} s, dx/dz {ratio:.2f}, "
          f"max ep {ep.max() * 100:.3f} %, axis extrema {extrema}, converged {converged}")
    print("  ep axis %", np.round(axis[:16] * 100, 3))


if __name__ == "__main__":
    main(sys.argv[1:])
