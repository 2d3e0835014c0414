"""The press's contact pressure at its peak load on sub-cells: where its peak sits, and the gap.

``python pipelines/press_pressure_profile.py [--runs NX ...] [--layers N]
[--increments LOAD UNLOAD] [--table CSV] [--profiles CSV] [--overwrite]``

Runs the press of the indentation-made dent (``pipelines/dent-from-indentation-press.toml``,
its contact on 2 × 2 sub-cells) at the convergence study's ``together`` levels: nx² cells,
4 nx / 3 layers over the study's box, (20 + 6) · nx / 48 increments, the traction beyond the
box left out as in that study. At the step of the largest load it measures
(:func:`sacflow.studies.pressure_profile.pressure_profile`): the largest cell pressure and the
radius of its cell against the contact's radius; the radial profile on the cells and on the
sub-cells; and the step's contact solved again on the sub-cells with the residual surface
displacement carried to them by the solver's bicubic splines and by the cells' plastic
strain's own displacement at the sub-cells (Chiu's cuboids), with the oscillation of each
pressure from sub-cell to sub-cell. ``--table`` gets one row per run, ``--profiles`` the
radial profiles (source, r, pressure).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from sacflow.config.case import Case
from sacflow.config.solver_inputs import simulation_for
from sacflow.errors import SacflowError
from sacflow.studies.convergence import (
    STUDY_CASES,
    WITHOUT_FAR_TRACTION,
    base_case,
    shipped_discretisation,
)
from sacflow.studies.convergence_table import (
    add_table_arguments,
    refuse_existing_table,
    write_csv,
)
from sacflow.studies.pressure_profile import pressure_profile

CASE = STUDY_CASES["dent-from-indentation-press"]
#: Cells per side of the ``together`` sequence's coarsest level, and its layers and increments.
BASE_CELLS, BASE_LAYERS, BASE_INCREMENTS = 48, 64, (20, 6)


def case_for(nx: int, layers: int | None = None,
             increments: tuple[int, int] | None = None) -> Case:
    """Return the press at the ``together`` level of nx² cells (module doc).

    ``layers`` and ``increments`` replace the level's own (a quicker look).
    """
    depth = shipped_discretisation(base_case(CASE)).depth
    scale = nx / BASE_CELLS
    load, unload = (increments if increments is not None
                    else tuple(round(n * scale) for n in BASE_INCREMENTS))
    layers = layers if layers is not None else round(BASE_LAYERS * scale)
    return base_case(CASE, [f"grid.nx={nx}", f"grid.ny={nx}",
                            f"grid.nz={layers}", f"grid.depth={depth!r}",
                            f"load_path.0.increments={load}",
                            f"load_path.1.increments={unload}", WITHOUT_FAR_TRACTION])


def parse(argv: list[str]) -> argparse.Namespace:
    """Parse the command line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, nargs="+", default=(48, 72), metavar="NX",
                        help="cells per side, a multiple of 12 from 24 (default: 48 72)")
    parser.add_argument("--layers", type=int, help="layers (default: 4 nx / 3)")
    parser.add_argument("--increments", type=int, nargs=2, metavar=("LOAD", "UNLOAD"),
                        help="load and unload increments (default: (20 + 6) nx / 48)")
    parser.add_argument("--profiles", type=Path, help="CSV of the radial profiles")
    add_table_arguments(parser)
    args = parser.parse_args(argv)
    if any(nx < 24 or nx % 12 for nx in args.runs):
        parser.error("--runs: cells per side must be multiples of 12 from 24 (24 48 72 96 ...)")
    return args


def main(argv: list[str]) -> None:
    """Run each level, print its line, write the tables."""
    args = parse(argv)
    refuse_existing_table(args.table, args.overwrite)
    refuse_existing_table(args.profiles, args.overwrite)
    try:
        cases = [case_for(nx, args.layers,
                          None if args.increments is None else tuple(args.increments))
                 for nx in args.runs]
    except SacflowError as exc:
        raise SystemExit(f"error: {exc}") from None
    rows, profiles = [], []
    for nx, case in zip(args.runs, cases, strict=True):
        start = time.perf_counter()
        try:
            summary, profile = pressure_profile(simulation_for(case))
        except SacflowError as exc:  # e.g. a step that does not converge: its message, no table
            raise SystemExit(f"error: {nx}² × {case.grid.nz}: {exc}") from None
        row = {"nx": nx, "layers": case.grid.nz, **summary,
               "seconds": time.perf_counter() - start}
        rows.append(row)
        profiles += [{"nx": nx, **point} for point in profile]
        print(f"{nx}² × {case.grid.nz}: peak pressure {row['peak_pressure'] / 1e9:.4f} GPa at "
              f"{row['peak_radius'] / row['contact_radius']:.2f} of the contact radius "
              f"({row['contact_radius'] * 1e6:.1f} µm); splines − cuboids up to "
              f"{row['splines_minus_cuboids_max'] * 1e9:.1f} nm; sub-cell oscillation "
              f"{row['sawtooth_splines'] / 1e6:.0f} MPa on the splines, "
              f"{row['sawtooth_cuboids'] / 1e6:.0f} MPa on the cuboids; "
              f"{row['seconds']:.0f} s", flush=True)
    try:
        if args.table is not None:
            write_csv(args.table, rows, list(rows[0]), overwrite=args.overwrite)
        if args.profiles is not None:
            write_csv(args.profiles, profiles, list(profiles[0]), overwrite=args.overwrite)
    except SacflowError as exc:  # a table appeared while the runs went on
        raise SystemExit(f"error: {exc}") from None


if __name__ == "__main__":
    main(sys.argv[1:])
