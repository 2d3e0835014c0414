"""Which half of the press's load carries the error of its load increments.

``python pipelines/press_load_phases.py [--grid NX NZ] [--increments N] [--factor K]
[--table CSV [--overwrite]]``

The press (``pipelines/dent-from-indentation-press.toml``, as it ships: cell-averaged stresses,
the traction beyond the box removed; its contact on the surface cells, as the table was
recorded before the press moved to sub-cells, ``WITHOUT_SUBCELLS``) is loaded in two halves,
to P/2 and then to P, each in equal increments. Four schedules on NX² × NZ cells over the
study's box depth:

* ``uniform``: N/2 + N/2 increments (the same steps as N equal ones);
* ``early``: the first half refined K times, K·N/2 + N/2;
* ``late``: the second half refined K times, N/2 + K·N/2;
* ``reference``: both refined, K·N/2 + K·N/2.

The error of an increment integration (second order, ``docs/convergence.md``) is the sum of
what each half contributes, and refining a half K times divides its part by about K². So
``early`` − ``reference`` is the second half's part of the error at N increments, ``late`` −
``reference`` the first half's, and ``uniform`` − ``reference`` about their sum. A quantity whose
two parts have opposite signs converges faster under uniform refinement than either part would
suggest; one whose error sits in one half is the one a schedule refined there serves. The
unloading keeps the config's increments: the schedules differ in the loading only.

It prints each schedule's quantities (:func:`sacflow.studies.convergence.measure`) and writes
them to ``--table`` (refused if the file exists, unless ``--overwrite``).
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any

from sacflow.config.case import Case
from sacflow.config.solver_inputs import simulation_for
from sacflow.errors import SacflowError
from sacflow.solver.history import light_history
from sacflow.studies.convergence import (
    STUDY_CASES,
    WITHOUT_SUBCELLS,
    base_case,
    measure,
    shipped_discretisation,
)
from sacflow.studies.convergence_table import (
    add_table_arguments,
    refuse_existing_table,
    write_runs_table,
)

CASE = STUDY_CASES["dent-from-indentation-press"]
#: The schedules: name -> whether the first and the second half of the load are refined.
SCHEDULES = {"uniform": (False, False), "early": (True, False), "late": (False, True),
             "reference": (True, True)}
#: Quantities printed on each line (all of :func:`measure`'s go to the table).
SHOWN = ("print_depth_refined", "peak_pressure", "max_plastic_strain_refined",
         "residual_s11_axis_min_refined", "residual_s11_axis_refined_at_0.25a",
         "residual_s11_axis_refined_at_0.5a", "residual_s11_axis_refined_at_1a")


def load_path(load: float, halves: tuple[int, int], unload: int) -> list[dict[str, Any]]:
    """The press's load path: to ``load``/2 in ``halves[0]`` increments, to ``load`` in
    ``halves[1]``, then unloaded in ``unload`` increments."""
    return [{"kind": "load", "to": load / 2.0, "increments": halves[0]},
            {"kind": "load", "to": load, "increments": halves[1]},
            {"kind": "unload", "to": 0.0, "increments": unload}]


def case_for(schedule: str, nx: int, nz: int, increments: int, factor: int) -> Case:
    """The press on nx² × nz cells over the study's box with the load path of ``schedule``."""
    if increments < 2 or increments % 2:
        raise SacflowError(f"--increments: an even number of load increments (2 or more) is "
                           f"needed, one half per half of the load; got {increments}")
    if factor < 2:
        raise SacflowError(f"--factor: a refinement of 2 or more is needed; got {factor}")
    depth = shipped_discretisation(base_case(CASE)).depth
    press = base_case(CASE, [f"grid.nx={nx}", f"grid.ny={nx}", f"grid.nz={nz}",
                             f"grid.depth={depth!r}", WITHOUT_SUBCELLS])
    early, late = SCHEDULES[schedule]
    half = increments // 2
    halves = (half * factor if early else half, half * factor if late else half)
    data = press.model_dump()
    data["load_path"] = load_path(press.load_path[0].to, halves, press.load_path[-1].increments)
    data["output"]["volume_every"] = sum(halves) + press.load_path[-1].increments
    return Case.model_validate(data)


def run_schedule(schedule: str, case: Case) -> dict[str, Any]:
    """Run ``case`` and return its row of the table."""
    start = time.perf_counter()
    sim = simulation_for(case)
    states = light_history(sim.run())
    quantities, _ = measure(sim, states, case.hertz().a)
    load_increments = tuple(seg.increments for seg in case.load_path[:2])
    return {"schedule": schedule, "nx": case.grid.nx, "nz": case.grid.nz,
            "first_half": load_increments[0], "second_half": load_increments[1],
            "seconds": time.perf_counter() - start, **quantities}


def parse(argv: list[str]) -> argparse.Namespace:
    """Parse the command line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grid", type=int, nargs=2, default=(48, 64), metavar=("NX", "NZ"),
                        help="cells per side and layers (48 64)")
    parser.add_argument("--increments", type=int, default=20,
                        help="load increments of the uniform schedule, even (20)")
    parser.add_argument("--factor", type=int, default=4,
                        help="refinement of a refined half (4)")
    add_table_arguments(parser)
    return parser.parse_args(argv)


def main(argv: list[str]) -> None:
    """Run the four schedules, print their lines, write the table."""
    args = parse(argv)
    refuse_existing_table(args.table, args.overwrite)
    try:  # every case first: a grid or schedule the press cannot run stops before any
        cases = {name: case_for(name, *args.grid, args.increments, args.factor)
                 for name in SCHEDULES}
    except SacflowError as exc:
        raise SystemExit(f"error: {exc}") from None
    rows = []
    for name, case in cases.items():
        row = run_schedule(name, case)
        rows.append(row)
        shown = ", ".join(f"{q} {row[q]:.6g}" for q in SHOWN)
        print(f"{name} ({row['first_half']} + {row['second_half']}): {row['seconds']:.0f} s, "
              f"{shown}", flush=True)
    if args.table is not None:
        write_runs_table(args.table, rows, args.overwrite)
        print(f"table: {args.table}")


if __name__ == "__main__":
    main(sys.argv[1:])
