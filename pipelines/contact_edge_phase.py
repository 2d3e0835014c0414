"""Which contact edge a scan's zigzag follows: Hertz's, or the contact's own (issue #32).

    python pipelines/contact_edge_phase.py data/contact-edge-650-radius.csv [more scans] \
        [--nx-range 120,136] [--table data/FILE.csv] [--plot FILE.png] [--overwrite]

Reads scans of ``pipelines/contact_edge_scan.py`` (one case each, with its ``contact_phase``)
and fits each one's approach at the largest load over the counts in ``--nx-range`` with a line
in the count plus one period of an edge's phase (:func:`sacflow.studies.edge_phase.phase_fit`),
once with the phase of the Hertz contact's edge (``edge_phase``) and once with that of the
contact's own edge (``contact_phase``, the circle of the loaded cells' area). It runs nothing.
The phase that explains the zigzag is the edge the zigzag comes from.
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path
from typing import Any

import numpy as np

from sacflow.errors import SacflowError
from sacflow.studies.convergence_table import refuse_existing_table, write_outputs
from sacflow.studies.edge_phase import MIN_COUNTS, PhaseFit, phase_fit

#: The phases a scan is fitted with: its column -> the edge it places.
PHASES = {"edge_phase": "hertz", "contact_phase": "contact"}
#: The columns of a scan this script reads.
SCAN_COLUMNS = ("case", "nx", "approach", *PHASES)
#: One row per scan and phase of ``--table`` (lengths in metres, phases in cells).
COLUMNS = ("case", "edge", "counts", "slope", "amplitude", "peak_phase", "spread", "residual",
           "explained")


def parse(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scans", type=Path, nargs="+", help="tables of contact_edge_scan.py")
    parser.add_argument("--nx-range", default="120,136",
                        help="the smallest and largest cells per side fitted (default 120,136)")
    parser.add_argument("--table", type=Path, help="write the fits here (CSV)")
    parser.add_argument("--plot", type=Path, help="draw each scan against both phases (PNG)")
    parser.add_argument("--overwrite", action="store_true", help="replace existing files")
    return parser.parse_args(argv)


def count_range(text: str) -> tuple[int, int]:
    """Parse ``--nx-range``: two whole numbers, the smaller first."""
    try:
        low, high = (int(part) for part in text.split(","))
    except ValueError:
        raise SacflowError(f"--nx-range: {text!r} is not two whole numbers; give e.g. "
                           f"--nx-range 120,136") from None
    if low >= high:
        raise SacflowError(f"--nx-range: {low} is not below {high}; give the smaller first")
    return low, high


def read_scan(path: Path, counts: tuple[int, int]) -> dict[str, np.ndarray]:
    """One scan's rows within ``counts``: its cells per side, approach and both phases."""
    if not path.is_file():
        raise SacflowError(f"no scan {path}: give a --table of pipelines/contact_edge_scan.py")
    with path.open(newline="", encoding="utf-8") as f:
        reader = csv.DictReader(f)
        missing = [c for c in SCAN_COLUMNS if c not in (reader.fieldnames or ())]
        if missing:
            raise SacflowError(f"{path} lacks the column(s) {', '.join(missing)}: scan it "
                               f"again with pipelines/contact_edge_scan.py")
        rows = [r for r in reader if counts[0] <= int(r["nx"]) <= counts[1]]
    cases = {r["case"] for r in rows}
    if len(cases) != 1:
        raise SacflowError(f"{path}: {len(cases)} cases within --nx-range {counts[0]},"
                           f"{counts[1]}; a scan is one case with counts in that range")
    if len(rows) < MIN_COUNTS:
        raise SacflowError(f"{path}: {len(rows)} counts within --nx-range {counts[0]},"
                           f"{counts[1]}; a phase fit needs {MIN_COUNTS} or more: widen it")
    out = {name: np.array([float(r[name]) for r in rows])
           for name in ("nx", "approach", *PHASES)}
    return {"case": np.array(cases.pop()), **out}


def fits(scan: dict[str, np.ndarray]) -> dict[str, PhaseFit]:
    """The scan's approach fitted with each edge's phase (:data:`PHASES`)."""
    return {edge: phase_fit(scan["nx"], scan["approach"], scan[column])
            for column, edge in PHASES.items()}


def plot(scans: list[dict[str, np.ndarray]]) -> Any:
    """Per scan, the approach less its line in the count against each edge's phase."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.4, 2.6 * len(scans)), layout="constrained")
    axes = fig.subplots(len(scans), len(PHASES), squeeze=False, sharey="row")
    for row, scan in zip(axes, scans, strict=True):
        fitted = fits(scan)
        line = np.polyfit(scan["nx"], scan["approach"], 1)
        rest = 1e9 * (scan["approach"] - np.polyval(line, scan["nx"]))
        for ax, (column, edge) in zip(row, PHASES.items(), strict=True):
            ax.scatter(scan[column], rest, c=scan["nx"], cmap="viridis", zorder=3)
            ax.set_title(f"{scan['case']}\nthe {edge} edge's phase explains "
                         f"{100 * fitted[edge].explained:.0f} %", fontsize="small")
            ax.set_xlim(-0.5, 0.5)
            ax.set_xlabel(f"{edge} edge's phase [cells]")
            ax.grid(True, alpha=0.3)
        row[0].set_ylabel("approach less its line [nm]")
    fig.suptitle("colour: cells per side, dark to light as they grow", fontsize="small")
    return fig


def main(argv: list[str] | None = None) -> int:
    args = parse(argv)
    for path in (args.table, args.plot):  # before anything: a user's file is not replaced
        refuse_existing_table(path, args.overwrite)
    try:
        counts = count_range(args.nx_range)
        scans = [read_scan(path, counts) for path in args.scans]
        rows = []
        for scan in scans:
            for edge, fit in fits(scan).items():
                rows.append({"case": str(scan["case"]), "edge": edge, "counts": scan["nx"].size,
                             "slope": fit.slope, "amplitude": fit.amplitude,
                             "peak_phase": fit.peak_phase, "spread": fit.spread,
                             "residual": fit.residual, "explained": fit.explained})
                print(f"{rows[-1]['case']:28s} {edge:8s} amplitude {1e9 * fit.amplitude:.5f} nm, "
                      f"spread {1e9 * fit.spread:.5f} nm, residual {1e9 * fit.residual:.5f} nm, "
                      f"{100 * fit.explained:.0f} % explained", flush=True)
        write_outputs(args.table, rows, COLUMNS, args.plot, lambda: plot(scans), args.overwrite)
    except SacflowError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
