"""The contact's edge within its cells: a case run at many lateral cell counts (issue #32).

    python pipelines/contact_edge_scan.py CASE.toml --nx 120,122,...,136 [KEY=VALUE ...] \
        [--table data/FILE.csv] [--plot FILE.png] [--overwrite]

Runs the case at each count of surface cells per side (``grid.nx`` = ``grid.ny``; everything
else as the case and the overrides give it) and records, at the step of the largest load, the
approach, the peak pressure, the loaded cells of the row nearest the axis on the side x1 > 0
(``edge_cells``: the contact radius in cells) and where the edge of the Hertz contact falls
in its cell, ``edge_phase`` = a / Δx less its nearest whole number, with a the Hertz contact
radius of the case: 0 when that edge lies on a cell boundary, ±0.5 when it lies on a cell's
centre (the axis lies on a cell corner with an even number of cells). The contact's own
radius, which a plastic body widens beyond Hertz's, is that of the circle with the contact's
area (the loaded cells', or with the contact on sub-cells the loaded sub-cells'),
``contact_radius`` = (A / π)^½, and ``contact_phase`` is where its edge falls in its cell, as
``edge_phase``. For an elastic case the approach is compared with Hertz's
δ = a²/R (``approach_error``).

Refining the cells by a factor of two keeps the edge's phase when a / Δx is a whole number;
refining by 1.5 need not. docs/convergence.md reads from such scans that the elastic
approach's error follows that phase, not a power of the cell size (and vanishes with the
contact on sub-cells, whose edge then keeps its phase), and how large the same zigzag is in
the nano-indentations, where it keeps some refinement sequences from converging.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from sacflow.errors import SacflowError
from sacflow.studies.convergence_table import refuse_existing_table, write_outputs

#: The table's columns (SI units; ``edge_cells``, ``edge_phase`` and ``contact_phase`` in
#: cells).
COLUMNS = ("case", "nx", "cell", "hertz_radius", "edge_cells", "edge_phase", "contact_radius",
           "contact_phase", "approach", "approach_error", "peak_pressure", "elapsed")


def parse(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("case", type=Path, help="a case file (TOML)")
    parser.add_argument("overrides", nargs="*", help="KEY=VALUE overrides, as sacflow run --set")
    parser.add_argument("--nx", required=True,
                        help="comma-separated surface cells per side, e.g. 120,122,124")
    parser.add_argument("--table", type=Path, help="write the scan here (CSV)")
    parser.add_argument("--plot", type=Path, help="draw the approach against the cells (PNG)")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing table")
    return parser.parse_args(argv)


def cell_counts(text: str) -> list[int]:
    """Parse ``--nx``: positive whole numbers, or a message naming the bad entry."""
    counts = []
    for part in text.split(","):
        try:
            n = int(part)
        except ValueError:
            raise SacflowError(f"--nx: {part!r} is not a whole number of cells; give e.g. "
                               f"--nx 120,122,124") from None
        if n < 4:
            raise SacflowError(f"--nx: {n} cells per side is too few; give 4 or more")
        counts.append(n)
    return counts


def scan_one(path: Path, overrides: list[str], nx: int) -> dict[str, Any]:
    """Run the case at ``nx`` × ``nx`` surface cells and return its row of :data:`COLUMNS`."""
    from sacflow.config.solver_inputs import simulation_for
    from sacflow.solver.history import light_history
    from sacflow.storage.case_file import load_case
    from sacflow.studies.pressure_profile import row_profile

    case = load_case(path, [*overrides, f"grid.nx={nx}", f"grid.ny={nx}"])
    start = time.perf_counter()
    sim = simulation_for(case)
    states = light_history(sim.run(), fields_of=lambda s: s.load)
    elapsed = time.perf_counter() - start
    top = int(np.argmax([s.load for s in states]))
    pressure = np.asarray(states[top].surface["pressure"], dtype=float)
    x1, x2 = sim.coords.x1, sim.coords.x2
    _, profile = row_profile(pressure, x1, x2, (states[top].load_x1, states[top].load_x2))
    cell = float(x1[1] - x1[0])
    hertz = case.hertz()
    loaded = int(np.count_nonzero(profile > 0.0))
    radius = math.sqrt(float(states[top].contact_area) / math.pi)
    approach = float(states[top].approach)
    elastic = case.body.hardening.law == "elastic"
    exact = hertz.approach if elastic else math.nan
    return {"case": case.name, "nx": nx, "cell": cell, "hertz_radius": hertz.a,
            "edge_cells": loaded, "edge_phase": hertz.a / cell - round(hertz.a / cell),
            "contact_radius": radius, "contact_phase": radius / cell - round(radius / cell),
            "approach": approach,
            "approach_error": (approach - exact) / exact if elastic else math.nan,
            "peak_pressure": float(states[top].max_pressure), "elapsed": elapsed}


def plot(rows: list[dict[str, Any]]) -> Any:
    """The approach against the cells per side, each point coloured by the edge's phase."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.4, 4.0), layout="constrained")
    ax = fig.subplots()
    nx = [r["nx"] for r in rows]
    elastic = all(math.isfinite(r["approach_error"]) for r in rows)
    y = [100 * r["approach_error"] if elastic else 1e9 * r["approach"] for r in rows]
    ax.plot(nx, y, color="0.7", lw=0.8)
    points = ax.scatter(nx, y, c=[r["edge_phase"] for r in rows], cmap="twilight", vmin=-0.5,
                        vmax=0.5, zorder=3)
    fig.colorbar(points, ax=ax, label="Hertz radius / cell, less its nearest whole number")
    ax.set_xlabel("surface cells per side")
    ax.set_ylabel("approach error against Hertz [%]" if elastic else "approach [nm]")
    ax.set_title(rows[0]["case"], fontsize="small")
    ax.grid(True, alpha=0.3)
    return fig


def main(argv: list[str] | None = None) -> int:
    args = parse(argv)
    for path in (args.table, args.plot):  # before any run: a user's file is not replaced
        refuse_existing_table(path, args.overwrite)
    try:
        counts = cell_counts(args.nx)
        rows = []
        for nx in counts:
            row = scan_one(args.case, list(args.overrides), nx)
            print(f"nx {nx:4d}: approach {1e9 * row['approach']:.6f} nm, edge "
                  f"{row['edge_cells']} cells, phase {row['edge_phase']:.3f}, "
                  f"{row['elapsed']:.1f} s", flush=True)
            rows.append(row)
        write_outputs(args.table, rows, COLUMNS, args.plot, lambda: plot(rows), args.overwrite)
    except SacflowError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
