"""The press's contact edge inside its cell: what its position alone does to the results.

``python pipelines/press_edge_position.py [--runs NX:W ...] [--layers N]
[--increments LOAD UNLOAD] [--subcells S] [--table CSV [--overwrite]]``

At 600 N the indentation press (``pipelines/dent-from-indentation-press.toml``) is fully plastic:
its contact pressure stays near 8 GPa up to the contact edge and drops to zero within one
surface cell. The solver's pressure is uniform over each cell, so where the edge falls inside
its cell is a discretisation parameter of its own, and refining the cells moves it along with
the cell size. This script separates the two: it runs the press on nx² cells and a fixed number
of layers over its box (the study's box depth), for several lateral windows ``grid.half_width``
(in Hertz radii). Each window changes the cell size by a few per cent, little enough for the
smooth part of the grid error to move little, while the edge crosses its cell; a wider window
at the same cell size (more cells) is the control for the window itself. It prints, and
writes to ``--table``, per window: the cell size, the contact radius at the peak load and the
edge's position in its cell, and the convergence study's quantities
(:func:`sacflow.studies.convergence.measure`). It runs the press as its tables were recorded,
with the residual stress's surface traction beyond the box left out (the press ships with it
removed since; ``WITHOUT_FAR_TRACTION``), so that the window changes only the edge's cell.
``--subcells S`` solves the contact on S × S sub-cells of each surface cell
(``solver.contact_subcells``, :mod:`sacflow.solver.subcell_contact`): the same windows then
show what is left once the edge is resolved to a sub-cell.

The contact radius is read on the cell row nearest the axis: the outermost loaded cell carries
a share of the pressure of the cell inside it, and the edge is put that share of a cell beyond
the inner face of that cell. The edge's position in its cell is that radius over the cell size,
modulo 1 (the axis lies on a cell corner, so the cell faces are at whole multiples of the cell
size): 0 at the inner face, 1 at the outer one.
"""

from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np

from sacflow.config.case import Case
from sacflow.config.solver_inputs import simulation_for
from sacflow.errors import SacflowError
from sacflow.solver.history import light_history
from sacflow.solver.state import State
from sacflow.studies.convergence import (
    STUDY_CASES,
    WITHOUT_FAR_TRACTION,
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
#: Default runs (cells per side, window in Hertz radii): at 48² cells the windows 3 to 3.35 a
#: move the edge through more than one cell; 50² and 52² keep the 48² cell of the 3 a window
#: and widen the window alone.
DEFAULT_RUNS = (*((48, w) for w in (3.0, 3.035, 3.07, 3.105, 3.15, 3.2, 3.25, 3.3, 3.35)),
                (50, 3.125), (52, 3.25))
#: Quantities printed on each line (all of :func:`measure`'s go to the table).
SHOWN = ("print_depth_refined", "peak_pressure", "max_plastic_strain_refined",
         "residual_s11_axis_refined_at_0.25a", "residual_s11_axis_refined_at_0.5a",
         "residual_s11_axis_refined_at_1a", "residual_s11_axis_refined_at_1.5a")


def contact_edge(state: State, x1: np.ndarray, x2: np.ndarray) -> float:
    """Contact radius [m] at ``state`` read on the cell row nearest the axis (module doc)."""
    pressure = np.asarray(state.surface["pressure"], dtype=float)
    row = pressure[:, int(np.argmin(np.abs(x2 - state.load_x2)))]
    r = x1 - state.load_x1
    loaded = np.flatnonzero((row > 0.0) & (r > 0.0))
    if loaded.size < 2:
        return math.nan
    edge = int(loaded[-1])
    h = float(x1[1] - x1[0])
    share = min(row[edge] / row[edge - 1], 1.0)
    return float(r[edge] - 0.5 * h + share * h)


def case_for(nx: int, layers: int, increments: tuple[int, int], half_width: float,
             subcells: int = 1) -> Case:
    """Return the press on nx² cells and ``layers`` over the study's box, in one window.

    ``subcells`` > 1 solves its contact on that many sub-cells per cell and axis.
    """
    depth = shipped_discretisation(base_case(CASE)).depth
    return base_case(CASE, [f"grid.nx={nx}", f"grid.ny={nx}", f"grid.nz={layers}",
                            f"grid.depth={depth!r}", f"grid.half_width={half_width!r}",
                            f"load_path.0.increments={increments[0]}",
                            f"load_path.1.increments={increments[1]}",
                            f"output.volume_every={sum(increments)}", WITHOUT_FAR_TRACTION,
                            WITHOUT_SUBCELLS if subcells == 1 else
                            f"solver.contact_subcells={subcells}"])


def run_window(case: Case) -> dict[str, float]:
    """Run the press ``case`` (:func:`case_for`) and return its row of the table."""
    nx = case.grid.nx
    start = time.perf_counter()
    sim = simulation_for(case)
    states = light_history(sim.run(), fields_of=lambda s: s.load)
    quantities, _ = measure(sim, states, case.hertz().a)
    x1, x2 = sim.coords.x1, sim.coords.x2
    h = float(x1[1] - x1[0])
    radius = contact_edge(max(states, key=lambda s: s.load), x1, x2)
    return {"nx": nx, "layers": case.grid.nz, "half_width": case.grid.half_width,
            "subcells": case.solver.contact_subcells, "cell": h,
            "contact_radius": radius, "edge_in_cell": radius / h % 1.0,
            "seconds": time.perf_counter() - start, **quantities}


def run_spec(text: str) -> tuple[int, float]:
    """Parse ``NX:W`` (cells per side, window half-width in Hertz radii)."""
    try:
        nx, width = text.split(":")
        return int(nx), float(width)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected NX:W such as 48:3.0, got {text!r}") from None


def parse(argv: list[str]) -> argparse.Namespace:
    """Parse the command line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=run_spec, nargs="+", default=DEFAULT_RUNS,
                        metavar="NX:W", help="cells per side and window in Hertz radii, "
                        "e.g. 96:3.0 96:3.03 (default: the 48² sweep and its controls)")
    parser.add_argument("--layers", type=int, default=64, help="layers over the box (64)")
    parser.add_argument("--increments", type=int, nargs=2, default=(20, 6),
                        metavar=("LOAD", "UNLOAD"), help="load and unload increments (20 6)")
    parser.add_argument("--subcells", type=int, default=1, metavar="S",
                        help="contact sub-cells per surface cell and axis (1: the cells)")
    add_table_arguments(parser)
    return parser.parse_args(argv)


def main(argv: list[str]) -> None:
    """Run each window, print its line, write the table."""
    args = parse(argv)
    refuse_existing_table(args.table, args.overwrite)
    try:  # every run's case first: a grid or window the press cannot run stops before any
        cases = [case_for(nx, args.layers, tuple(args.increments), width, args.subcells)
                 for nx, width in args.runs]
    except SacflowError as exc:
        raise SystemExit(f"error: {exc}") from None
    rows = []
    for (nx, width), case in zip(args.runs, cases, strict=True):
        row = run_window(case)
        rows.append(row)
        shown = ", ".join(f"{name} {row[name]:.6g}" for name in SHOWN)
        print(f"{nx}² × {args.layers}, half width {width:g} a: cell "
              f"{row['cell'] * 1e6:.3f} µm, contact radius {row['contact_radius'] * 1e6:.1f} µm, "
              f"edge at {row['edge_in_cell']:.2f} of its cell, {row['seconds']:.0f} s; {shown}",
              flush=True)
    write_runs_table(args.table, rows, args.overwrite)


if __name__ == "__main__":
    main(sys.argv[1:])
