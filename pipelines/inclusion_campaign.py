"""The inclusion campaign, end to end: runs, fatigue stage, table and plot (issue #33).

    python pipelines/inclusion_campaign.py --out runs/inclusion [--workers N]
                                           [--scheduler ADDRESS] [--set KEY=VALUE ...]

1. runs ``configs/campaign-inclusion.toml`` (inclusion-hertz over the inclusion's depth x its
   modulus ratio) into ``--out`` with dask; finished cases are not run again;
2. runs the fatigue stage on every finished run (``<out>/fatigue/<case>-fatigue.nc`` and
   ``.png``; kept when still valid for the same run);
3. writes ``<out>/campaign-inclusion-summary.csv`` (one row per case: depth / a, E_i / E, the
   largest Dang Van and Crossland indices and where, the largest equivalent plastic strain, the
   peak pressure, the Krylov iterations) and ``<out>/campaign-inclusion-index-vs-depth.png``:
   the largest Dang Van index against the inclusion's depth over the contact radius, one line
   per modulus ratio (E_i / E = 1 is the homogeneous body: its line is flat).

``--set`` changes the base case (``--set grid.nx=96 --set grid.ny=96`` for a finer grid).
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
import time
from pathlib import Path
from typing import Any

import xarray as xr

from sacflow.campaign import load_campaign, run_campaign
from sacflow.compare.core import case_of
from sacflow.errors import SacflowError
from sacflow.storage.atomic_file import write_atomically
from sacflow.storage.run_reader import open_run
from sacflow.studies.dent_study import fatigue_results

HERE = Path(__file__).resolve().parent
CAMPAIGN = HERE.parent / "configs" / "campaign-inclusion.toml"
STEM = "campaign-inclusion"
#: Columns of the summary table, in order.
COLUMNS = ("case", "depth_over_a", "modulus_ratio", "inclusion_E", "inclusion_nu",
           "dang_van_max", "dang_van_max_depth_over_a", "crossland_max",
           "max_plastic_strain", "peak_pressure", "inclusion_iterations_total")


def main(argv: list[str] | None = None) -> int:
    """Run the campaign, the fatigue stage and the summary; 0 on success, 2 on an error."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("runs/inclusion"))
    parser.add_argument("--workers", type=int)
    parser.add_argument("--scheduler")
    parser.add_argument("--set", dest="overrides", action="append", default=[],
                        metavar="KEY=VALUE")
    parser.add_argument("--no-progress", action="store_true")
    args = parser.parse_args(argv)
    try:
        return _study(args)
    except SacflowError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


def _study(args: argparse.Namespace) -> int:
    progress = not args.no_progress
    start = time.perf_counter()
    outcome = run_campaign(load_campaign(CAMPAIGN, args.overrides), args.out,
                           workers=args.workers, scheduler=args.scheduler, progress=progress)
    print(outcome.table())
    if outcome.failed:
        print(f"{len(outcome.failed)} case(s) failed; the summary leaves them out",
              file=sys.stderr)
    runs = time.perf_counter()
    fatigue_dir = args.out / "fatigue"
    results = fatigue_results(outcome.manifest, fatigue_dir, progress=progress)
    stage = time.perf_counter()
    rows = [summary_row(record, args.out, results[record["name"]])
            for record in finished_cases(outcome.manifest) if record["name"] in results]
    table = write_table(rows, args.out / f"{STEM}-summary.csv")
    figure = plot_index_vs_depth(rows)
    write_atomically(args.out / f"{STEM}-index-vs-depth.png",
                     lambda tmp: figure.savefig(tmp, dpi=120))
    for row in rows:
        print("  ".join(f"{key}={_short(row[key])}" for key in COLUMNS))
    end = time.perf_counter()
    print(f"campaign {runs - start:.0f} s, fatigue stage {stage - runs:.0f} s, summary "
          f"{end - stage:.0f} s -> {table}")
    return 0


def finished_cases(manifest: Path) -> list[dict[str, Any]]:
    """The manifest records of the finished cases, in campaign order."""
    records = json.loads(Path(manifest).read_text())["cases"]
    return [r for r in records if r.get("status") in ("done", "skipped")]


def summary_row(record: dict[str, Any], out: Path, fatigue_path: Path) -> dict[str, Any]:
    """One line of the summary: the case's inclusion, its fatigue maxima, its run's extremes."""
    run = open_run(out / record["path"])
    case = case_of(run)
    item = case.body.inhomogeneity[0]
    assert item.centre is not None  # a sphere
    a = case.hertz().a  # Hertz contact radius at the largest load
    with xr.open_dataset(fatigue_path) as index:
        dang_van = float(index["dang_van_max"])
        dang_van_depth = float(index["dang_van_max_depth"])
        crossland = float(index["crossland_max"])
    plastic = run.get("equivalent_plastic_strain")
    iterations = run.get("inclusion_iterations")
    return {
        "case": record["name"],
        "depth_over_a": item.centre[2] / a,
        "modulus_ratio": item.E / case.body.E,
        "inclusion_E": item.E,
        "inclusion_nu": item.nu,
        "dang_van_max": dang_van,
        "dang_van_max_depth_over_a": dang_van_depth / a,
        "crossland_max": crossland,
        "max_plastic_strain": float(plastic.max()) if plastic is not None else 0.0,
        "peak_pressure": float(run["max_pressure"].max()),
        "inclusion_iterations_total": int(iterations.sum()) if iterations is not None else 0,
    }


def _short(value: Any) -> str:
    return f"{value:.4g}" if isinstance(value, float) else str(value)


def write_table(rows: list[dict[str, Any]], path: Path) -> Path:
    """Write the summary rows as CSV (a temporary file moved onto ``path``)."""
    def write(tmp: Path) -> None:
        with tmp.open("w", newline="", encoding="utf-8") as f:
            writer = csv.DictWriter(f, fieldnames=COLUMNS)
            writer.writeheader()
            writer.writerows(rows)

    return write_atomically(path, write)


def plot_index_vs_depth(rows: list[dict[str, Any]]):
    """The largest Dang Van index against depth / a, one line per modulus ratio."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(6.0, 4.0))
    for ratio in sorted({row["modulus_ratio"] for row in rows}):
        line = sorted((row["depth_over_a"], row["dang_van_max"]) for row in rows
                      if row["modulus_ratio"] == ratio)
        depth, index = zip(*line, strict=True)
        axes.plot(depth, index, marker="o", label=f"$E_i/E$ = {ratio:.3g}")
    axes.axvline(0.48, color="0.6", linestyle=":", label="largest shear (0.48 a)")
    axes.set_xlabel("inclusion depth / contact radius a")
    axes.set_ylabel("largest Dang Van index")
    axes.set_title("Inclusion under a Hertz contact: fatigue index against depth")
    axes.legend()
    figure.tight_layout()
    return figure


if __name__ == "__main__":
    sys.exit(main())
